"""The notebooks run from top to bottom, show what they promise, and are stored without outputs.

Each is executed with nbclient in a kernel of this interpreter (the venv's ``python3``), in a
fresh temporary folder that the notebook makes for itself.
"""

from __future__ import annotations

import asyncio
import re
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


def _header(text: str, first: str) -> set[str]:
    """The cells of the first Markdown table row that starts with ``| first |``."""
    line = next(x for x in text.splitlines() if x.startswith(f"| {first} |"))
    return {c.strip() for c in line.strip().strip("|").split("|")}


def test_reproduce_paper_tables(executed) -> None:
    nb = executed["reproduce_paper_tables.ipynb"]
    text = _text_of(nb)
    # Table 3: the five bins of Turn-H3.6M (45° to 225°) and a total
    assert "Table 3: clips per angle bin" in text
    assert _header(text, "Bin (°)") >= {"Bin (°)", "Clips", "Min (°)", "Max (°)", "Mean (°)"}
    for row in ("| 45 |", "| 90 |", "| 135 |", "| 180 |", "| 225 |", "| **Total** |"):
        assert row in text, row
    # Tables 4 and 5: metrics as rows, groups as columns, then Avg. and # Turns: Turn-H3.6M by
    # its seven subjects, Turn-REMAP by the three scenarios and by cohort
    for needle in ("Acc. (%)", "MAE (°)", "WPrec (%)", "MAE speed (°/s)", "# Turns"):
        assert needle in text, needle
    subjects = {"S1", "S5", "S6", "S7", "S8", "S9", "S11"}
    assert _header(text, "subject") == {"subject", *subjects, "Avg."}
    assert _header(text, "scenario") == {"scenario", "scripted", "clinical", "free-living", "Avg."}
    assert _header(text, "cohort") == {"cohort", "PD", "HC", "Avg."}
    # Figure 5 (a: predicted angles per bin, b: absolute errors) and the two other plots
    assert "predicted_by_bin.png" in text and "abs_error.png" in text
    assert _images_of(nb) >= 4
    assert "McNemar" in text and "signature" in text


def test_agreement_audit(executed) -> None:
    nb = executed["agreement_audit.ipynb"]
    text = _text_of(nb)
    assert "Gate: kappa >= 0.8 passed" in text
    # the kappa printed by the audit is the one scikit-learn computes from its pairs
    audit_line = next(line for line in text.splitlines() if line.startswith("kappa from the audit"))
    sk_line = next(line for line in text.splitlines() if line.startswith("kappa by scikit-learn"))
    assert audit_line.split(":")[1].strip() == sk_line.split(":")[1].strip()
    # the review EAF's Disagreement tier, read back from the session of an angle disagreement:
    # one annotation saying what each rater wrote, both angles from the vocabulary
    marks = re.findall(
        r"^Disagreement \S+: +[\d.]+- *[\d.]+ s  clinician1: (\d+) / clinician2: (\d+)$",
        text,
        flags=re.MULTILINE,
    )
    assert any(a != b for a, b in marks)
    assert all(int(a) % 45 == 0 and 90 <= int(a) <= 360 for pair in marks for a in pair)
    assert "gate failed" in text  # the stricter gate fails, as the notebook shows
    assert "Table 2: turns per scenario and angle" in text
    assert _images_of(nb) >= 1


def test_submitting_predictions(executed) -> None:
    nb = executed["submitting_predictions.ipynb"]
    text = _text_of(nb)
    # the broken copy is refused on the duplicated line: the file has a header and the
    # reference's clips, the last one replaced by a copy of the first (line 2); both
    # problems, the duplicate and the clip it pushed out, in the one error
    refused = re.search(
        r"refused: broken\.csv:(\d+): 2 problems of 2 kinds; nothing scored:\s+"
        r"duplicate clip_id '[^']+', first on line 2: line (\d+) ",
        text,
    )
    assert refused and refused.group(1) == refused.group(2)
    assert "1 of the reference's" in text and "clips is missing from the predictions" in text
    scored = re.search(r"\{'n': (\d+), 'accuracy'", text)
    assert scored and int(refused.group(1)) == int(scored.group(1)) + 1
    # the comparison is of the same clips as the score
    signature = re.search(r"signature: turnbench-compare\|n:(\d+)\|", text)
    assert signature and signature.group(1) == scored.group(1)


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
