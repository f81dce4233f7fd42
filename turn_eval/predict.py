"""The paper's turning-angle estimator as a plug-in for any 3D pose estimator's output.

Cheng et al. estimate a turn's angle from 3D skeletons: the frontal vector of a left/right
joint pair (equations 1 and 2), its rotation about the vertical axis summed over the clip
(equation 3), and the angular speed as that angle over the clip's duration (equation 4).
This module applies that estimator, clip by clip, to whatever skeletons a submitter's pose
estimator produced, and returns a predictions table that ``turn-eval score`` reads.

All of the geometry is :mod:`turn_datasets.geometry` (``turning_angle``,
``angular_speed_deg_s``) and :func:`turn_datasets.skeleton.to_z_up`; nothing here re-derives
an angle, so the miner that built Turn-H3.6M and this estimator cannot drift apart.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import METHODS, angular_speed_deg_s, parse_joints, turning_angle
from turn_datasets.mocap.arrays import iter_arrays
from turn_datasets.mocap.checks import check_magnitude
from turn_datasets.skeleton import AUTO, UP_AXIS_CHOICES, Layout, get_layout, to_z_up
from turn_datasets.up_axis import AxesFound, resolve_up_axis, z_up_arrays
from turn_eval.steps import STEP_COLUMNS, turn_steps

__all__ = [
    "PREDICTION_DTYPES",
    "SPEED_DTYPES",
    "clip_arrays",
    "implausible_clips",
    "predict_angle",
    "predict_angles",
]

#: Columns and dtypes of :func:`predict_angles` without ``fps_hz``.
PREDICTION_DTYPES: dict[str, str] = {
    "clip_id": "str",
    "angle_deg": "float64",
    "direction": "str",
}
#: Columns and dtypes of :func:`predict_angles` with ``fps_hz``: the speed, and the clip's
#: peak speed, steps and turn type (:func:`turn_eval.steps.turn_steps`, which needs time).
SPEED_DTYPES: dict[str, str] = {**PREDICTION_DTYPES, "speed_deg_s": "float64", **STEP_COLUMNS}


def _resolve_layout(layout: str | Layout) -> Layout:
    return layout if isinstance(layout, Layout) else get_layout(layout)


def predict_angle(
    positions: np.ndarray,
    *,
    layout: str | Layout,
    up_axis: str = "z",
    joints: str | Sequence[str] = ("hip",),
    method: str = "net",
    fps_hz: float | None = None,
) -> dict[str, float | str]:
    """Turning angle (equation 3), direction and, given a frame rate, speed (equation 4) of one clip.

    Parameters
    ----------
    positions
        ``(n_frames, n_joints, 3)`` joint positions of one clip, in any unit (angles do not
        depend on it), with ``up_axis`` vertical.
    layout
        ``"h36m17"``, ``"h36m32"`` or a :class:`~turn_datasets.skeleton.Layout`.
    up_axis
        ``z``, ``y``, ``-y``, ``x``, ``-x``, ``-z`` (see :func:`turn_datasets.skeleton.to_z_up`)
        or ``auto``: inferred from the trunk (:func:`turn_datasets.up_axis.infer_up_axis`).
    joints
        Any of ``hip``, ``knee``, ``shoulder`` (Table 7's ablation); the paper uses the hip.
    method
        ``net`` (signed net rotation, the paper's stated intent) or ``paper`` (equation 3 as
        printed); see :mod:`turn_datasets.geometry`.
    fps_hz
        Frame rate of the skeletons. When given, ``speed_deg_s`` is the angle over the
        clip's duration ``n_frames / fps_hz``: the same duration the clip index records
        (``(end_frame - start_frame) / fps``), so a predicted speed compares like with like;
        and the clip, taken as one turn, gets ``peak_speed_deg_s``, ``steps`` and
        ``turn_type`` (:func:`turn_eval.steps.turn_steps`; empty without ankles).

    Returns
    -------
    dict
        ``angle_deg``, ``direction`` (``left``, ``right`` or ``none``) and, with ``fps_hz``,
        ``speed_deg_s``, ``peak_speed_deg_s``, ``steps`` and ``turn_type``.
    """
    lay = _resolve_layout(layout)
    p = np.asarray(positions, dtype=float)
    z_up = to_z_up(p, resolve_up_axis(p, lay, up_axis))
    result = turning_angle(z_up, lay, joints=joints, method=method)
    out: dict[str, float | str] = {"angle_deg": result.angle_deg, "direction": result.direction}
    if fps_hz is not None:
        duration_s = result.n_frames / fps_hz
        out["speed_deg_s"] = float(angular_speed_deg_s(result.angle_deg, duration_s))
        whole = turn_steps(z_up, lay, fps_hz, np.array([0]), np.array([z_up.shape[0]]))
        out.update({c: whole[c].iat[0] for c in STEP_COLUMNS})
    return out


def clip_arrays(
    path: str | os.PathLike[str],
    *,
    source_format: str,
    layout: Layout,
    up_axis: str | None,
    found: AxesFound | None = None,
) -> tuple[Iterable[tuple[str, np.ndarray]], str]:
    """The ``(clip id, array)`` pairs of one skeleton file, z up, and the axis now up (``z``).

    ``source_format`` ``arrays``: a generic ``.npy``/``.npz``/``.h5`` whose arrays must have
    ``layout``'s joints, read one at a time; their vertical axis is ``up_axis``, or, when
    None, inferred per array (``auto``: generic arrays do not state their axes). Else an
    estimator's own file by name (:func:`turn_eval.estimate.formats.read_estimator_output`),
    its own axis unless ``up_axis`` is given. The axis used for each array is recorded in
    ``found``.
    """
    if source_format == "arrays":
        named: Iterable[tuple[str, np.ndarray]] = iter_arrays(path, layout=layout)
        axis = up_axis or AUTO
    else:
        # imported here: the estimate package is only needed for an estimator's own files
        from turn_eval.estimate.formats import read_estimator_output

        spec, named = read_estimator_output(path, source_format)
        axis = up_axis or spec.up_axis
    log = found if found is not None else AxesFound(axis)
    # the magnitude check of every skeleton reader, before the axis inference reads them
    checked = ((key, _magnitude_checked(a, path, str(key))) for key, a in named)
    return z_up_arrays(checked, layout=layout, up_axis=axis, found=log), "z"


def _magnitude_checked(array: np.ndarray, path: str | os.PathLike[str], key: str) -> np.ndarray:
    check_magnitude(array, path=path, item=key)
    return array


def predict_angles(
    arrays: Iterable[tuple[str, np.ndarray]],
    *,
    layout: str | Layout,
    up_axis: str = "z",
    joints: str | Sequence[str] = ("hip",),
    method: str = "net",
    fps_hz: float | None = None,
) -> pd.DataFrame:
    """A predictions table from skeletons, one row per clip, in the order given.

    Parameters
    ----------
    arrays
        ``(clip_id, positions)`` pairs, positions ``(n_frames, n_joints, 3)``; for example
        :func:`turn_datasets.mocap.arrays.iter_arrays` of a file.
    layout, up_axis, joints, method, fps_hz
        As in :func:`predict_angle`; checked once, before any clip is read.

    Returns
    -------
    pandas.DataFrame
        ``clip_id, angle_deg, direction`` and, with ``fps_hz``, ``speed_deg_s``
        (:data:`PREDICTION_DTYPES`, :data:`SPEED_DTYPES`): a valid predictions file once
        written as CSV.

    Raises
    ------
    TurnbenchError
        A bad option, a duplicate clip id, or a clip the estimator cannot handle (wrong joint
        count for the layout, an infinite or implausibly large coordinate, fewer than two
        usable frames); the error's ``item`` names the clip.
    """
    lay = _resolve_layout(layout)
    if up_axis not in UP_AXIS_CHOICES:
        raise TurnbenchError(
            f"unknown up axis {up_axis!r}; choose one of {', '.join(UP_AXIS_CHOICES)}"
        )
    if method not in METHODS:
        raise TurnbenchError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    names = parse_joints(joints)
    if fps_hz is not None and not (np.isfinite(fps_hz) and fps_hz > 0):
        raise TurnbenchError(f"the frame rate must be a positive number of Hz, got {fps_hz}")

    rows: list[dict[str, float | str]] = []
    seen: set[str] = set()
    for clip_id, positions in arrays:
        clip_id = str(clip_id)
        if clip_id in seen:
            raise TurnbenchError("duplicate clip id", item=clip_id)
        seen.add(clip_id)
        try:
            # the magnitude check every reader of skeletons applies (no inf, no 1e300)
            check_magnitude(positions, path=None, item=clip_id)
            row = predict_angle(
                positions, layout=lay, up_axis=up_axis, joints=names, method=method, fps_hz=fps_hz
            )
        except TurnbenchError as exc:
            # The geometry does not know which clip it is looking at; say it here.
            raise TurnbenchError(exc.message, item=clip_id, hint=exc.hint) from None
        rows.append({"clip_id": clip_id, **row})
    dtypes = SPEED_DTYPES if fps_hz is not None else PREDICTION_DTYPES
    return typed_frame(pd.DataFrame(rows, columns=list(dtypes)), dtypes)


def implausible_clips(predictions: pd.DataFrame) -> list[str]:
    """Clip ids whose predicted mean speed is above what a person turns at.

    The bound is the miner's and ``detect``'s
    (:data:`turn_datasets.limits.MAX_TURN_MEAN_SPEED_DEG_S`): a trimmed clip's angle over its
    duration beyond it comes from a left/right swap or a flip of the hip vector inside the
    clip, not from the turn. ``predict`` still writes every clip (a submission must cover
    them all) and names these on stderr. Empty without a ``speed_deg_s`` column.
    """
    from turn_datasets import limits

    if "speed_deg_s" not in predictions.columns:
        return []
    fast = predictions["speed_deg_s"].to_numpy(dtype=float) > limits.MAX_TURN_MEAN_SPEED_DEG_S
    return [str(c) for c in predictions.loc[fast, "clip_id"]]
