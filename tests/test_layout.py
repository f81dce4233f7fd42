"""The layout's rules, checked on the source: who may import what, and how long a function is."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("turn_datasets", "turn_eval")
#: House rule: no function longer than this many lines (from ``def`` to its last line).
MAX_FUNCTION_LINES = 120


def _modules(package: str) -> list[Path]:
    return sorted((REPO / package).rglob("*.py"))


def _imports(path: Path) -> list[tuple[str, list[str]]]:
    """(module imported, names taken from it) for every import of a file, nested ones too."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(alias.name, []) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.append((node.module, [alias.name for alias in node.names]))
    return out


def _private(dotted: str) -> bool:
    return any(part.startswith("_") and not part.startswith("__") for part in dotted.split("."))


def test_turn_eval_uses_only_public_turn_datasets() -> None:
    # turn_eval may import turn_datasets' public modules and names; never a private one
    found = []
    for path in _modules("turn_eval"):
        for module, names in _imports(path):
            if not module.startswith("turn_datasets"):
                continue
            taken = [module, *(f"{module}.{n}" for n in names)]
            found += [f"{path.relative_to(REPO)}: {t}" for t in taken if _private(t)]
    assert found == []


def test_turn_datasets_never_imports_turn_eval() -> None:
    found = [
        f"{path.relative_to(REPO)}: {module}"
        for path in _modules("turn_datasets")
        for module, _ in _imports(path)
        if module.split(".")[0] == "turn_eval"
    ]
    assert found == []


def test_the_check_sees_a_private_import(tmp_path: Path) -> None:
    # the rule above would pass on nothing: it must catch what it forbids
    bad = tmp_path / "bad.py"
    bad.write_text(
        "from turn_datasets._io import x\nfrom turn_datasets.fileio import _helper\n"
        "def f():\n    import turn_datasets.cli._common\n",
        encoding="utf-8",
    )
    taken = [t for m, names in _imports(bad) for t in (m, *(f"{m}.{n}" for n in names))]
    assert [t for t in taken if _private(t)] == [
        "turn_datasets._io",
        "turn_datasets._io.x",
        "turn_datasets.fileio._helper",
        "turn_datasets.cli._common",
    ]


@pytest.mark.parametrize("package", PACKAGES)
def test_no_function_is_longer_than_the_house_rule(package: str) -> None:
    long = []
    for path in _modules(package):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(REPO)}:{node.lineno} {node.name} ({lines})")
    assert long == []
