"""The layout's rules, checked on the source: who may import what, and how long a function is."""

from __future__ import annotations

import ast
import re
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


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _package_imports() -> dict[str, list[tuple[str, list[str]]]]:
    """Each module of both packages and what it imports from either package."""
    return {
        _module_name(path): [
            (module, names) for module, names in _imports(path) if module.split(".")[0] in PACKAGES
        ]
        for package in PACKAGES
        for path in _modules(package)
    }


def test_no_module_imports_a_private_name_of_another() -> None:
    # a name with a leading underscore (or a module named so) is its module's own business
    found = []
    for module, imports in _package_imports().items():
        for imported, names in imports:
            taken = [imported, *(f"{imported}.{n}" for n in names)]
            found += [f"{module}: {t}" for t in taken if imported != module and _private(t)]
    assert found == []


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected set of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _import_graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports (``from a.b import c`` is ``a.b.c`` when
    ``c`` is a module, else ``a.b``); a package's ``__init__`` re-exporting its modules is
    not an edge back from them."""
    imports = _package_imports()
    graph: dict[str, set[str]] = {}
    for module, found in imports.items():
        edges = set()
        for imported, names in found:
            for name in names or [""]:
                target = f"{imported}.{name}" if f"{imported}.{name}" in imports else imported
                if target in imports and target != module and not module.startswith(target + "."):
                    edges.add(target)
        graph[module] = edges
    return graph


def test_no_import_circle() -> None:
    assert _cycles(_import_graph()) == []


def test_the_circle_check_sees_a_circle() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"e"}}
    assert _cycles(graph) == [["a", "b", "c"]]


_ISSUE = re.compile(r"\bissues? *#?\d", re.IGNORECASE)


@pytest.mark.parametrize("package", PACKAGES)
def test_package_code_cites_no_issue_numbers(package: str) -> None:
    # code says what it does and why; the history of how it got there is in the commits
    found = [
        f"{path.relative_to(REPO)}:{i}"
        for path in _modules(package)
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)
        if _ISSUE.search(line)
    ]
    assert found == []


def test_the_issue_check_sees_a_citation() -> None:
    assert _ISSUE.search("the notes of issue 13") and _ISSUE.search("(Issue #5)")
    assert not _ISSUE.search("no issue here") and not _ISSUE.search("tissue 3")
