"""``turn-eval profile``: per-participant turning profiles and PD-versus-control contrasts.

Thin: parse the options, call :func:`turn_eval.profile.turning_profile`, write the tables (and
with ``--plots`` the figures) into ``--out-dir`` together, print the contrasts on stdout.
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
from turn_datasets.fileio import to_json_text, write_files
from turn_eval.cli import cli
from turn_eval.profile.plots import HEATMAP_DIR
from turn_eval.profile.render import contrasts_markdown
from turn_eval.profile.run import ProfileParams, turning_profile

#: The tables ``--out-dir`` receives.
PROFILE_FILES = ("profile.csv", "by_hour.csv", "contrasts.csv", "contrasts.json")
#: The run record in --out-dir: what a run wrote, so the next removes what it does not write
#: (the plots and heat maps of an earlier --plots run).
PROFILE_RECORD = "profile.manifest.json"

_path = click.Path(dir_okay=False, path_type=Path)


@cli.command("profile", context_settings=CONTEXT_SETTINGS)
@click.argument("detections", type=_path)
@click.option(
    "--sessions",
    "sessions_path",
    required=True,
    type=_path,
    help="sessions.csv: session, subject, duration_s and optionally start_time (ISO 8601 "
    "with its UTC offset, for local hours and days).",
)
@click.option(
    "--participants",
    "participants_path",
    required=True,
    type=_path,
    help="The participants table: subject and the --by column (cohort: PD or HC).",
)
@click.option(
    "--out-dir",
    required=True,
    type=click.Path(path_type=Path),
    help="Write profile.csv, by_hour.csv, contrasts.csv and contrasts.json here.",
)
@params_options(ProfileParams)
@bootstrap_options("Bootstrap resamples of the participants within each group (0: none).")
@click.option(
    "--by",
    default="cohort",
    show_default=True,
    metavar="COLUMN",
    help="The participants table's two-level column to contrast (e.g. medication); its "
    "first value in natural order is reported in the pd columns.",
)
@click.option(
    "--plots",
    is_flag=True,
    help="Also a day x hour heat map per participant (heatmaps/), the groups' distributions "
    "of each measure and a forest plot of the effect sizes beside published ones.",
)
@format_option()
def profile_cmd(
    detections: Path,
    sessions_path: Path,
    participants_path: Path,
    out_dir: Path,
    min_turns: int,
    n_resamples: int,
    seed: int,
    by: str,
    plots: bool,
    fmt: str,
) -> None:
    """Turn detected turns into per-participant turning profiles and PD-vs-HC contrasts.

    DETECTIONS is `turn-eval detect`'s CSV (session, subject, start_s, end_s, angle_deg and
    optionally peak_speed_deg_s, steps, turn_type). Writes profile.csv (one row per
    participant: turns per hour, mean angle, median duration, mean and peak speed, steps,
    pivot share, 45-degree bin shares, variation across turns and days), by_hour.csv (turns
    and recorded minutes per local date and hour) and contrasts.csv (group means, difference,
    Hedges' g and AUC, with bootstrap 95% intervals). Prints the contrasts.

    \b
    Example:
      turn-eval profile detections.csv --sessions labels/sessions.csv \\
          --participants participants.csv --out-dir profile/ --plots
      turn-eval profile det.csv --sessions s.csv --participants p.csv --out-dir out \\
          --by medication --min-turns 20 --format json > contrasts.json
    """
    inputs = [detections, sessions_path, participants_path]
    check_out_dir(out_dir, PROFILE_FILES, inputs)
    result = turning_profile(
        detections,
        sessions_path,
        participants_path,
        by=by,
        min_turns=min_turns,
        n_resamples=n_resamples,
        seed=seed,
        warn=warn,
        progress=bootstrap_progress,
    )
    with one_run(out_dir, what="the profile", record=PROFILE_RECORD) as stage:
        files = {
            "profile.csv": result.profile,
            "by_hour.csv": result.by_hour,
            "contrasts.csv": result.contrasts,
            "contrasts.json": result.doc,
        }
        names = [str(p.name) for p in write_files(stage, files)]
        if plots:
            from turn_eval.profile.plots import write_profile_plots

            names += [str(p.relative_to(stage)) for p in write_profile_plots(result, stage)]
    heatmaps = sum(1 for n in names if n.startswith(f"{HEATMAP_DIR}/"))
    shown = [out_dir / n for n in names if not n.startswith(f"{HEATMAP_DIR}/")]
    wrote(
        *shown,
        *([f"{heatmaps} heat maps in {out_dir / HEATMAP_DIR}"] if heatmaps else []),
        what="profile",
    )
    if fmt == "json":
        emit(to_json_text(result.doc))
    elif fmt == "csv":
        emit(result.contrasts.to_csv(index=False, lineterminator="\n"))
    else:
        emit(contrasts_markdown(result.doc))
