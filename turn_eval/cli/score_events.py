"""``turn-eval score-events``: score detected turns in untrimmed sessions (issue 12).

Thin: parse the options, call :func:`turn_eval.events.score_events`, print one format on
stdout and, with ``--out-dir``, write every table together, atomically.
"""

from __future__ import annotations

from pathlib import Path

import click

from turn_datasets.cli.common import (
    CONTEXT_SETTINGS,
    FRACTION,
    bootstrap_options,
    bootstrap_progress,
    check_out_dir,
    emit,
    format_option,
    one_run,
    warn,
    wrote,
)
from turn_datasets.fileio import (
    to_json_text,
    write_files,
)
from turn_eval.cli import cli
from turn_eval.events.plots import EVENT_PLOT_FILES, TIMELINE_DIR
from turn_eval.events.scoring import DEFAULT_BY, score_events
from turn_eval.events.tables import events_frame, events_markdown

#: The files ``--out-dir`` receives (``turn_rates.csv`` only with ``--sessions``).
EVENT_FILES = ("event_scores.json", "event_scores.md", "event_scores.csv", "events.csv")
RATES_FILE = "turn_rates.csv"
#: The run record of ``--out-dir``: what a run wrote, so the next removes only those of them
#: it does not write again (figures without ``--plots``, turn rates without ``--sessions``).
EVENT_RECORD = "event_scores.manifest.json"


def _split_by(values: tuple[str, ...]) -> list[str]:
    return [part.strip() for value in values for part in value.split(",") if part.strip()]


_path = click.Path(dir_okay=True, path_type=Path)


@cli.command("score-events", context_settings=CONTEXT_SETTINGS)
@click.argument("detections", type=_path)
@click.option(
    "--reference",
    "-r",
    required=True,
    type=_path,
    help="Reference turns: `remap labels` CSV (session, subject, start_s, end_s, angle_deg, "
    "...) or a Turn-H3.6M clip index (its action and subaction are the session).",
)
@click.option(
    "--context",
    "context_path",
    type=_path,
    help="context.csv beside the labels: groups false detections by the scenario and "
    "location at their midpoint (else they are 'unknown').",
)
@click.option(
    "--sessions",
    "sessions_path",
    type=_path,
    help="sessions.csv beside the labels: annotated duration per session and subject, for "
    "turns per hour.",
)
@click.option(
    "--iou",
    type=FRACTION,
    default=0.5,
    show_default=True,
    help="A detection and a turn can match when their temporal IoU is at least this.",
)
@click.option(
    "--by",
    multiple=True,
    metavar="COL[,COL...]",
    help=f"Group by these reference columns. Default: those of {', '.join(DEFAULT_BY)} the "
    "reference has.",
)
@bootstrap_options(
    "Cluster-bootstrap resamples of the (session, subject) units for the 95% intervals (0: none)."
)
@click.option(
    "--ignore-unknown",
    is_flag=True,
    help="Drop (and count) detections of sessions and subjects the reference does not "
    "annotate, instead of refusing them.",
)
@format_option()
@click.option(
    "--out-dir",
    type=click.Path(path_type=Path),
    help="Also write event_scores.json/.md/.csv, events.csv (every TP, FP, FN) and, with "
    "--sessions, turn_rates.csv here.",
)
@click.option(
    "--plots",
    is_flag=True,
    help="With --out-dir: also the figures: a timeline per session and subject "
    "(timelines/), F1 per group with intervals, and the PR curve (with scores).",
)
def score_events_cmd(
    detections: Path,
    reference: Path,
    context_path: Path | None,
    sessions_path: Path | None,
    iou: float,
    by: tuple[str, ...],
    n_resamples: int,
    seed: int,
    ignore_unknown: bool,
    fmt: str,
    out_dir: Path | None,
    plots: bool,
) -> None:
    """Score detected turns against time-stamped reference turns of whole sessions.

    DETECTIONS is a CSV with session, subject, start_s, end_s, angle_deg and optionally
    direction (left/right), speed_deg_s and score (higher = surer). Per (session, subject),
    detections and reference turns are matched one-to-one: a pair is eligible at temporal
    IoU >= --iou; the matching with the most pairs, then the largest total IoU, is taken.
    Reports precision, recall and F1 overall and per group; on matched turns the angle
    metrics of `turn-eval score`; turns per hour (--sessions); average precision at IoU
    0.3-0.7 when detections have a score; cluster-bootstrap 95% intervals.

    \b
    Example:
      turn-eval score-events detections.csv --reference labels/labels.csv \\
          --context labels/context.csv --sessions labels/sessions.csv
      turn-eval score-events det.csv -r turn-h36m.csv --iou 0.3 --format json
      turn-eval score-events det.csv -r labels.csv --by cohort,scenario --out-dir events/ --plots
    """
    if plots and out_dir is None:
        raise click.UsageError("--plots needs --out-dir (the figures are files)")
    inputs = [p for p in (detections, reference, context_path, sessions_path) if p is not None]
    if out_dir is not None:
        check_out_dir(
            out_dir,
            (*EVENT_FILES, RATES_FILE, *EVENT_PLOT_FILES),
            inputs,
            folders=(TIMELINE_DIR,),
            record=EVENT_RECORD,
        )
    scores = score_events(
        detections,
        reference,
        iou=iou,
        context=context_path,
        sessions=sessions_path,
        by=_split_by(by),
        n_resamples=n_resamples,
        seed=seed,
        ignore_unknown=ignore_unknown,
        warn=warn,
        progress=bootstrap_progress,
    )
    texts = {"json": to_json_text(scores.doc), "md": events_markdown(scores.doc)}
    frame = events_frame(scores.doc)
    if out_dir is not None:
        _write_out_dir(scores, texts["md"], frame, out_dir, plots=plots)
    if fmt == "csv":
        emit(frame.to_csv(index=False, lineterminator="\n"))
    else:
        emit(texts[fmt])


def _write_out_dir(scores, markdown: str, frame, out_dir: Path, *, plots: bool) -> None:
    """Every table (and with ``plots`` the figures) into ``out_dir``, together or not at all;
    files an earlier run wrote and this one does not are removed (one run per folder)."""
    with one_run(out_dir, what="the scores", record=EVENT_RECORD) as stage:
        files = {
            "event_scores.json": scores.doc,
            "event_scores.md": markdown,
            "event_scores.csv": frame,
            "events.csv": scores.events,
        }
        if scores.rates is not None:
            files[RATES_FILE] = scores.rates
        write_files(stage, files)
        names = list(files)
        if plots:
            from turn_eval.events.plots import write_event_plots

            figures = write_event_plots(scores, stage, warn=warn)
            names += [str(p.relative_to(stage)) for p in figures]
    written = [out_dir / name for name in names]
    n_timelines = sum(1 for p in written if p.parent.name == TIMELINE_DIR)
    shown = [p for p in written if p.parent.name != TIMELINE_DIR]
    wrote(
        *shown,
        *([f"{n_timelines} timelines in {out_dir / TIMELINE_DIR}"] if n_timelines else []),
        what="event scores",
    )
