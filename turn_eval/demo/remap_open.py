"""The demo's REMAP Open stage: Turn-REMAP as released, read, predicted and scored by group.

The real Turn-REMAP is published as the REMAP Open dataset (a rater spreadsheet and one
folder of 2D/3D keypoint CSVs per turn; :mod:`turn_datasets.remap.open_release`). This stage
writes a synthetic tree in that layout (:func:`turn_datasets.synthetic.remap_open.
write_remap_open`, with an estimator's depth error and jitter), then runs the three commands
a user runs on the real release, printed as the demo prints its others::

    turn-datasets remap open release/ --out-dir data/
    turn-eval predict data/skeletons.npz --layout h36m17 --fps 30 --out predictions.csv
    turn-eval score predictions.csv -r data/labels.csv --by cohort --by medication ...

and adds a "Turn-REMAP as released" section to ``report.html`` with the scores by
medication, DBS state, turn type, steps, cohort and scenario.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from turn_datasets.synthetic.remap_open import write_remap_open
from turn_eval.report import Report

__all__ = [
    "OPEN_DIR",
    "GROUPINGS",
    "RemapOpenResults",
    "load_remap_open",
    "remap_open_section",
    "run_remap_open_stage",
]

#: The stage's folder inside the demo's output folder.
OPEN_DIR = "remap-open"
#: The groupings scored and shown: every label the release's raters gave.
GROUPINGS = ("medication", "dbs", "turn_type", "steps", "cohort", "scenario")


@dataclass(frozen=True)
class RemapOpenResults:
    """What the stage wrote: its folder, the manifest of ``remap open`` and the scores."""

    folder: Path
    manifest: dict[str, Any]
    scores: dict[str, Any]


def run_remap_open_stage(
    out: Path,
    *,
    seed: int,
    run_datasets: Callable[[Sequence[str]], str],
    run_eval: Callable[[Sequence[str]], str],
    quick: bool = False,
    bootstrap: int = 1000,
) -> RemapOpenResults:
    """Write the synthetic release, then ``remap open``, ``predict`` and ``score``.

    Parameters
    ----------
    out
        The demo's output folder; the stage writes ``out / OPEN_DIR``.
    seed
        The demo's seed.
    run_datasets, run_eval
        Run one ``turn-datasets`` / ``turn-eval`` command line in-process (the demo's
        runners, which print it).
    quick
        Four participants with four turns each instead of twelve with twelve.
    bootstrap
        ``score --bootstrap``.
    """
    folder = out / OPEN_DIR
    n = 2 if quick else 6
    write_remap_open(
        folder / "release",
        n_pd=n,
        n_hc=n,
        turns_per_participant=4 if quick else 12,
        seed=seed,
        sheet_format="xlsx",
        estimator_error=True,
    )
    data = folder / "data"
    run_datasets(["remap", "open", str(folder / "release"), "--out-dir", str(data)])
    predictions = folder / "predictions.csv"
    run_eval(
        [
            "predict",
            str(data / "skeletons.npz"),
            "--layout",
            "h36m17",
            "--fps",
            "30",
            "--out",
            str(predictions),
        ]
    )
    by = [arg for g in GROUPINGS for arg in ("--by", g)]
    run_eval(
        [
            "score",
            str(predictions),
            "--reference",
            str(data / "labels.csv"),
            *by,
            "--bootstrap",
            str(bootstrap),
            "--out-dir",
            str(folder / "scores"),
        ]
    )
    results = load_remap_open(out)
    assert results is not None  # the commands above wrote both files
    return results


def load_remap_open(out: Path) -> RemapOpenResults | None:
    """The stage's results read back from a finished demo folder (None if it did not run)."""
    folder = out / OPEN_DIR
    scores, manifest = folder / "scores" / "scores.json", folder / "data" / "manifest.json"
    if not (scores.exists() and manifest.exists()):
        return None
    return RemapOpenResults(
        folder,
        json.loads(manifest.read_text(encoding="utf-8")),
        json.loads(scores.read_text(encoding="utf-8")),
    )


def remap_open_section(report: Report, results: RemapOpenResults) -> None:
    """The report's "Turn-REMAP as released (REMAP Open)" section."""
    sec = report.section("Turn-REMAP as released (REMAP Open)")
    m = results.manifest
    axes = ", ".join(f"{a} for {k}" for a, k in m["up_axis"]["found"].items())
    sec.paragraph(
        f"A synthetic tree in the REMAP Open release's layout: {m['n_clips']} turns of "
        f"{m['n_participants']} participants, a rater spreadsheet (.xlsx) and one folder of "
        "2D/3D keypoint CSVs per turn, the 3D in root-relative camera axes (y down) with a "
        "monocular estimator's depth error. `turn-datasets remap open` read it (vertical axis "
        f"inferred from the trunk: {axes}), `turn-eval predict --fps 30` estimated each turn's "
        "angle with the default up axis (auto), and `turn-eval score` grouped the results by "
        "every label the raters gave: medication (on/off, control), DBS state, turn type "
        "(pivot/step, blank where unlabelled), steps, cohort and scenario."
    )
    sec.summary({"net": results.scores}, caption="Turn-REMAP as released: overall")
    present = [g for g in GROUPINGS if g in results.scores.get("by", {})]
    sec.scores(results.scores, groupings=present, caption="Turn-REMAP as released, net")
