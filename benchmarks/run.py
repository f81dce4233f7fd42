"""Run every benchmark in ``benchmarks/`` and print one table (``make bench``).

Each ``benchmarks/bench_*.py`` defines ``run() -> dict`` with

``what``
    What was timed, in a few words ("mine a synthetic H3.6M corpus").
``size``
    On how much ("210 sequences, 840,000 frames").
``ratio``
    The measured time divided by the time of the benchmark's own baseline (``np.load`` of
    the same arrays, one pass of scikit-learn's ``precision_score``, ...): a ratio, not
    seconds, so the figure means the same on a laptop and on a CI runner.
``target``
    The largest acceptable ratio, as a number (``1.5``) or as text with a comparison
    (``"<= 1.5"``, ``"< 200"``, ``">= 2"``).

A benchmark that needs an optional package names it in a module constant
``REQUIRES = ("mediapipe",)``; where one is not importable it is listed as ``skipped`` (not
run, not a failure) and ``make bench`` runs it again in the environment that has it.

Optional keys ``baseline`` (what the ratio divides by) and ``seconds`` (the measured time)
are printed when given; ``wall_s`` is the benchmark's whole run, setup and baseline
included. Each benchmark runs in a fresh Python process of its own (its baseline beside it,
in that process): what one leaves behind (a Dask cluster's threads, a large heap for the
garbage collector to walk, caches) cannot slow the next, so a row does not depend on which
ran before it. The table goes to stdout as Markdown, and nothing else does (what a
benchmark prints goes to stderr); a benchmark that raises, or whose process dies, is listed
as ``error`` with its message and does not stop the others. The exit code is 0 once the
table is printed (timings vary between machines; the table is the result), or 1 with
``--strict`` when any benchmark failed its target or raised.

Example::

    python benchmarks/run.py
    python benchmarks/run.py --only miner --strict
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import math
import operator
import re
import subprocess
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from types import ModuleType

BENCH_DIR = Path(__file__).resolve().parent
COLUMNS = (
    "benchmark",
    "what",
    "size",
    "baseline",
    "seconds",
    "ratio",
    "target",
    "result",
    "wall_s",
)

_COMPARISONS: dict[str, Callable[[float, float], bool]] = {
    "<=": operator.le,
    "<": operator.lt,
    ">=": operator.ge,
    ">": operator.gt,
}
_TARGET_RE = re.compile(r"^\s*(<=|>=|<|>)?\s*([-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*x?\s*$")


@dataclass
class Row:
    """One line of the table."""

    benchmark: str
    what: str = ""
    size: str = ""
    baseline: str = ""
    seconds: float = math.nan
    ratio: float = math.nan
    target: str = ""
    result: str = "error"
    wall_s: float = math.nan


def discover(bench_dir: Path = BENCH_DIR, only: Sequence[str] = ()) -> list[Path]:
    """``bench_*.py`` files of ``bench_dir`` in name order, filtered by ``only`` substrings."""
    paths = sorted(bench_dir.glob("bench_*.py"))
    if only:
        paths = [p for p in paths if any(o in p.stem for o in only)]
    return paths


def _load(path: Path) -> ModuleType:
    # Loaded by path, not by import name: benchmarks/ is not a package and must not become one.
    spec = importlib.util.spec_from_file_location(f"turnbench_bench_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {path}")
    module = importlib.util.module_from_spec(spec)
    # Registered before running, as an import would be: dataclasses and pickling look it up.
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _importable(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def parse_target(target: object) -> tuple[Callable[[float, float], bool], float, str]:
    """``1.5`` or ``"<= 1.5"`` -> (comparison, bound, display text); a bare number means ``<=``."""
    if isinstance(target, bool):
        raise ValueError(f"target must be a number or a comparison, got {target!r}")
    if isinstance(target, (int, float)):
        return operator.le, float(target), f"<= {target:g}"
    match = _TARGET_RE.match(str(target))
    if match is None:
        raise ValueError(f"target must be a number or a comparison like '<= 1.5', got {target!r}")
    op = match.group(1) or "<="
    bound = float(match.group(2))
    return _COMPARISONS[op], bound, f"{op} {bound:g}"


def run_one(path: Path) -> Row:
    """:func:`run_here` in a fresh Python process of its own (module docstring): its row comes
    back through a file, so nothing the benchmark or its children print can garble it; its
    stderr is this process's."""
    name = path.stem.removeprefix("bench_")
    start = time.perf_counter()
    # the child's prints go straight to this process's stderr where it is a file (live
    # progress), else (a caller that swapped sys.stderr for an object) through it afterwards
    try:
        sink = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):
        sink = None
    with tempfile.TemporaryDirectory(prefix="turnbench-bench-row-") as tmp:
        out = Path(tmp) / "row.json"
        proc = subprocess.run(
            [sys.executable, str(Path(__file__).resolve()), "--one", str(path), "--row", str(out)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE if sink is None else sink,
            stderr=subprocess.PIPE if sink is None else None,
            text=True,
            check=False,
        )
        if sink is None:
            sys.stderr.write((proc.stdout or "") + (proc.stderr or ""))
        if proc.returncode == 0 and out.is_file():
            return Row(**json.loads(out.read_text(encoding="utf-8")))
    return Row(
        benchmark=name,
        what=f"its process exited with code {proc.returncode} before reporting",
        wall_s=time.perf_counter() - start,
    )


def run_here(path: Path) -> Row:
    """Import one benchmark file, call its ``run()`` and judge the ratio against its target."""
    name = path.stem.removeprefix("bench_")
    row = Row(benchmark=name)
    start = time.perf_counter()
    try:
        # stdout is the table's alone: whatever a benchmark prints goes to stderr
        with contextlib.redirect_stdout(sys.stderr):
            module = _load(path)
            missing = [m for m in getattr(module, "REQUIRES", ()) if not _importable(m)]
            if missing:
                row.what = f"needs {', '.join(missing)} (not installed here)"
                row.result = "skipped"
                row.wall_s = time.perf_counter() - start
                return row
            result = module.run()
        row.wall_s = time.perf_counter() - start
        if not isinstance(result, dict):
            raise TypeError(f"run() returned {type(result).__name__}, expected a dict")
        missing = [k for k in ("what", "size", "ratio", "target") if k not in result]
        if missing:
            raise KeyError(f"run() result lacks {', '.join(missing)}")
        row.what = str(result["what"])
        row.size = str(result["size"])
        row.baseline = str(result.get("baseline", ""))
        row.seconds = float(result.get("seconds", math.nan))
        row.ratio = float(result["ratio"])
        compare, bound, row.target = parse_target(result["target"])
        row.result = "pass" if math.isfinite(row.ratio) and compare(row.ratio, bound) else "FAIL"
    except Exception as exc:  # noqa: BLE001 - one broken benchmark must not hide the others
        row.wall_s = time.perf_counter() - start
        row.what = row.what or f"{type(exc).__name__}: {exc}"
        row.result = "error"
        traceback.print_exc(file=sys.stderr)
    return row


def _cell(value: object) -> str:
    if isinstance(value, float):
        return "" if not math.isfinite(value) else f"{value:.2f}"
    # A pipe inside a cell would break the Markdown table.
    return str(value).replace("|", "\\|").replace("\n", " ")


def format_table(rows: Sequence[Row]) -> str:
    """The rows as one Markdown table, columns in :data:`COLUMNS` order."""
    lines = [
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "|".join(["---"] * 4 + ["---:", "---:", "---", "---", "---:"]) + "|",
    ]
    for row in rows:
        lines.append("| " + " | ".join(_cell(getattr(row, c)) for c in COLUMNS) + " |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="benchmarks/run.py",
        description="Run benchmarks/bench_*.py and print one table of ratios to their baselines.",
        epilog="Example: python benchmarks/run.py --only score",
    )
    parser.add_argument(
        "--only", action="append", default=[], help="Run only benchmarks whose name contains this."
    )
    parser.add_argument(
        "--strict", action="store_true", help="Exit 1 if any benchmark fails its target or errors."
    )
    parser.add_argument(
        "--dir", type=Path, default=BENCH_DIR, help="Folder holding the bench_*.py files."
    )
    # the child's side of run_one: one benchmark, its row written as JSON to --row
    parser.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--row", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one is not None:
        if args.row is None:
            parser.error("--one needs --row")
        row = run_here(args.one)
        args.row.write_text(json.dumps(asdict(row)), encoding="utf-8")
        return 0
    paths = discover(args.dir, args.only)
    if not paths:
        print(f"no bench_*.py in {args.dir}", file=sys.stderr)
        return 1 if args.strict else 0
    rows = []
    for path in paths:
        print(f"running {path.name} ...", file=sys.stderr, flush=True)
        rows.append(run_one(path))
    print(format_table(rows))
    if args.strict and any(r.result not in ("pass", "skipped") for r in rows):
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
