"""``benchmarks/run.py``: discovery, judging against targets, the one table, exit codes.

The benchmarks here are fakes written into a temporary folder (nothing is timed).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def _runner():
    spec = importlib.util.spec_from_file_location("bench_runner", REPO / "benchmarks" / "run.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


run = _runner()


def _bench(folder: Path, name: str, body: str) -> Path:
    path = folder / f"bench_{name}.py"
    path.write_text(body, encoding="utf-8")
    return path


@pytest.fixture()
def bench_dir(tmp_path: Path) -> Path:
    _bench(
        tmp_path,
        "fast",
        "def run():\n"
        "    return {'what': 'add numbers', 'size': '10 rows', 'ratio': 1.2, 'target': 1.5,\n"
        "            'baseline': 'np.sum', 'seconds': 0.25}\n",
    )
    _bench(
        tmp_path,
        "slow",
        "def run():\n"
        "    return {'what': 'score | rows', 'size': '100,000 rows', 'ratio': 250.0,\n"
        "            'target': '< 200'}\n",
    )
    _bench(
        tmp_path,
        "broken",
        "def run():\n    print('| chatter |')\n    raise RuntimeError('no data')\n",
    )
    _bench(
        tmp_path,
        "chatty",
        "print('loading')\n"
        "def run():\n"
        "    print('| warming up | not a row |')\n"
        "    return {'what': 'talk', 'size': '1', 'ratio': 1.0, 'target': 2}\n",
    )
    (tmp_path / "helper.py").write_text("raise SystemExit('must not be imported')\n")
    return tmp_path


def test_discover_finds_only_bench_files_in_name_order(bench_dir: Path) -> None:
    assert [p.name for p in run.discover(bench_dir)] == [
        "bench_broken.py",
        "bench_chatty.py",
        "bench_fast.py",
        "bench_slow.py",
    ]
    assert [p.name for p in run.discover(bench_dir, ["slo"])] == ["bench_slow.py"]


@pytest.mark.parametrize(
    ("target", "ratio", "ok", "text"),
    [
        (1.5, 1.5, True, "<= 1.5"),  # a bare number is an upper bound, inclusive
        (1.5, 1.51, False, "<= 1.5"),
        ("< 200", 199.9, True, "< 200"),
        ("< 200", 200.0, False, "< 200"),
        (">= 2", 2.0, True, ">= 2"),
        ("1.5x", 1.0, True, "<= 1.5"),
    ],
)
def test_parse_target(target, ratio, ok, text) -> None:
    compare, bound, shown = run.parse_target(target)
    assert compare(ratio, bound) is ok
    assert shown == text


@pytest.mark.parametrize("bad", ["fast", "", True, "<= x"])
def test_parse_target_rejects_nonsense(bad) -> None:
    with pytest.raises(ValueError):
        run.parse_target(bad)


def test_one_table_with_pass_fail_and_error(bench_dir: Path, capsys) -> None:
    assert run.main(["--dir", str(bench_dir)]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out[0] == (
        "| benchmark | what | size | baseline | seconds | ratio | target | result | wall_s |"
    )
    body = {
        line.split("|")[1].strip(): [c.strip() for c in line.split("|")[1:-1]] for line in out[2:]
    }
    # a header, its rule and one row per benchmark: what the benchmarks print is not here
    assert len(out) == 2 + 4
    assert "chatter" not in "\n".join(out) and "warming up" not in "\n".join(out)
    assert body["chatty"][7] == "pass"
    assert body["fast"][1:8] == [
        "add numbers",
        "10 rows",
        "np.sum",
        "0.25",
        "1.20",
        "<= 1.5",
        "pass",
    ]
    # the pipe inside "what" is escaped, so the row still has its eight cells
    slow_line = next(line for line in out if line.startswith("| slow "))
    assert "score \\| rows" in slow_line
    assert slow_line.split(" | ")[-2] == "FAIL"
    assert body["slow"][4] == ""  # no seconds given: an empty cell
    assert body["broken"][7] == "error"
    assert "RuntimeError: no data" in body["broken"][1]


def test_strict_exit_code(bench_dir: Path, tmp_path: Path) -> None:
    assert run.main(["--dir", str(bench_dir), "--strict"]) == 1
    assert run.main(["--dir", str(bench_dir), "--only", "fast", "--strict"]) == 0


def test_missing_keys_is_an_error_row(tmp_path: Path) -> None:
    path = _bench(tmp_path, "partial", "def run():\n    return {'what': 'x', 'ratio': 1}\n")
    row = run.run_one(path)
    assert row.result == "error"
    assert "size, target" in row.what


def test_command_line_prints_only_the_table_on_stdout(bench_dir: Path) -> None:
    proc = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / "run.py"), "--dir", str(bench_dir)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0
    lines = proc.stdout.strip().splitlines()
    assert all(line.startswith("|") for line in lines)
    assert len(lines) == 2 + 4
    assert "running bench_fast.py" in proc.stderr
    # what the benchmarks printed went to stderr
    assert "loading" in proc.stderr and "| warming up | not a row |" in proc.stderr


def test_a_benchmark_needing_a_missing_package_is_skipped_not_failed(
    tmp_path: Path, capsys
) -> None:
    (tmp_path / "bench_needs.py").write_text(
        "REQUIRES = ('turnbench_no_such_package',)\n"
        "def run():\n    raise AssertionError('must not run')\n"
    )
    assert run.main(["--dir", str(tmp_path), "--strict"]) == 0
    row = capsys.readouterr().out.strip().splitlines()[2]
    cells = [c.strip() for c in row.split("|")[1:-1]]
    assert cells[0] == "needs" and cells[7] == "skipped"
    assert "turnbench_no_such_package" in cells[1]


def test_each_benchmark_runs_in_a_process_of_its_own(tmp_path: Path, capsys) -> None:
    # "a" leaves state behind in its interpreter (as a Dask cluster's threads or a large heap
    # would); "b" would read it and fail. Run one after the other, neither sees the other.
    _bench(
        tmp_path,
        "a",
        "import builtins, os\n"
        "def run():\n"
        "    builtins.TURNBENCH_LEFT_BEHIND = True\n"
        "    return {'what': str(os.getpid()), 'size': '1', 'ratio': 1.0, 'target': 1.5}\n",
    )
    _bench(
        tmp_path,
        "b",
        "import builtins, os\n"
        "def run():\n"
        "    left = hasattr(builtins, 'TURNBENCH_LEFT_BEHIND')\n"
        "    return {'what': str(os.getpid()), 'size': '1', 'ratio': 2.0 if left else 1.0,\n"
        "            'target': 1.5}\n",
    )
    assert run.main(["--dir", str(tmp_path), "--strict"]) == 0
    rows = [line.split("|")[1:-1] for line in capsys.readouterr().out.strip().splitlines()[2:]]
    pids = {r[0].strip(): int(r[1]) for r in rows}
    assert [r[7].strip() for r in rows] == ["pass", "pass"]
    assert len({pids["a"], pids["b"], os.getpid()}) == 3


def test_a_benchmark_whose_process_dies_is_an_error_row(tmp_path: Path, capsys) -> None:
    _bench(tmp_path, "dies", "import os\ndef run():\n    os._exit(7)\n")
    _bench(
        tmp_path,
        "fine",
        "def run():\n    return {'what': 'x', 'size': '1', 'ratio': 1, 'target': 2}\n",
    )
    assert run.main(["--dir", str(tmp_path), "--strict"]) == 1
    rows = {
        line.split("|")[1].strip(): [c.strip() for c in line.split("|")[1:-1]]
        for line in capsys.readouterr().out.strip().splitlines()[2:]
    }
    assert rows["dies"][7] == "error"
    assert "exited with code 7" in rows["dies"][1]
    assert rows["fine"][7] == "pass"
