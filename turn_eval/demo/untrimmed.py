"""The demo's untrimmed stage: streams of its REMAP-like sessions, ``detect``, ``score-events``.

``make demo`` labels synthetic Turn-REMAP sessions (ELAN files with planted turns). This
stage writes what a home camera and a pose estimator would have produced over the same
sessions: one untrimmed skeleton stream per participant with the *same planted turns as
the labels* at their times and angles, everything between them filled with walking,
decoys and estimator artefacts (:func:`turn_datasets.synthetic.untrimmed.write_streams_for_labels`).
It then runs the commands a clinic would run on them, printed as the demo prints its
others, and adds an "Untrimmed sessions" section to ``report.html``: the detection tables
per cohort and scenario, a timeline of one session and the precision-recall curve.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from turn_datasets.fileio import write_csv
from turn_datasets.remap.labels import MIN_LABELLED_TURN_DEG
from turn_datasets.synthetic.untrimmed import write_streams_for_labels
from turn_eval.report import Report

__all__ = [
    "UNTRIMMED_DIR",
    "telling_timeline",
    "UntrimmedResults",
    "load_untrimmed",
    "run_untrimmed_stage",
    "untrimmed_section",
]

#: The stage's folder inside the demo's output folder.
UNTRIMMED_DIR = "untrimmed"
#: The detector's smallest turn: Turn-REMAP's smallest labelled one.
MIN_TURN_DEG = MIN_LABELLED_TURN_DEG
FPS_HZ = 30.0


@dataclass(frozen=True)
class UntrimmedResults:
    """What the stage wrote: the streams, the detections and score-events' folder."""

    folder: Path
    streams: Path
    detections: Path
    events: Path
    scores: dict[str, Any]


def _table(path: Path | None) -> pd.DataFrame | None:
    return pd.read_csv(path, keep_default_na=False) if path is not None and path.exists() else None


def _first_sessions(
    folder: Path, n: int, labels: Path, context: Path | None, sessions: Path | None
) -> tuple[Path, Path | None, Path | None]:
    """The three tables cut to the first ``n`` sessions (by name), written into ``folder``."""
    table = pd.read_csv(labels, keep_default_na=False)
    keep = sorted(set(table["session"].astype(str)))[:n]
    out: list[Path | None] = []
    for path in (labels, context, sessions):
        frame = _table(path)
        if path is None or frame is None:
            out.append(None)
            continue
        frame = frame[frame["session"].astype(str).isin(keep)]
        out.append(write_csv(frame, folder / path.name))
    labels_cut = out[0]
    assert labels_cut is not None  # the labels were read above
    return labels_cut, out[1], out[2]


def run_untrimmed_stage(
    out: Path,
    *,
    labels: Path,
    context: Path | None,
    sessions: Path | None,
    seed: int,
    run_eval: Callable[[Sequence[str]], str],
    max_sessions: int | None = None,
    bootstrap: int = 1000,
) -> UntrimmedResults:
    """Write the streams, then ``turn-eval detect`` and ``turn-eval score-events --plots``.

    Parameters
    ----------
    out
        The demo's output folder; the stage writes ``out / UNTRIMMED_DIR``.
    labels, context, sessions
        What ``turn-datasets remap labels`` wrote (``labels.csv``, ``context.csv``,
        ``sessions.csv``).
    seed
        The demo's seed.
    run_eval
        Runs one ``turn-eval`` command line in-process (the demo's runner, which prints it).
    max_sessions
        Only the first sessions (``--quick``): the labels, context and sessions tables are
        cut to them and written into the stage's folder, so that scoring sees whole
        sessions only.
    bootstrap
        ``score-events --bootstrap`` (the demo's own setting).
    """
    folder = out / UNTRIMMED_DIR
    streams = folder / "streams"
    if max_sessions is not None:
        labels, context, sessions = _first_sessions(folder, max_sessions, labels, context, sessions)
    ctx = _table(context)
    write_streams_for_labels(
        pd.read_csv(labels, keep_default_na=False),
        streams,
        seed=seed,
        context=ctx,
        sessions=_table(sessions),
        fps_hz=FPS_HZ,
        footsteps=True,  # feet that rest between steps: the profile counts them
    )
    detections = folder / "detections.csv"
    run_eval(
        [
            "detect",
            str(streams),
            "--layout",
            "h36m17",
            "--up-axis",
            "-y",
            "--fps",
            f"{FPS_HZ:g}",
            "--min-turn-deg",
            f"{MIN_TURN_DEG:g}",
            "--out",
            str(detections),
        ]
    )
    events = folder / "events"
    args = ["score-events", str(detections), "--reference", str(labels)]
    if context is not None and context.exists():
        args += ["--context", str(context)]
    if sessions is not None and sessions.exists():
        args += ["--sessions", str(sessions)]
    args += ["--by", "cohort,scenario", "--bootstrap", str(bootstrap)]
    run_eval([*args, "--out-dir", str(events), "--plots"])
    scores = json.loads((events / "event_scores.json").read_text(encoding="utf-8"))
    return UntrimmedResults(folder, streams, detections, events, scores)


def load_untrimmed(out: Path) -> UntrimmedResults | None:
    """The stage's results read back from a finished demo folder (None if it did not run)."""
    folder = out / UNTRIMMED_DIR
    scores = folder / "events" / "event_scores.json"
    if not scores.exists():
        return None
    doc = json.loads(scores.read_text(encoding="utf-8"))
    return UntrimmedResults(
        folder, folder / "streams", folder / "detections.csv", folder / "events", doc
    )


def telling_timeline(events_dir: Path) -> Path | None:
    """The timeline that shows most: the first (session, subject), by unit number, with a
    false and a missed detection beside its hits (else the one with the most of them);
    None without timelines.

    ``events.csv`` (``score-events --out-dir``) gives each unit's kinds; the timelines are
    named ``<unit:04d>_<session>_<subject>.png``.
    """
    timelines = sorted((events_dir / "timelines").glob("*.png"))
    if not timelines:
        return None
    events = _table(events_dir / "events.csv")
    if events is None or events.empty:
        return timelines[0]
    kinds = events.groupby("unit")["kind"].agg(
        lambda k: (("FP" in set(k)) + ("FN" in set(k)), len(k))
    )
    ranked = sorted(kinds.items(), key=lambda item: (-item[1][0], int(item[0])))
    by_unit = {int(p.name.split("_", 1)[0]): p for p in timelines if p.name[:4].isdigit()}
    for unit, _ in ranked:
        if int(unit) in by_unit:
            return by_unit[int(unit)]
    return timelines[0]


def untrimmed_section(report: Report, results: UntrimmedResults) -> None:
    """The report's "Untrimmed sessions" section (module docstring)."""
    sec = report.section("Untrimmed sessions")
    overall = results.scores["overall"]
    matched = overall.get("matched", {})
    n_files = len(list(results.streams.glob("*.npz")))
    sec.paragraph(
        f"Each REMAP-like session as a pose estimator would hand it over: {n_files} "
        "files of untrimmed 17-joint streams at 30 fps, one per participant, with the "
        "labels' turns planted at their times and everything between them walking, "
        "standing, decoys (small direction changes, swaying, reaching, sitting down) and "
        "estimator artefacts (left/right swaps, depth error, dropouts, absences, jumps to "
        "a bystander). `turn-eval detect --min-turn-deg 67.5` found the turns; "
        "`turn-eval score-events` matched them to the labels one-to-one at temporal IoU "
        f"0.5: F1 {100 * overall['f1']:.1f}%, matched accuracy "
        f"{100 * matched.get('accuracy', float('nan')):.1f}%, MAE "
        f"{matched.get('mae_deg', float('nan')):.1f}°."
    )
    sec.markdown_file(results.events / "event_scores.md")
    timeline = telling_timeline(results.events)
    if timeline is not None:
        sec.figure(
            timeline,
            caption="One session, chosen to show a false and a missed detection beside the "
            "hits: labelled turns above, detections below (TP green, FP orange, FN red), "
            f"angles written on them ({timeline.name})",
        )
    for name, caption in (
        ("f1_by_group.png", "F1 per group with 95% intervals"),
        ("pr_curve.png", "Precision-recall curve of the detections' scores"),
    ):
        if (results.events / name).exists():
            sec.figure(results.events / name, caption=caption)
