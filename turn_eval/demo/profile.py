"""The demo's profile stage: ``turn-eval profile`` on the untrimmed stage's detections.

After the untrimmed stage (:mod:`turn_eval.demo.untrimmed`) has found every turn in the
demo's home-like streams, this stage runs what a clinic would run next: per-participant
turning profiles and the PD-versus-control contrasts, with their figures, and adds a "Turning
profile" section to ``report.html``.

The recording behind each stream lasts as long as the stream (the streams run on past the
labels' annotated span, which ``sessions.csv`` gives), so the stage writes the sessions table
the profile reads: each stream's length, and the start time ``remap labels`` found in the
session's ELAN header (the demo corpus records one per session).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from turn_datasets.fileio import write_csv
from turn_eval.profile.render import contrasts_markdown
from turn_eval.report import Report

__all__ = ["PROFILE_DIR", "run_profile_stage", "profile_section", "recorded_sessions"]

#: The stage's folder inside the untrimmed stage's folder.
PROFILE_DIR = "profile"


def recorded_sessions(streams: Path, fps_hz: float, sessions: Path | None) -> pd.DataFrame:
    """``session, subject, duration_s`` (each stream's frames / fps) and ``start_time`` (from
    ``sessions``, empty where it has none) of every stream in the folder."""
    rows = []
    for path in sorted(streams.glob("*.npz")):
        with np.load(path) as arrays:
            for subject in sorted(arrays.files):
                rows.append((path.stem, subject, arrays[subject].shape[0] / fps_hz))
    table = pd.DataFrame(rows, columns=["session", "subject", "duration_s"])
    starts = pd.Series("", index=pd.MultiIndex.from_frame(table[["session", "subject"]]))
    if sessions is not None and sessions.exists():
        known = pd.read_csv(sessions, keep_default_na=False, dtype=str)
        if "start_time" in known.columns:
            given = known.set_index(["session", "subject"])["start_time"]
            starts = given.reindex(starts.index).fillna("")
    table["start_time"] = starts.to_numpy()
    return table


def run_profile_stage(
    folder: Path,
    *,
    detections: Path,
    streams: Path,
    sessions: Path | None,
    participants: Path,
    fps_hz: float,
    run_eval: Callable[[Sequence[str]], str],
    bootstrap: int = 1000,
) -> Path:
    """Write the recorded sessions, then ``turn-eval profile --plots`` into
    ``folder / PROFILE_DIR``; returns that folder."""
    table = recorded_sessions(streams, fps_hz, sessions)
    recorded = write_csv(table, folder / "recorded_sessions.csv")
    out = folder / PROFILE_DIR
    run_eval(
        [
            "profile",
            str(detections),
            "--sessions",
            str(recorded),
            "--participants",
            str(participants),
            "--out-dir",
            str(out),
            "--bootstrap",
            str(bootstrap),
            "--plots",
        ]
    )
    return out


def profile_section(report: Report, out: Path) -> None:
    """The report's "Turning profile" section, if the stage ran into ``out``."""
    doc_path = out / "contrasts.json"
    if not doc_path.exists():
        return
    doc = json.loads(doc_path.read_text(encoding="utf-8"))
    sec = report.section("Turning profile")
    sec.paragraph(
        "What a clinic reads from the detections: `turn-eval profile` turns every detected "
        "turn into one row of turning measures per participant (turns per hour, mean angle, "
        "median duration, mean and peak speed, steps, pivot share, 45° bin shares, "
        "variation across turns and days) and contrasts the two groups: means, difference, "
        "Hedges' g and the AUC of each measure, with intervals from a bootstrap of the "
        f"participants within each group. {doc['participants']} participants; "
        f"{doc['suppressed']} with fewer than {doc['settings']['min_turns']} turns left out. "
        "The demo's sessions are minutes long and its participants few: the intervals are "
        "wide, as they should be."
    )
    sec.markdown(contrasts_markdown(doc))
    sec.csv_file(
        out / "profile.csv", caption="profile.csv: one row per participant", float_digits=2
    )
    for name, caption in (
        ("forest.png", "Effect sizes with 95% intervals, published values beside them"),
        ("distributions.png", "Each measure per group"),
    ):
        if (out / name).exists():
            sec.figure(out / name, caption=caption)
    heatmaps = sorted((out / "heatmaps").glob("*.png"))
    if heatmaps:
        sec.figure(heatmaps[0], caption="Turns per recorded hour of one participant, by day")
