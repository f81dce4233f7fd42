"""``turn-eval score``: score a predictions file against a reference.

Thin: parse the options, read and validate (:mod:`turn_eval.clips.submission`), score
(:mod:`turn_eval.clips.tables`), print one format on stdout and, with ``--out-dir``, write all three
(and the figures) together, atomically.
"""

from __future__ import annotations

from pathlib import Path

import click

from turn_datasets.cli.common import (
    CONTEXT_SETTINGS,
    bootstrap_options,
    bootstrap_progress,
    check_out_dir,
    emit,
    format_option,
    one_run,
    params_options,
    warn,
    wrote,
)
from turn_datasets.fileio import (
    to_json_text,
    write_files,
)
from turn_datasets.geometry import BinParams
from turn_eval.cli import cli
from turn_eval.cli.common import by_option
from turn_eval.clips.submission import read_predictions, read_reference
from turn_eval.clips.tables import build_scores, scores_csv, scores_frame, scores_markdown
from turn_eval.steps.scoring import step_scores, steps_markdown

#: The files ``--out-dir`` receives besides the figures.
SCORE_FILES = ("scores.json", "scores.md", "scores.csv")
#: The figures ``--plots`` adds (as :data:`turn_eval.clips.plots.PLOT_FILES`; matplotlib is only
#: imported when they are drawn).
PLOT_FILES = ("confusion_matrix.png", "predicted_by_bin.png", "abs_error.png", "bland_altman.png")
#: The run record of ``--out-dir``: a run without ``--plots`` removes the figures listed there.
SCORE_RECORD = "scores.manifest.json"


@cli.command("score", context_settings=CONTEXT_SETTINGS)
@click.argument("predictions", type=click.Path(dir_okay=True, path_type=Path))
@click.option(
    "--reference",
    "-r",
    required=True,
    type=click.Path(dir_okay=True, path_type=Path),
    help="CSV with clip_id, angle_deg and optionally duration_s and group columns "
    "(a Turn-H3.6M clip index or Turn-REMAP labels).",
)
@by_option(
    "every one of scenario, location, cohort, subject, bin_deg, action, split the reference has."
)
@click.option(
    "--allow-missing",
    is_flag=True,
    help="Score the clips the predictions have and report how many are missing.",
)
@click.option(
    "--abs",
    "abs_angles",
    is_flag=True,
    help="Take negative angles (signed rotations) as their magnitudes.",
)
@bootstrap_options(
    "Bootstrap resamples for the 95% intervals (0: none).", seed_help="Seed of the bootstrap."
)
@params_options(BinParams)
@format_option()
@click.option(
    "--out-dir",
    # A file here is refused below, in one line like every bad input (not click's usage text).
    type=click.Path(path_type=Path),
    help="Also write scores.json, scores.md and scores.csv here.",
)
@click.option("--plots", is_flag=True, help="With --out-dir: also write the figures as PNG.")
def score(
    predictions: Path,
    reference: Path,
    by: tuple[str, ...],
    allow_missing: bool,
    abs_angles: bool,
    n_resamples: int,
    seed: int,
    bin_width_deg: float,
    fmt: str,
    out_dir: Path | None,
    plots: bool,
) -> None:
    """Score turning-angle predictions overall and per group, as the paper's tables.

    PREDICTIONS is a CSV with clip_id, angle_deg and optionally speed_deg_s (degrees per
    second); other columns are ignored. Metrics: accuracy of the 45° bin, MAE (degrees),
    weighted precision, MAE of angular speed (with reference durations), with seeded
    percentile bootstrap 95% intervals; per group and the groups' unweighted average.
    Where the reference and the predictions both carry steps or turn_type (REMAP Open's
    labels, predict --fps): steps MAE and exact share, turn-type accuracy and Cohen's kappa.

    \b
    Example:
      turn-eval score predictions.csv --reference turn-h36m.csv
      turn-eval score predictions.csv -r labels.csv --by cohort --by scenario --format json
      turn-eval score predictions.csv -r labels.csv --out-dir scores/ --plots
    """
    if plots and out_dir is None:
        raise click.UsageError("--plots needs --out-dir (the figures are files)")
    if out_dir is not None:
        check_out_dir(
            out_dir, (*SCORE_FILES, *PLOT_FILES), [predictions, reference], record=SCORE_RECORD
        )
    ref = read_reference(reference, bin_width_deg=bin_width_deg)
    joined = read_predictions(
        predictions, ref, allow_missing=allow_missing, abs_angles=abs_angles, warn=warn
    )
    scores = build_scores(
        joined, by=list(by), n_resamples=n_resamples, seed=seed, progress=bootstrap_progress
    )
    steps = step_scores(reference, predictions, joined.table, list(scores["by"]))
    if steps is not None:
        scores["steps"] = steps
    texts = {
        "json": to_json_text(scores),
        "md": scores_markdown(scores) + ("" if steps is None else "\n" + steps_markdown(steps)),
    }
    frame = scores_frame(scores)
    if out_dir is not None:
        # Figures of an earlier --plots run go when this run has none.
        with one_run(out_dir, what="the scores", record=SCORE_RECORD) as stage:
            write_files(
                stage,
                {"scores.json": scores, "scores.md": texts["md"], "scores.csv": scores_csv(frame)},
            )
            if plots:
                from turn_eval.clips.plots import write_plots

                t = joined.table
                pred, ref_deg = t["pred_angle_deg"].to_numpy(), t["ref_angle_deg"].to_numpy()
                write_plots(pred, ref_deg, stage, bin_width_deg=bin_width_deg)
        names = [*SCORE_FILES, *(PLOT_FILES if plots else ())]
        wrote(*(out_dir / name for name in names), what="scores")
    if fmt == "csv":
        emit(scores_csv(frame))
    else:
        emit(texts[fmt])
