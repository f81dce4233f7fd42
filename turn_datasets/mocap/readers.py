"""Motion-capture readers: every source into z-up world positions, one sequence at a time.

Every reader yields :class:`turn_datasets.skeleton.MocapSequence` objects whose
``positions`` are ``(frames, joints, 3)`` float64 in the z-up, right-handed frame of
DESIGN.md, with the layout, fps and units they came with. Formats (``fmt`` names):

``cdf``
    Human3.6M's original release, ``S*/MyPoseFeatures/D3_Positions/<Action>.cdf``: variable
    ``Pose`` of shape ``(1, N, 96)``, millimetres, 50 Hz, z up, 32 joints (read with cdflib).
``h36m-h5``
    3d-pose-baseline's copy, ``S*/MyPoses/3D_positions/<Action>.h5``: dataset
    ``3D_positions`` stored ``(96, N)``; transposed, then ``(N, 32, 3)``, millimetres.
``videopose-npz``
    VideoPose3D's ``data_3d_h36m.npz``: ``positions_3d``, a *pickled* dict subject -> action
    -> float32 ``(N, 32, 3)`` in metres. Unpickling can run code, so such a file is only
    loaded because the user named it (or the folder holding it); it is loaded once and its
    sequences yielded one by one.
``bvh``
    Any BVH motion capture (:mod:`turn_datasets.mocap.bvh`): forward kinematics, y up converted to
    z up, fps from ``Frame Time``, joints found by name (CMU's names built in).
``array``
    Generic arrays (``.npy``, ``.npz``, ``.h5``/``.hdf5``) of shape ``(frames, joints, 3)``
    (:func:`iter_arrays`); their layout, fps, up axis and units are not in the file and must
    be given.

Human3.6M's subject comes from the ``S<n>`` folder (or the npz key) and the action and trial
from the name on disk (:func:`parse_h36m_action`). BVH and generic arrays take the parent
folder's name as ``subject`` and the file stem (with the array key for ``.npz``/``.h5``) as
``action``, so two files of the same name in different folders stay apart.

Bad input raises :class:`TurnbenchError` naming the file (and the sequence inside it):
a truncated or corrupt file, a wrong shape, infinite values, hips that are NaN in every
frame, hips that coincide (fewer than two frames with a usable hip vector, as
:func:`turn_datasets.geometry.usable_frames` decides), an unknown layout or action name.
"""

from __future__ import annotations

import os
import re
import zipfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import cdflib
import h5py
import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path
from turn_datasets.geometry import usable_frames
from turn_datasets.mocap import bvh as _bvh
from turn_datasets.skeleton import (
    H36M17,
    H36M32,
    UP_AXES,
    Layout,
    MocapSequence,
    get_layout,
    to_z_up,
)

__all__ = [
    "FORMATS",
    "H36M_ACTIONS",
    "H36M_ACTION_ALIASES",
    "UNITS",
    "SourceFile",
    "discover",
    "natural_key",
    "sorted_sources",
    "read_source",
    "iter_arrays",
    "parse_h36m_action",
    "h36m_subject_of",
    "write_h36m_cdf",
    "write_h36m_h5",
    "write_videopose_npz",
]

#: Format names, as ``--format`` takes them.
FORMATS = ("cdf", "h36m-h5", "videopose-npz", "bvh", "array")
_FORMAT_SUFFIXES: Mapping[str, tuple[str, ...]] = MappingProxyType(
    {
        "cdf": (".cdf",),
        "h36m-h5": (".h5", ".hdf5"),
        "videopose-npz": (".npz",),
        "bvh": (".bvh",),
        "array": (".npy", ".npz", ".h5", ".hdf5"),
    }
)
#: Unit names a generic array may be declared in (a label: positions are not rescaled).
UNITS = ("mm", "cm", "m", "in")

H36M_FPS = 50.0
_H36M_CDF_VARIABLE = "Pose"
_H36M_H5_DATASET = "3D_positions"
_VIDEOPOSE_KEY = "positions_3d"

# --- Human3.6M action names ---------------------------------------------------------------

#: The 15 Human3.6M actions, in the one spelling the clip index uses.
H36M_ACTIONS = (
    "Directions",
    "Discussion",
    "Eating",
    "Greeting",
    "Phoning",
    "Photo",
    "Posing",
    "Purchases",
    "Sitting",
    "SittingDown",
    "Smoking",
    "Waiting",
    "WalkDog",
    "Walking",
    "WalkTogether",
)
#: Other spellings found on disk -> the canonical one. Matching ignores case, spaces and
#: underscores, so "Walking Dog" and "walkingdog" are WalkDog too.
H36M_ACTION_ALIASES: Mapping[str, str] = MappingProxyType(
    {
        "TakingPhoto": "Photo",  # S1's name, and some copies of the other subjects
        "WalkingDog": "WalkDog",  # some copies of S1 and of 3d-pose-baseline's files
        "WalkingTogether": "WalkTogether",
    }
)


def _action_key(name: str) -> str:
    return re.sub(r"[\s_]+", "", name).lower()


_ACTION_TABLE: Mapping[str, str] = MappingProxyType(
    {
        **{_action_key(a): a for a in H36M_ACTIONS},
        **{_action_key(k): v for k, v in H36M_ACTION_ALIASES.items()},
    }
)
# "<name>[ <trial>][.<camera id>]", e.g. "Walking", "Walking 1", "Walking 1.54138969"
_ACTION_RE = re.compile(
    r"^(?P<name>[A-Za-z][A-Za-z _]*?)(?:[ _]+(?P<trial>\d+))?(?:\.(?P<camera>\d+))?$"
)


def parse_h36m_action(name: str) -> tuple[str, str]:
    """A Human3.6M action name as found on disk -> ``(canonical action, subaction)``.

    ========================================  ==================  ==========
    on disk                                   action              subaction
    ========================================  ==================  ==========
    ``Walking``                               ``Walking``         ``""``
    ``Walking 1``                             ``Walking``         ``"1"``
    ``Walking 1.54138969`` (camera suffix)    ``Walking``         ``"1"``
    ``TakingPhoto``, ``TakingPhoto 1``        ``Photo``           ``""``, ``"1"``
    ``Photo``, ``Photo 2``                    ``Photo``           ``""``, ``"2"``
    ``WalkDog 1``, ``WalkingDog``             ``WalkDog``         ``"1"``, ``""``
    ``WalkTogether``, ``WalkingTogether 1``   ``WalkTogether``    ``""``, ``"1"``
    ``Discussion 1``, ``Directions 2``        as written          ``"1"``, ``"2"``
    ========================================  ==================  ==========

    The canonical actions are :data:`H36M_ACTIONS`; the other spellings are
    :data:`H36M_ACTION_ALIASES` (case, spaces and underscores are ignored when matching).

    The subaction is the trial number exactly as the file name writes it, ``""`` when there
    is none. Human3.6M records each action twice per subject and names the two files
    inconsistently: mostly ``"Walking"`` and ``"Walking 1"``, but S1 has ``"Eating"`` and
    ``"Eating 2"`` and S5 ``"Discussion 2"`` and ``"Discussion 3"``. Keeping the number as
    written keeps every (subject, action, subaction) unique and traceable to its file;
    renumbering to 1/2 would need a per-subject table that no release documents. S11 lacks
    ``"Directions 2"`` in some copies; that is a missing file, not a naming problem.

    Raises
    ------
    TurnbenchError
        A name that is none of the 15 actions.
    """
    match = _ACTION_RE.match(name.strip())
    canonical = _ACTION_TABLE.get(_action_key(match.group("name"))) if match else None
    if match is None or canonical is None:
        raise TurnbenchError(
            f"{name!r} is not a Human3.6M action name; expected one of "
            f"{', '.join(H36M_ACTIONS)} (or {', '.join(H36M_ACTION_ALIASES)}), optionally "
            "followed by a trial number"
        )
    return canonical, match.group("trial") or ""


_SUBJECT_RE = re.compile(r"^S\d+$")


def h36m_subject_of(path: str | os.PathLike[str]) -> str:
    """The Human3.6M subject (``"S9"``) of a file: the nearest ``S<n>`` folder above it."""
    for parent in Path(path).absolute().parents:
        if _SUBJECT_RE.match(parent.name):
            return parent.name
    raise TurnbenchError(
        "cannot tell the Human3.6M subject: the file is not inside an S<n> folder",
        file=path,
        hint="keep the release's layout, e.g. S1/MyPoseFeatures/D3_Positions/Walking.cdf",
    )


def natural_key(text: str) -> tuple:
    """Sort key putting "S2" before "S11": runs of digits compare as numbers, the rest as text.

    The one ordering of subjects, actions and file paths in the index, the manifest and the
    statistics.
    """
    return tuple((0, int(t), "") if t.isdigit() else (1, 0, t) for t in re.split(r"(\d+)", text))


# --- finding the files --------------------------------------------------------------------

# What a library may raise when it parses a truncated or corrupt file. Truncating and
# flipping bytes of files of every format met ValueError, OSError, EOFError, KeyError,
# IndexError from all of them, but also h5py's RuntimeError (a damaged symbol table),
# cdflib's MemoryError and OverflowError (a record size read from garbage), zlib.error (a
# damaged deflate stream) and tokenize.TokenError (a damaged .npy header), and unpickling
# VideoPose3D's dict can raise anything. So each read site wraps the library call alone (no
# code of ours inside) and reports any exception from it as an unreadable file, naming it.
_CORRUPT = (Exception,)


#: Called with the error of one unusable sequence of a multi-sequence file (see
#: :func:`read_source`'s ``on_bad_sequence``).
OnBadSequence = Callable[[TurnbenchError], None]


@dataclass(frozen=True)
class SourceFile:
    """One file to read and the format it is read as (one of :data:`FORMATS`)."""

    path: Path
    fmt: str


def _npz_members(path: Path) -> list[str] | None:
    """Names of the arrays in an ``.npz`` without loading (or unpickling) them; None if unreadable."""
    try:
        with zipfile.ZipFile(path) as zf:
            return [n[:-4] if n.endswith(".npy") else n for n in zf.namelist()]
    except _CORRUPT:
        return None


def _h5_has_root_dataset(path: Path, name: str) -> bool | None:
    try:
        with h5py.File(path, "r") as fh:
            return isinstance(fh.get(name), h5py.Dataset)
    except _CORRUPT:
        return None


def _sniff_file(path: Path) -> str | None:
    """The format of a file the user named, from its suffix and, where needed, its contents."""
    suffix = path.suffix.lower()
    if suffix == ".cdf":
        return "cdf"
    if suffix == ".bvh":
        return "bvh"
    if suffix == ".npy":
        return "array"
    if suffix == ".npz":
        members = _npz_members(path)
        if members is None:
            raise TurnbenchError("cannot open this .npz (truncated or corrupt?)", file=path)
        return "videopose-npz" if _VIDEOPOSE_KEY in members else "array"
    if suffix in (".h5", ".hdf5"):
        has = _h5_has_root_dataset(path, _H36M_H5_DATASET)
        if has is None:
            raise TurnbenchError("cannot open this HDF5 file (truncated or corrupt?)", file=path)
        return "h36m-h5" if has else "array"
    return None


def _detect_in_folder(path: Path) -> str | None:
    """The format of a file met while walking a dataset root, by the releases' layouts.

    Only world-coordinate 3-D positions are taken: ``D3_Positions`` (not ``D3_Positions_mono``,
    which is in camera coordinates, nor ``D2_Positions`` or ``D3_Angles``), 3d-pose-baseline's
    ``3D_positions``, an npz holding ``positions_3d`` (VideoPose3D's 2-D files hold
    ``positions_2d`` and are left alone), and any BVH.
    """
    suffix = path.suffix.lower()
    if suffix == ".bvh":
        return "bvh"
    if suffix == ".cdf" and path.absolute().parent.name == "D3_Positions":
        return "cdf"
    if suffix in (".h5", ".hdf5") and path.absolute().parent.name == "3D_positions":
        return "h36m-h5"
    if suffix == ".npz":
        members = _npz_members(path)
        if members is None:
            # an unreadable VideoPose3D file is reported when read, not skipped unseen
            return "videopose-npz" if path.name.startswith("data_3d") else None
        return "videopose-npz" if _VIDEOPOSE_KEY in members else None
    return None


def _walk_files(root: Path) -> list[Path]:
    out: list[Path] = []
    for dirpath, dirnames, filenames in os.walk(root):
        # hidden folders and files (.git, macOS's ._Walking.cdf) are never data
        dirnames[:] = [d for d in dirnames if not d.startswith(".")]
        out.extend(Path(dirpath) / f for f in filenames if not f.startswith("."))
    return out


def discover(
    sources: str | os.PathLike[str] | Iterable[str | os.PathLike[str]], *, fmt: str | None = None
) -> list[SourceFile]:
    """The motion-capture files in the given dataset roots and files, each with its format.

    Parameters
    ----------
    sources
        Dataset roots (folders, walked recursively), files, or a mix.
    fmt
        Force one format (one of :data:`FORMATS`). A named file is then read as that format
        (its suffix must fit); in a folder only files of that format are taken, found as
        below, except ``array``, which takes every ``.npy``/``.npz``/``.h5``/``.hdf5``.

    Returns
    -------
    list of SourceFile
        Sorted by path (digit runs as numbers, so S2 before S11), each file once.

    Notes
    -----
    Without ``fmt``, a folder is searched for the layouts of the releases: ``.cdf`` files in
    a ``D3_Positions`` folder (``S*/MyPoseFeatures/D3_Positions``), ``.h5`` files in a
    ``3D_positions`` folder (``S*/MyPoses/3D_positions``), ``.npz`` files holding
    ``positions_3d`` (``data_3d_h36m.npz``), and ``.bvh`` files anywhere. Generic arrays in a
    folder are taken only with ``fmt="array"``: a dataset root holds many arrays that are not
    skeletons. A file named directly is recognised by its suffix and, for ``.npz`` and
    ``.h5``, by whether it holds ``positions_3d`` or ``3D_positions`` (else it is an array).

    Raises
    ------
    TurnbenchError
        A missing path, an empty folder, a folder or file in which nothing is recognised, an
        unknown ``fmt``, a file whose suffix does not fit ``fmt``.
    """
    if fmt is not None and fmt not in FORMATS:
        raise TurnbenchError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    if isinstance(sources, (str, os.PathLike)):
        sources = [sources]
    items = [Path(s) for s in sources]
    if not items:
        raise TurnbenchError("no source given: name a dataset folder or files")
    found: list[SourceFile] = []
    for item in items:
        if item.is_dir():
            files = _walk_files(item)
            if not files:
                raise TurnbenchError("the folder is empty", file=item)
            hits = []
            for f in files:
                if fmt == "array":
                    kind = "array" if f.suffix.lower() in _FORMAT_SUFFIXES["array"] else None
                else:
                    kind = _detect_in_folder(f)
                    if fmt is not None and kind != fmt:
                        kind = None
                if kind is not None:
                    hits.append(SourceFile(f, kind))
            if not hits:
                wanted = f"no {fmt} file" if fmt else "no motion-capture file"
                raise TurnbenchError(
                    f"{wanted} recognised in this folder ({len(files)} files)",
                    file=item,
                    hint="expected S*/MyPoseFeatures/D3_Positions/*.cdf, "
                    "S*/MyPoses/3D_positions/*.h5, data_3d_h36m.npz or *.bvh; name files "
                    "directly, or force a format (generic arrays need --format array)",
                )
            found.extend(hits)
        elif item.is_file():
            if fmt is not None:
                if item.suffix.lower() not in _FORMAT_SUFFIXES[fmt]:
                    raise TurnbenchError(
                        f"a {fmt} file should end in {' or '.join(_FORMAT_SUFFIXES[fmt])}",
                        file=item,
                    )
                kind = fmt
            else:
                kind = _sniff_file(item)
                if kind is None:
                    raise TurnbenchError(
                        f"unknown format (suffix {item.suffix or 'none'!r}); expected one of "
                        ".cdf, .h5, .hdf5, .npz, .npy, .bvh",
                        file=item,
                    )
            found.append(SourceFile(item, kind))
        else:
            raise TurnbenchError("no such file or folder", file=item)
    return sorted_sources(found)


def sorted_sources(found: Iterable[SourceFile]) -> list[SourceFile]:
    """Source files sorted by path (:func:`natural_key`), each file once (by its real path)."""
    out: list[SourceFile] = []
    seen: set[Path] = set()
    for src in sorted(found, key=lambda s: (natural_key(str(s.path)), s.fmt)):
        key = src.path.resolve()
        if key not in seen:
            seen.add(key)
            out.append(src)
    return out


# --- reading ------------------------------------------------------------------------------


def _checked_positions(
    positions: np.ndarray, layout: Layout, *, path: Path, item: str | None
) -> np.ndarray:
    """Float64 ``(frames, joints, 3)`` positions with usable hips, or a TurnbenchError."""
    p = np.asarray(positions)
    if p.ndim != 3 or p.shape[2] != 3 or p.shape[1] != layout.n_joints:
        raise TurnbenchError(
            f"positions have shape {tuple(p.shape)}, expected (frames, {layout.n_joints}, 3) "
            f"for layout {layout.name!r}",
            file=path,
            item=item,
        )
    if p.shape[0] == 0:
        raise TurnbenchError("the sequence has no frames", file=path, item=item)
    if not (np.issubdtype(p.dtype, np.floating) or np.issubdtype(p.dtype, np.integer)):
        raise TurnbenchError(
            f"positions have dtype {p.dtype}, expected numbers", file=path, item=item
        )
    p = np.ascontiguousarray(p, dtype=np.float64)
    if np.isinf(p).any():
        raise TurnbenchError("positions hold infinite values (corrupt?)", file=path, item=item)
    hips = p[:, [layout.index("left_hip"), layout.index("right_hip")], :2]
    if not np.isfinite(hips).all(axis=(1, 2)).any():
        raise TurnbenchError("the left or right hip is NaN in every frame", file=path, item=item)
    n_usable = int(usable_frames(p, layout, "hip").sum())
    if n_usable < 2:
        raise TurnbenchError(
            f"the left and right hips coincide (or are missing) in all but {n_usable} of "
            f"{p.shape[0]} frames: no hip direction to measure",
            file=path,
            item=item,
        )
    return p


def _h36m_file_sequence(
    path: Path, positions: np.ndarray, fmt: str, subject: str, action: tuple[str, str]
) -> MocapSequence:
    """One Human3.6M sequence stored one per file (CDF, h5): 32 joints, 50 Hz, millimetres."""
    return MocapSequence(
        subject=subject,
        action=action[0],
        subaction=action[1],
        positions=_checked_positions(positions, H36M32, path=path, item=None),
        layout=H36M32,
        fps=H36M_FPS,
        units="mm",
        source=str(path),
        meta={"format": fmt, "name_on_disk": path.stem},
    )


def _read_cdf(path: Path) -> Iterator[MocapSequence]:
    # subject and action first: a file outside the release's layout is refused unread
    subject = h36m_subject_of(path)
    action = _action_of(path.stem, path)
    try:
        pose = np.asarray(cdflib.CDF(path).varget(_H36M_CDF_VARIABLE))
    except _CORRUPT as exc:
        raise TurnbenchError(
            f"cannot read variable {_H36M_CDF_VARIABLE!r} (truncated or corrupt CDF?): {exc}",
            file=path,
        ) from None
    if pose.ndim == 3 and pose.shape[0] == 1:
        pose = pose[0]
    if pose.ndim != 2 or pose.shape[1] != 96:
        raise TurnbenchError(
            f"variable {_H36M_CDF_VARIABLE!r} has shape {pose.shape}, expected (1, N, 96)",
            file=path,
        )
    yield _h36m_file_sequence(path, pose.reshape(pose.shape[0], 32, 3), "cdf", subject, action)


def _read_h36m_h5(path: Path) -> Iterator[MocapSequence]:
    subject = h36m_subject_of(path)
    action = _action_of(path.stem, path)
    stored, names = None, []
    try:
        with h5py.File(path, "r") as fh:
            dset = fh.get(_H36M_H5_DATASET)
            if isinstance(dset, h5py.Dataset):
                stored = np.asarray(dset[()])
            else:
                names = sorted(fh)
    except _CORRUPT as exc:
        raise TurnbenchError(
            f"cannot read HDF5 (truncated or corrupt?): {exc}", file=path
        ) from None
    if stored is None:
        raise TurnbenchError(f"no dataset {_H36M_H5_DATASET!r} (datasets: {names})", file=path)
    if stored.ndim != 2 or stored.shape[0] != 96:
        raise TurnbenchError(
            f"dataset {_H36M_H5_DATASET!r} has shape {stored.shape}, expected (96, N)",
            file=path,
        )
    # 3d-pose-baseline stores one column per frame: transpose, then 32 joints x 3
    yield _h36m_file_sequence(
        path, stored.T.reshape(stored.shape[1], 32, 3), "h36m-h5", subject, action
    )


def _action_of(name: str, path: Path, item: str | None = None) -> tuple[str, str]:
    try:
        return parse_h36m_action(name)
    except TurnbenchError as exc:
        raise TurnbenchError(exc.message, file=path, item=item) from None


def _read_videopose_npz(path: Path, on_bad: OnBadSequence | None) -> Iterator[MocapSequence]:
    # allow_pickle: positions_3d is a pickled dict; only loaded from a file the user named
    data, members = None, []
    try:
        with np.load(path, allow_pickle=True) as archive:
            if _VIDEOPOSE_KEY in archive.files:
                data = archive[_VIDEOPOSE_KEY]
            else:
                members = sorted(archive.files)
    except _CORRUPT as exc:
        raise TurnbenchError(
            f"cannot read this npz (truncated or corrupt?): {exc}", file=path
        ) from None
    if data is None:
        raise TurnbenchError(f"no {_VIDEOPOSE_KEY!r} in this npz (it holds {members})", file=path)
    if data.dtype == object and data.shape == ():
        data = data.item()
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise TurnbenchError(
            f"{_VIDEOPOSE_KEY!r} is not a dict subject -> action -> array", file=path
        )
    for subject in sorted(data, key=lambda s: natural_key(str(s))):
        actions = data[subject]
        for name in sorted(actions, key=lambda a: natural_key(str(a))):
            item = f"{subject}/{name}"
            array = np.asarray(actions[name])
            layout = H36M17 if array.ndim == 3 and array.shape[1] == 17 else H36M32
            try:
                action, subaction = _action_of(str(name), path, item)
                positions = _checked_positions(array, layout, path=path, item=item)
            except TurnbenchError as exc:
                if on_bad is None:
                    raise
                on_bad(exc)
                continue
            yield MocapSequence(
                subject=str(subject),
                action=action,
                subaction=subaction,
                positions=positions,
                layout=layout,
                fps=H36M_FPS,
                units="m",
                source=str(path),
                meta={"format": "videopose-npz", "name_on_disk": str(name), "key": item},
            )


def _read_bvh(
    path: Path,
    *,
    units: str | None,
    joint_map: Mapping[str, str] | None,
    skip_first_frame: bool | None,
) -> Iterator[MocapSequence]:
    seq = _bvh.read_bvh(path, joint_map=joint_map, skip_first_frame=skip_first_frame)
    yield MocapSequence(
        subject=path.absolute().parent.name,
        action=path.stem,
        subaction="",
        positions=_checked_positions(seq.positions, seq.layout, path=path, item=None),
        layout=seq.layout,
        fps=seq.fps,
        # BVH does not state its unit: the label is the user's, or "bvh" (the file's own)
        units=units or "bvh",
        source=str(path),
        meta={
            "format": "bvh",
            "n_frames_in_file": seq.n_frames_in_file,
            "skipped_first_frame": seq.skipped_first_frame,
        },
    )


def _read_arrays(
    path: Path,
    *,
    layout: str | Layout | None,
    fps: float | None,
    up_axis: str | None,
    units: str | None,
    on_bad: OnBadSequence | None,
) -> Iterator[MocapSequence]:
    missing = [
        opt
        for opt, value in (
            ("--layout", layout),
            ("--fps", fps),
            ("--up-axis", up_axis),
            ("--units", units),
        )
        if value is None
    ]
    if missing:
        raise TurnbenchError(
            f"a generic array does not say its {', '.join(m.lstrip('-') for m in missing)}",
            file=path,
            hint=f"give {' '.join(missing)} (layout: h36m32 or h36m17; up axis: "
            f"{'/'.join(UP_AXES)}; units: {'/'.join(UNITS)})",
        )
    try:
        lay = layout if isinstance(layout, Layout) else get_layout(str(layout))
    except TurnbenchError as exc:
        raise TurnbenchError(exc.message, file=path) from None
    if not (np.isfinite(fps) and fps > 0):
        raise TurnbenchError(f"fps must be positive, got {fps}", file=path)
    if up_axis not in UP_AXES:
        raise TurnbenchError(
            f"unknown up axis {up_axis!r}; choose one of {', '.join(UP_AXES)}", file=path
        )
    if units not in UNITS:
        raise TurnbenchError(
            f"unknown units {units!r}; choose one of {', '.join(UNITS)}", file=path
        )
    single = path.suffix.lower() == ".npy"
    for key, array in iter_arrays(path, on_bad_array=on_bad):
        item = None if single else key
        try:
            if array.shape[1] != lay.n_joints:
                raise TurnbenchError(
                    f"array has {array.shape[1]} joints but layout {lay.name!r} has "
                    f"{lay.n_joints} (shape {tuple(array.shape)})",
                    file=path,
                    item=item,
                )
            positions = to_z_up(np.asarray(array, dtype=np.float64), up_axis)
            positions = _checked_positions(positions, lay, path=path, item=item)
        except TurnbenchError as exc:
            if on_bad is None or single:
                raise
            on_bad(exc)
            continue
        yield MocapSequence(
            subject=path.absolute().parent.name,
            action=path.stem if single else f"{path.stem}.{key.replace('/', '.')}",
            subaction="",
            positions=positions,
            layout=lay,
            fps=float(fps),
            units=units,
            source=str(path),
            meta={"format": "array", "key": key, "up_axis": up_axis},
        )


def read_source(
    src: SourceFile | str | os.PathLike[str],
    *,
    layout: str | Layout | None = None,
    fps: float | None = None,
    up_axis: str | None = None,
    units: str | None = None,
    joint_map: Mapping[str, str] | None = None,
    skip_first_frame: bool | None = None,
    on_bad_sequence: OnBadSequence | None = None,
) -> Iterator[MocapSequence]:
    """Yield the sequences of one source file, one at a time, as z-up float64 positions.

    Parameters
    ----------
    src
        A :class:`SourceFile` from :func:`discover`, or a path (its format sniffed).
    layout, fps, up_axis, units
        What a generic array does not say: all four are required for ``array`` files
        (layout ``h36m32``/``h36m17`` or a :class:`Layout`, fps in frames per second, up axis
        one of ``z``, ``y``, ``-y``, units one of :data:`UNITS`). The Human3.6M formats state
        all of them (32 joints, 50 Hz, z up; mm, or m for VideoPose3D) and BVH states its
        joints and fps, so these options do not apply to them and a run over a mix of
        formats can pass them for its arrays alone; ``units`` also labels a BVH's unit.
    joint_map
        BVH only: our joint name -> BVH joint name, over CMU's built-in names
        (:data:`turn_datasets.mocap.bvh.CMU_JOINT_MAP`).
    skip_first_frame
        BVH only: ``True`` drops frame 0, ``False`` keeps it; ``None`` (default) drops it only
        when it is the rest pose that CMU's conversion adds
        (:func:`turn_datasets.mocap.bvh.first_frame_is_rest_pose`).
    on_bad_sequence
        Files holding several sequences (VideoPose3D's npz, a generic ``.npz``/``.h5``):
        when given, a sequence that cannot be used (an unknown action name, a wrong shape,
        unusable hips, an array that cannot be read) is passed to it as a
        :class:`TurnbenchError` naming the file and the sequence, and the others are still
        read; when None, it is raised. A problem with the file itself is always raised.

    Yields
    ------
    MocapSequence
        Memory is bounded by one sequence (for VideoPose3D's npz, by the file's pickled
        dict, loaded once).

    Raises
    ------
    TurnbenchError
        Naming the file (and the sequence inside it): see the module docstring.
    """
    if not isinstance(src, SourceFile):
        if Path(src).is_dir():
            raise TurnbenchError(
                "read_source reads one file; list a folder's files with discover()", file=src
            )
        (src,) = discover([src])
    path = Path(src.path)
    if not path.is_file():
        raise TurnbenchError("no such file", file=path)
    if src.fmt == "cdf":
        yield from _read_cdf(path)
    elif src.fmt == "h36m-h5":
        yield from _read_h36m_h5(path)
    elif src.fmt == "videopose-npz":
        yield from _read_videopose_npz(path, on_bad_sequence)
    elif src.fmt == "bvh":
        yield from _read_bvh(
            path, units=units, joint_map=joint_map, skip_first_frame=skip_first_frame
        )
    elif src.fmt == "array":
        yield from _read_arrays(
            path, layout=layout, fps=fps, up_axis=up_axis, units=units, on_bad=on_bad_sequence
        )
    else:
        raise TurnbenchError(
            f"unknown format {src.fmt!r}; choose one of {', '.join(FORMATS)}", file=path
        )


# --- writing (the exact inverse layouts; for tests and the demo corpus) -------------------


def _check_h36m_positions(positions: np.ndarray) -> np.ndarray:
    p = np.asarray(positions)
    if p.ndim != 3 or p.shape[1:] != (32, 3) or not np.issubdtype(p.dtype, np.floating):
        raise ValueError(f"expected float positions of shape (N, 32, 3), got {p.dtype} {p.shape}")
    return p


def write_h36m_cdf(path: str | os.PathLike[str], positions_mm: np.ndarray) -> Path:
    """Write ``positions_mm`` ``(N, 32, 3)`` as Human3.6M's ``D3_Positions`` CDF, atomically.

    Variable ``Pose``, one record of ``(N, 96)`` (read back as ``(1, N, 96)``), float32 data
    stored as CDF_FLOAT and anything else as CDF_DOUBLE, uncompressed, with cdflib's writer.
    """
    p = _check_h36m_positions(positions_mm)
    data = p.reshape(1, p.shape[0], 96)
    cdf_type = 44 if p.dtype == np.float32 else 45  # CDF_FLOAT, CDF_DOUBLE
    if cdf_type == 45:
        data = data.astype(np.float64)
    target = Path(path)
    with atomic_path(target) as tmp:
        # cdflib appends ".cdf" to a name without it and refuses an existing file
        cdf_tmp = tmp.with_name(tmp.name + ".cdf")
        tmp.unlink()
        try:
            writer = cdflib.cdfwrite.CDF(cdf_tmp, cdf_spec={"Compressed": False})
            writer.write_var(
                {
                    "Variable": _H36M_CDF_VARIABLE,
                    "Data_Type": cdf_type,
                    "Num_Elements": 1,
                    "Rec_Vary": True,
                    "Dim_Sizes": [p.shape[0], 96],
                    "Compress": 0,
                },
                var_data=data,
            )
            writer.close()
            os.replace(cdf_tmp, tmp)
        finally:
            if cdf_tmp.exists():
                cdf_tmp.unlink()
    return target


def write_h36m_h5(path: str | os.PathLike[str], positions_mm: np.ndarray) -> Path:
    """Write ``positions_mm`` ``(N, 32, 3)`` as 3d-pose-baseline's h5, atomically.

    Dataset ``3D_positions`` of shape ``(96, N)`` (one column per frame), the dtype kept,
    without timestamps so the bytes depend only on the data.
    """
    p = _check_h36m_positions(positions_mm)
    target = Path(path)
    with atomic_path(target) as tmp:
        with h5py.File(tmp, "w", track_order=False) as fh:
            fh.create_dataset(_H36M_H5_DATASET, data=p.reshape(p.shape[0], 96).T, track_times=False)
    return target


def write_videopose_npz(
    path: str | os.PathLike[str],
    data: Mapping[str, Mapping[str, np.ndarray]],
    *,
    compressed: bool = True,
) -> Path:
    """Write VideoPose3D's ``data_3d_h36m.npz`` layout, atomically and reproducibly.

    Parameters
    ----------
    data
        subject -> action name (as on disk, e.g. ``"Walking 1"``) -> ``(N, 32, 3)`` metres,
        stored float32 as VideoPose3D does, in a pickled dict under ``positions_3d``.
    compressed
        Deflate the archive as VideoPose3D's ``np.savez_compressed`` does (the default), or
        store it (as ``np.savez``): several times faster to write for a large synthetic
        corpus, and read the same way.

    Notes
    -----
    Written as ``np.savez_compressed`` (or ``np.savez``) would, but with a fixed timestamp
    in the zip entry, so the same data gives the same bytes.
    """
    payload: dict[str, dict[str, np.ndarray]] = {}
    for subject, actions in data.items():
        payload[str(subject)] = {}
        for name, positions in actions.items():
            p = _check_h36m_positions(positions)
            payload[str(subject)][str(name)] = p.astype(np.float32)
    obj = np.empty((), dtype=object)
    obj[()] = payload
    target = Path(path)
    with atomic_path(target) as tmp:
        method = zipfile.ZIP_DEFLATED if compressed else zipfile.ZIP_STORED
        info = zipfile.ZipInfo(f"{_VIDEOPOSE_KEY}.npy", date_time=(1980, 1, 1, 0, 0, 0))
        info.compress_type = method
        with zipfile.ZipFile(tmp, "w", compression=method) as zf:
            with zf.open(info, "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, obj, allow_pickle=True)
    return target


# --- generic arrays -----------------------------------------------------------------------

ARRAY_SUFFIXES = (".npy", ".npz", ".h5", ".hdf5")


def _check_tj3(array: np.ndarray, *, path: Path, key: str) -> np.ndarray:
    if array.ndim != 3 or array.shape[2] != 3 or array.shape[0] < 1 or array.shape[1] < 1:
        raise TurnbenchError(
            f"array has shape {tuple(array.shape)}, expected (frames, joints, 3)",
            file=path,
            item=key,
        )
    if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
        raise TurnbenchError(
            f"array has dtype {array.dtype}, expected numbers", file=path, item=key
        )
    return array


def _h5_dataset_names(group: h5py.Group) -> list[str]:
    names: list[str] = []

    def visit(name: str, obj: object) -> None:
        if isinstance(obj, h5py.Dataset):
            names.append(name)

    group.visititems(visit)
    return sorted(names)


def iter_arrays(
    path: str | os.PathLike[str], *, on_bad_array: OnBadSequence | None = None
) -> Iterator[tuple[str, np.ndarray]]:
    """Yield ``(name, array)`` for each ``(frames, joints, 3)`` array in a generic array file.

    Parameters
    ----------
    path
        ``.npy`` -> one ``(file stem, array)``; ``.npz`` -> one ``(key, array)`` per array, in
        the archive's sorted key order, loaded without pickles; ``.h5``/``.hdf5`` -> one
        ``(dataset path, array)`` per dataset, nested groups walked, sorted by path.
    on_bad_array
        ``.npz``/``.h5``: when given, an array that cannot be read or is not
        ``(frames, joints, 3)`` is passed to it (a :class:`TurnbenchError` naming the file and
        the key) and the others are still yielded; when None, it is raised.

    Yields
    ------
    name, array
        The array as stored (its dtype unchanged), read one at a time so memory is bounded by
        the largest array.

    Raises
    ------
    TurnbenchError
        An unknown suffix, an unreadable (truncated, corrupt, pickled) file, a file holding no
        array, or an array that is not numeric ``(frames, joints, 3)``; the message names the
        file, the key and the shape.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in ARRAY_SUFFIXES:
        raise TurnbenchError(
            f"not a generic array file (expected one of {', '.join(ARRAY_SUFFIXES)})", file=p
        )
    if not p.is_file():
        raise TurnbenchError("no such file", file=p)
    if suffix == ".npy":
        try:
            array = np.load(p, allow_pickle=False)
        except _CORRUPT as exc:
            raise TurnbenchError(
                f"cannot read .npy (truncated or corrupt?): {exc}", file=p
            ) from None
        yield p.stem, _check_tj3(array, path=p, key=p.stem)
        return
    if suffix == ".npz":
        try:
            archive = np.load(p, allow_pickle=False)
        except _CORRUPT as exc:
            raise TurnbenchError(
                f"cannot read .npz (truncated or corrupt?): {exc}", file=p
            ) from None
        with archive:
            keys = sorted(archive.files)
            if not keys:
                raise TurnbenchError("the .npz archive holds no array", file=p)
            for key in keys:
                try:
                    try:
                        array = archive[key]
                    except _CORRUPT as exc:
                        raise TurnbenchError(
                            f"cannot read this array (pickled, truncated or corrupt?): {exc}",
                            file=p,
                            item=key,
                        ) from None
                    array = _check_tj3(array, path=p, key=key)
                except TurnbenchError as exc:
                    if on_bad_array is None:
                        raise
                    on_bad_array(exc)
                    continue
                yield key, array
        return
    try:
        fh = h5py.File(p, "r")
    except _CORRUPT as exc:
        raise TurnbenchError(f"cannot read HDF5 (truncated or corrupt?): {exc}", file=p) from None
    with fh:
        try:
            names = _h5_dataset_names(fh)
        except _CORRUPT as exc:
            raise TurnbenchError(
                f"cannot list the datasets (truncated or corrupt?): {exc}", file=p
            ) from None
        if not names:
            raise TurnbenchError("the HDF5 file holds no dataset", file=p)
        for name in names:
            try:
                try:
                    array = fh[name][()]
                except _CORRUPT as exc:
                    raise TurnbenchError(
                        f"cannot read this dataset (truncated or corrupt?): {exc}",
                        file=p,
                        item=name,
                    ) from None
                array = _check_tj3(np.asarray(array), path=p, key=name)
            except TurnbenchError as exc:
                if on_bad_array is None:
                    raise
                on_bad_array(exc)
                continue
            yield name, array
