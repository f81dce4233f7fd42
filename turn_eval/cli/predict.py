"""``turn-eval predict``: the paper's angle estimator on any 3D pose estimator's skeletons."""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd

from turn_datasets import limits
from turn_datasets.cli.common import (
    CONTEXT_SETTINGS,
    FILE,
    FPS_HZ,
    file_option,
    info,
    progress,
    writing,
    wrote,
)
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import check_not_input, write_csv
from turn_datasets.geometry import METHODS, parse_joints
from turn_datasets.skeleton import AUTO
from turn_datasets.up_axis import AxesFound
from turn_eval.cli import cli
from turn_eval.cli.common import SkeletonSource, skeleton_source_options
from turn_eval.estimate.formats import refuse_2d
from turn_eval.predict import clip_arrays, implausible_clips, predict_angles


@cli.command("predict", context_settings=CONTEXT_SETTINGS)
@click.argument("skeletons", nargs=-1, required=True, type=FILE)
@file_option(
    "--out",
    required=True,
    help="Predictions CSV to write: clip_id, angle_deg, direction[, speed_deg_s].",
)
@skeleton_source_options(
    from_help="Whose files: generic arrays (give --layout), or an estimator's own output by name "
    "(layout and up axis known: turnbench = `turn-eval estimate`).",
    layout_help="Joint layout of the skeletons (Human3.6M's 17- or 32-joint order); required with "
    "--from arrays.",
    up_axis_help="The vertical axis: z (Human3.6M world), y (y up), -y (camera: y down), x, -x, "
    "-z, or auto (inferred per clip from the trunk, signed by the head above the feet). Default: "
    "auto for generic arrays, the named format's own otherwise.",
)
@click.option(
    "--joints",
    default="hip",
    show_default=True,
    help="Joint pairs whose frontal vectors are averaged: any of hip, knee, shoulder.",
)
@click.option(
    "--method",
    type=click.Choice(METHODS),
    default="net",
    show_default=True,
    help="net: signed net rotation; paper: equation 3 as printed (sums every wiggle).",
)
@click.option(
    "--fps",
    "fps_hz",
    type=FPS_HZ,
    default=None,
    help="Frame rate in Hz; adds speed_deg_s = angle / (frames / fps) (equation 4), and the "
    "peak speed, steps (foot contacts) and turn type (pivot/step) of each clip.",
)
def predict_command(
    skeletons: tuple[Path, ...],
    out: Path,
    source: SkeletonSource,
    joints: str,
    method: str,
    fps_hz: float | None,
) -> None:
    """Predict turning angles from 3D skeletons with the paper's estimator (equations 1-4).

    SKELETONS are .npy (one (frames, joints, 3) array, clip id = file stem), .npz (one array
    per clip id) or .h5 (one dataset per clip id). Clip ids must be unique across all
    inputs. The output is a predictions file that `turn-eval score` reads, with the
    direction of each turn (left = counter-clockwise seen from above).

    With --from NAME, SKELETONS are another estimator's own output files: turnbench
    (`turn-eval estimate`'s .npz, the same as --layout h36m17 --up-axis -y),
    strided-transformer (its demo's output_keypoints_3d.npz), videopose3d (run.py
    --viz-export .npy), motionbert (infer_wild.py's X3D.npy, named after its folder).
    AlphaPose's JSON is 2D and refused: lift it to 3D first.

    \b
    Example:
      turn-eval predict poses.npz --layout h36m17 --up-axis y --out predictions.csv
      turn-eval predict remap-open/skeletons.npz --layout h36m17 --fps 30 --out pred.csv
      turn-eval predict walk.npz --layout h36m17 --up-axis -y --out pred.csv  (estimate's)
      turn-eval predict clips/*/X3D.npy --from motionbert --out pred.csv
      turn-eval predict S9_*.npy --layout h36m32 --joints hip,knee --fps 50 --out pred.csv
      turn-eval score pred.csv --reference turn-h36m.csv
    """
    refuse_2d(skeletons)  # AlphaPose's 2D output: said before anything else
    layout = source.layout()
    names = parse_joints(joints)
    check_not_input(out, skeletons)
    frames: list[pd.DataFrame] = []
    first_file: dict[str, Path] = {}
    found = AxesFound(source.up_axis or (AUTO if source.format == "arrays" else source.format))
    for path in progress(skeletons, label="predicting", length=len(skeletons)):
        try:
            arrays, file_up_axis = clip_arrays(
                path,
                source_format=source.format,
                layout=layout,
                up_axis=source.up_axis,
                found=found,
            )
            table = predict_angles(
                arrays,
                layout=layout,
                up_axis=file_up_axis,
                joints=names,
                method=method,
                fps_hz=fps_hz,
            )
        except TurnbenchError as exc:
            if exc.where.file is not None:
                raise
            # predict_angles names the clip; the file is known only here.
            raise TurnbenchError(
                exc.message, file=path, item=exc.where.item, hint=exc.hint
            ) from None
        for clip_id in table["clip_id"]:
            if clip_id in first_file:
                raise TurnbenchError(
                    f"duplicate clip id: also in {first_file[clip_id]}",
                    file=path,
                    item=clip_id,
                    hint="clip ids (file stems, .npz keys, .h5 dataset paths) must be unique",
                )
            first_file[clip_id] = path
        frames.append(table)
    result = pd.concat(frames, ignore_index=True)
    info(found.summary())
    fast = implausible_clips(result)
    if fast:
        shown = ", ".join(fast[:5]) + (f" and {len(fast) - 5} more" if len(fast) > 5 else "")
        info(
            f"warning: {len(fast)} clip(s) turn faster than a person does on average "
            f"({limits.MAX_TURN_MEAN_SPEED_DEG_S:g} °/s): {shown}; a left/right swap or a flip "
            "of the hip vector inside the clip?"
        )
    with writing("the predictions", out):
        write_csv(result, out)
    n = len(result)
    wrote(out, what=f"predictions for {n} clip{'' if n == 1 else 's'} to")
