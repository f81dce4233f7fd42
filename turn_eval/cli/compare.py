"""``turn-eval compare``: is submission B better than A on the same clips?"""

from __future__ import annotations

from pathlib import Path

import click

from turn_datasets.cli.common import (
    CONTEXT_SETTINGS,
    FILE,
    bootstrap_options,
    check_out_dir,
    emit,
    file_option,
    format_option,
    one_run,
    warn,
    writing,
    wrote,
)
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import check_not_input, to_json_text, write_text
from turn_datasets.render.labels import METRIC_LABELS
from turn_datasets.render.markdown import markdown_table
from turn_datasets.render.numbers import format_p, one_decimal
from turn_datasets.render.numbers import signed as with_sign
from turn_datasets.usertable import list_ids
from turn_eval.cli import cli
from turn_eval.cli.score import PLOT_FILES
from turn_eval.clips.significance import Comparison, compare_predictions
from turn_eval.clips.submission import Joined, read_predictions, read_reference


def _same_clips(a: Joined, b: Joined) -> list[str]:
    """The clip ids both cover, in reference order; an error if they cover different clips."""
    ids_a = a.table["clip_id"].astype(str).tolist()
    ids_b = b.table["clip_id"].astype(str).tolist()
    if ids_a == ids_b:
        return ids_a
    set_a, set_b = set(ids_a), set(ids_b)
    only_a = [i for i in ids_a if i not in set_b]
    only_b = [i for i in ids_b if i not in set_a]
    parts = []
    for path, only in ((a.predictions_path, only_a), (b.predictions_path, only_b)):
        if only:
            parts.append(f"{len(only)} only in {path} ({list_ids(only)})")
    raise TurnbenchError(
        "the two submissions do not cover the same clips: " + "; ".join(parts),
        file=b.predictions_path,
        hint="a paired comparison needs both to predict the same clips",
    )


def _fmt(value: float, scale: float, *, signed: bool = False) -> str:
    # Rounded as `turn-eval score` prints its tables, so the same number reads the same.
    text = one_decimal(value * scale)
    return with_sign(text) if signed else text


def _p_clause(p: float) -> str:
    text = format_p(p)
    return text if text.startswith("<") else f"= {text}"


def _markdown(
    result: Comparison, *, a: str, b: str, reference: str, n_missing: int, signature: str
) -> str:
    lines = [
        f"A: {a}  ",
        f"B: {b}  ",
        f"reference: {reference} ({result.n} clips"
        + (f", {n_missing} missing from both" if n_missing else "")
        + ")",
        "",
    ]
    rows = []
    for name, d in result.differences.items():
        label, scale = METRIC_LABELS[name].long, METRIC_LABELS[name].scale
        if d.ci_low is None or d.ci_high is None or d.p_value is None:
            ci, p = "n/a", "n/a"  # some resample had no clip with a duration
        else:
            ci = f"[{_fmt(d.ci_low, scale, signed=True)}, {_fmt(d.ci_high, scale, signed=True)}]"
            p = format_p(d.p_value)
        rows.append(
            [label, _fmt(d.a, scale), _fmt(d.b, scale), _fmt(d.diff, scale, signed=True), ci, p]
        )
    lines += markdown_table(["metric", "A", "B", "B - A", "95% CI", "p"], rows, align="lrrrrr")
    m = result.mcnemar
    lines += [
        "",
        f"McNemar exact test on bin correctness: b = {m.b} (A right, B wrong), "
        f"c = {m.c} (A wrong, B right), p {_p_clause(m.p_value)}",
        "",
        f"signature: {signature}",
    ]
    return "\n".join(lines) + "\n"


@cli.command("compare", context_settings=CONTEXT_SETTINGS)
@click.argument("pred_a", metavar="A.csv", type=FILE)
@click.argument("pred_b", metavar="B.csv", type=FILE)
@file_option(
    "--reference",
    "-r",
    required=True,
    help="Reference CSV (clip index or labels): clip_id, angle_deg, ...",
)
@bootstrap_options(
    "Paired bootstrap resamples of the clips.",
    seed_help="Seed of the resampling (printed in the signature).",
    min_resamples=1,
)
@format_option(default="md", choices=("md", "json"))
@click.option(
    "--allow-missing",
    is_flag=True,
    help="Compare on the reference clips both submissions have (they must have the same).",
)
@click.option(
    "--abs",
    "abs_angles",
    is_flag=True,
    help="Take negative predicted angles as magnitudes (signed-rotation submissions).",
)
@file_option(
    "--out",
    default=None,
    help="Also write the result (as printed) to this file.",
)
@click.option(
    "--plots-dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Also draw the figures of `score --plots` with A and B side by side on shared axes "
    "(same limits, ticks, bars and bins) into this folder.",
)
@click.option(
    "--names",
    nargs=2,
    type=str,
    default=None,
    metavar="A B",
    help="Panel titles of A and B in --plots-dir's figures (default: the file names without .csv).",
)
def compare_command(
    pred_a: Path,
    pred_b: Path,
    reference: Path,
    n_resamples: int,
    seed: int,
    fmt: str,
    allow_missing: bool,
    abs_angles: bool,
    out: Path | None,
    plots_dir: Path | None,
    names: tuple[str, str] | None,
) -> None:
    """Compare two submissions on the same clips: is B's difference from A more than noise?

    Paired bootstrap of B - A in accuracy, MAE and WPrec (and the speed MAE when the
    reference has durations) over the same resampled clips: mean difference, 95% percentile
    interval, two-sided p-value. Then an exact McNemar test on which clips each puts in the
    right 45° bin, and a signature line (n, seed, resamples, version) that lets a reader
    reproduce the numbers. For the MAEs a negative difference means B is better. Both files
    are validated as `turn-eval score` does.

    \b
    Example:
      turn-eval compare baseline.csv ours.csv --reference turn-h36m.csv
      turn-eval compare a.csv b.csv --reference labels.csv --bootstrap 10000 --seed 1 --format json
      turn-eval compare a.csv b.csv -r labels.csv --plots-dir figures/ --names baseline ours
    """
    if names is not None and plots_dir is None:
        raise click.UsageError("--names titles the figures of --plots-dir; give one")
    if names is not None and names[0] == names[1]:
        raise click.UsageError(f"--names: A and B are both called {names[0]!r}")
    if out is not None:
        check_not_input(out, (pred_a, pred_b, reference))
    if plots_dir is not None:
        check_out_dir(plots_dir, PLOT_FILES, [pred_a, pred_b, reference])
    ref = read_reference(reference)
    joined_a = read_predictions(
        pred_a, ref, allow_missing=allow_missing, abs_angles=abs_angles, warn=warn
    )
    joined_b = read_predictions(
        pred_b, ref, allow_missing=allow_missing, abs_angles=abs_angles, warn=warn
    )
    _same_clips(joined_a, joined_b)
    table_a, table_b = joined_a.table, joined_b.table
    result = compare_predictions(
        table_a["pred_angle_deg"].to_numpy(),
        table_b["pred_angle_deg"].to_numpy(),
        table_a["ref_angle_deg"].to_numpy(),
        ref_duration_s=table_a["ref_duration_s"].to_numpy() if joined_a.has_durations else None,
        pred_a_speed_deg_s=table_a["pred_speed_deg_s"].to_numpy(),
        pred_b_speed_deg_s=table_b["pred_speed_deg_s"].to_numpy(),
        n_resamples=n_resamples,
        seed=seed,
        bin_width_deg=joined_a.bin_width_deg,
    )
    signature = result.signature_of(
        {"reference": reference, "a": pred_a, "b": pred_b},
        {
            "reference": joined_a.reference_sha256,
            "a": joined_a.predictions_sha256,
            "b": joined_b.predictions_sha256,
        },
    )
    if fmt == "json":
        doc = {
            "a": str(pred_a),
            "b": str(pred_b),
            "reference": str(reference),
            "n_missing": joined_a.n_missing,
            **result.as_dict(),
            "signature": signature.as_dict(),
        }
        text = to_json_text(doc)
    else:
        text = _markdown(
            result,
            a=str(pred_a),
            b=str(pred_b),
            reference=str(reference),
            n_missing=joined_a.n_missing,
            signature=signature.line(),
        )
    if plots_dir is not None:
        from turn_eval.clips.plots import write_side_by_side

        title_a, title_b = names or (pred_a.stem, pred_b.stem)
        if title_a == title_b:  # two files of one name in two folders
            title_a, title_b = f"A: {title_a}", f"B: {title_b}"
        panels = {
            title_a: (table_a["pred_angle_deg"].to_numpy(), table_a["ref_angle_deg"].to_numpy()),
            title_b: (table_b["pred_angle_deg"].to_numpy(), table_b["ref_angle_deg"].to_numpy()),
        }
        with one_run(plots_dir, what="the figures") as stage:
            write_side_by_side(panels, stage, bin_width_deg=joined_a.bin_width_deg)
        wrote(*(plots_dir / name for name in PLOT_FILES), what=f"{title_a} beside {title_b}:")
    if out is not None:
        # The file first: if it cannot be written, stdout stays empty and the exit is 2.
        with writing("the comparison", out):
            write_text(out, text)
        wrote(out, what="comparison")
    emit(text)
