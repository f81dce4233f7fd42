"""The notebooks run from top to bottom, show what they promise, and are stored without outputs.

Each is executed with nbclient in a kernel of this interpreter (the venv's ``python3``), in a
fresh temporary folder that the notebook makes for itself.
"""

from __future__ import annotations

import asyncio
import subprocess
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

REPO = Path(__file__).resolve().parents[1]
NOTEBOOKS = REPO / "notebooks"
NAMES = (
    "reproduce_paper_tables.ipynb",
    "agreement_audit.ipynb",
    "submitting_predictions.ipynb",
)


def _text_of(nb) -> str:
    """Everything the executed notebook shows: streams, Markdown and plain-text results."""
    parts: list[str] = []
    for cell in nb.cells:
        for output in cell.get("outputs", []):
            if output.get("output_type") == "stream":
                parts.append(output.get("text", ""))
            data = output.get("data", {})
            for mime in ("text/markdown", "text/plain", "text/html"):
                if mime in data:
                    parts.append(data[mime])
    return "\n".join(parts)


def _images_of(nb) -> int:
    return sum(
        "image/png" in output.get("data", {})
        for cell in nb.cells
        for output in cell.get("outputs", [])
    )


@pytest.fixture(scope="module")
def executed() -> dict[str, nbformat.NotebookNode]:
    """The three notebooks, executed side by side (each in its own kernel).

    Kernel "python3" resolves to this interpreter's ipykernel when no other spec is
    installed; each notebook chdirs into its own temporary folder.
    """
    books = {name: nbformat.read(NOTEBOOKS / name, as_version=4) for name in NAMES}

    async def run_all() -> None:
        clients = [
            NotebookClient(
                nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(REPO)}}
            )
            for nb in books.values()
        ]
        await asyncio.gather(*(client.async_execute() for client in clients))

    asyncio.run(run_all())
    return books


def test_reproduce_paper_tables(executed) -> None:
    nb = executed["reproduce_paper_tables.ipynb"]
    text = _text_of(nb)
    assert "Table 3: clips per angle bin" in text
    # Tables 4 and 5: metrics as rows, groups as columns, then Avg. and # Turns
    for needle in ("Acc. (%)", "MAE (°)", "WPrec (%)", "Avg.", "# Turns", "free-living", "PD"):
        assert needle in text, needle
    # Figure 5 and the other plots are shown
    assert _images_of(nb) >= 2
    assert "McNemar" in text and "signature" in text


def test_agreement_audit(executed) -> None:
    nb = executed["agreement_audit.ipynb"]
    text = _text_of(nb)
    assert "Gate: kappa >= 0.8 passed" in text
    # the kappa printed by the audit is the one scikit-learn computes from its pairs
    audit_line = next(line for line in text.splitlines() if line.startswith("kappa from the audit"))
    sk_line = next(line for line in text.splitlines() if line.startswith("kappa by scikit-learn"))
    assert audit_line.split(":")[1].strip() == sk_line.split(":")[1].strip()
    assert "Disagreement" in text  # the review EAF's tier was read back
    assert "gate failed" in text  # the stricter gate fails, as the notebook shows
    assert "Table 2: turns per scenario and angle" in text
    assert _images_of(nb) >= 1


def test_submitting_predictions(executed) -> None:
    nb = executed["submitting_predictions.ipynb"]
    text = _text_of(nb)
    assert "refused:" in text and "duplicate" in text.lower()
    assert "'accuracy'" in text
    assert "signature: turnbench-compare" in text


@pytest.mark.parametrize("name", NAMES)
def test_stored_without_outputs(name: str) -> None:
    """What git holds (and the working copy) has no outputs or execution counts."""
    texts = [(NOTEBOOKS / name).read_text(encoding="utf-8")]
    committed = subprocess.run(
        ["git", "show", f"HEAD:notebooks/{name}"], cwd=REPO, capture_output=True, text=True
    )
    if committed.returncode == 0:
        texts.append(committed.stdout)
    for text in texts:
        nb = nbformat.reads(text, as_version=4)
        nbformat.validate(nb)
        code = [c for c in nb.cells if c.cell_type == "code"]
        assert code
        for cell in code:
            assert cell.outputs == []
            assert cell.execution_count is None
