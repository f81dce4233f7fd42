"""Other pose estimators' 3D output files, read by name: the paper's pipeline as input.

People who run the paper's FastPose + Strided Transformer, or VideoPose3D or MotionBERT,
themselves get ``(frames, 17, 3)`` arrays in Human3.6M's 17-joint order, saved in each
project's own way. ``turn-eval predict --from NAME`` (and ``detect``) read them here, with
the layout, up axis and unit each one writes, so nobody has to know them:

``turnbench``
    ``turn-eval estimate``'s ``.npz``: one array per track, MediaPipe's world frame
    (x to the image's right, y down, z away from the camera; metres; up axis ``-y``).
``strided-transformer``
    The ``.npz`` its video demo writes (``output_3D/output_keypoints_3d.npz``), key
    ``reconstruction``: ``(frames, 17, 3)`` (or with a leading batch axis of 1) after the
    demo's ``camera_to_world``, so z is up (up axis ``z``); metres up to the lifter's scale.
    The demo's *input* file (``input_2D/keypoints.npz``, same key, 2 coordinates) is 2D and
    refused.
``videopose3d``
    ``run.py --viz-export``'s ``.npy`` (``np.save`` of the prediction): ``(frames, 17, 3)``
    in the camera's frame (y down, up axis ``-y``), root-relative metres; an ``.npz`` holding
    one such array is read too. Its *inference* ``.npz`` files (``infer_video_d2.py``'s
    ``keypoints``, ``prepare_data_2d_custom.py``'s ``positions_2d``) are 2D and refused.
``motionbert``
    ``infer_wild.py``'s ``X3D.npy``: ``(frames, 17, 3)``, x right, y down (up axis ``-y``),
    in units of half the image's shorter side (pixels with ``--pixel``). Its stem is always
    ``X3D``, so the clip is named after the folder holding it (``--out_path``).
``alphapose``
    AlphaPose's ``alphapose-results.json`` is 2D keypoints: refused, with the advice to lift
    it to 3D first. Any ``.json`` is refused the same way.

The turning angle needs no unit and tolerates a root-relative skeleton, so every format's
own unit is kept and stated.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap.arrays import iter_arrays, load_numpy, read_npz_member
from turn_datasets.skeleton import H36M17

__all__ = [
    "ESTIMATOR_FORMATS",
    "EstimatorFormat",
    "FORMAT_CHOICES",
    "read_estimator_output",
    "refuse_2d",
]

_LIFTER_HINT = (
    "turnbench needs 3D skeletons: lift the 2D keypoints with a 3D lifter (Strided "
    "Transformer, VideoPose3D, MotionBERT) or run `turn-eval estimate` on the video"
)


@dataclass(frozen=True)
class EstimatorFormat:
    """What an estimator's files hold: the axis that points up and the unit."""

    name: str
    up_axis: str
    units: str
    suffixes: tuple[str, ...]


ESTIMATOR_FORMATS = MappingProxyType(
    {
        "turnbench": EstimatorFormat("turnbench", "-y", "m", (".npz",)),
        "strided-transformer": EstimatorFormat("strided-transformer", "z", "m", (".npz",)),
        "videopose3d": EstimatorFormat("videopose3d", "-y", "m", (".npy", ".npz")),
        "motionbert": EstimatorFormat("motionbert", "-y", "half-image", (".npy",)),
    }
)
#: What ``--from`` accepts: ``arrays`` (generic, the caller states layout and axis), each
#: named format, and ``alphapose`` (refused, to say why).
FORMAT_CHOICES = ("arrays", *ESTIMATOR_FORMATS, "alphapose")

# File stems the tools always write, so the clip is named after a folder instead.
_FIXED_STEMS = {"x3d", "output_keypoints_3d", "keypoints"}
_TOOL_FOLDERS = {"output_3d", "input_2d", "output"}


def _clip_name(path: Path) -> str:
    if path.stem.lower() not in _FIXED_STEMS:
        return path.stem
    for parent in path.absolute().parents:
        if parent.name and parent.name.lower() not in _TOOL_FOLDERS:
            return parent.name
    return path.stem


def _refuse_json(path: Path) -> TurnbenchError:
    return TurnbenchError(
        "AlphaPose's JSON (and any .json) holds 2D keypoints, not 3D skeletons",
        file=path,
        hint=_LIFTER_HINT,
    )


def refuse_2d(paths: Iterable[str | os.PathLike[str]]) -> None:
    """Refuse the first ``.json`` among ``paths`` (AlphaPose's 2D keypoints), saying what
    would serve, before any other file is read."""
    for path in paths:
        if Path(path).suffix.lower() == ".json":
            raise _refuse_json(Path(path))


def _as_h36m17(array: np.ndarray, path: Path, key: str) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim == 4 and a.shape[0] == 1:
        a = a[0]  # Strided Transformer's and VideoPose3D's batch axis of one clip
    if a.ndim == 3 and a.shape[-1] == 2:
        raise TurnbenchError(
            f"array has shape {tuple(a.shape)}: 2D keypoints",
            file=path,
            item=key,
            hint=_LIFTER_HINT,
        )
    if a.ndim != 3 or a.shape[1:] != (H36M17.n_joints, 3):
        raise TurnbenchError(
            f"array has shape {tuple(a.shape)}, expected (frames, 17, 3) in Human3.6M's order",
            file=path,
            item=key,
        )
    if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise TurnbenchError(f"array has dtype {a.dtype}, expected numbers", file=path, item=key)
    # float32 stays float32 (half the memory of a long stream); other types become float64
    return a if a.dtype in (np.float32, np.float64) else a.astype(np.float64)


def _refuse_2d_members(keys: list[str], path: Path) -> None:
    """Refuse a 2D keypoint file by its members' names, before any is read: VideoPose3D's
    ``positions_2d`` is a pickle, never unpickled here, so reading it first would only say
    "pickled"."""
    for two_d in ("positions_2d", "keypoints"):
        if two_d in keys or (two_d == "keypoints" and "boxes" in keys):
            raise TurnbenchError(
                f"this is a 2D keypoint file (it holds {keys})",
                file=path,
                hint=_LIFTER_HINT,
            )


def _npz_arrays(path: Path) -> dict[str, np.ndarray]:
    out = {}
    with load_numpy(path) as archive:
        keys = sorted(archive.files)
        _refuse_2d_members(keys, path)
        for key in keys:
            # declared size checked first; a pickled member or a damaged one is one error
            out[key] = read_npz_member(archive, key, path)
    return out


def _read(path: Path, fmt: EstimatorFormat) -> Iterator[tuple[str, np.ndarray]]:
    if fmt.name == "turnbench":
        for key, array in iter_arrays(path):
            yield key, _as_h36m17(array, path, key)
        return
    if path.suffix.lower() == ".npy":
        yield _clip_name(path), _as_h36m17(load_numpy(path), path, path.stem)
        return
    members = _npz_arrays(path)
    if fmt.name == "strided-transformer":
        if "reconstruction" not in members:
            raise TurnbenchError(
                f"no 'reconstruction' array in this .npz (it holds {sorted(members)})",
                file=path,
                hint="Strided Transformer's demo saves output_3D/output_keypoints_3d.npz",
            )
        yield _clip_name(path), _as_h36m17(members["reconstruction"], path, "reconstruction")
        return
    if len(members) != 1:
        raise TurnbenchError(
            f"expected one prediction array in this .npz, found {sorted(members)}",
            file=path,
            hint="VideoPose3D's --viz-export writes one (frames, 17, 3) array",
        )
    key, array = next(iter(members.items()))
    yield _clip_name(path), _as_h36m17(array, path, key)


def read_estimator_output(
    path: str | os.PathLike[str], fmt: str
) -> tuple[EstimatorFormat, list[tuple[str, np.ndarray]]]:
    """The format's description and ``(name, (frames, 17, 3))`` arrays of one file (float32
    or float64 as stored, other number types float64).

    Arrays keep the estimator's own axes and unit (:class:`EstimatorFormat` says which);
    convert with :func:`turn_datasets.skeleton.to_z_up` and ``up_axis``. The name is the
    clip (or, for a stream, the subject): the array's key for ``turnbench``, else the file's
    stem or, for a tool's fixed output name, the folder it is in.

    Raises
    ------
    TurnbenchError
        An unknown format, AlphaPose or any ``.json`` (2D), a 2D keypoint file, a suffix the
        format does not write, or an array that is not ``(frames, 17, 3)``.
    """
    p = Path(path)
    if p.suffix.lower() == ".json" or fmt == "alphapose":
        raise _refuse_json(p)
    if fmt not in ESTIMATOR_FORMATS:
        raise TurnbenchError(
            f"unknown estimator format {fmt!r}; choose one of {', '.join(ESTIMATOR_FORMATS)}",
            file=p,
        )
    spec = ESTIMATOR_FORMATS[fmt]
    if p.suffix.lower() not in spec.suffixes:
        raise TurnbenchError(
            f"{fmt} writes {' or '.join(spec.suffixes)} files, not {p.suffix or 'no suffix'}",
            file=p,
        )
    if not p.is_file():
        raise TurnbenchError("no such file", file=p)
    return spec, list(_read(p, spec))
