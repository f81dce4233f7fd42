"""Motion-capture sources: which files a dataset holds, and which reader reads each.

Every reader yields :class:`turn_datasets.skeleton.MocapSequence` objects whose
``positions`` are ``(frames, joints, 3)`` float64 in the z-up, right-handed frame of
DESIGN.md, with the layout, fps and units they came with. Formats (``fmt`` names), one
module each:

``cdf``, ``h36m-h5``, ``videopose-npz``
    Human3.6M's original release, 3d-pose-baseline's copy and VideoPose3D's npz
    (:mod:`turn_datasets.mocap.h36m`).
``bvh``
    Any BVH motion capture (:mod:`turn_datasets.mocap.bvh`): forward kinematics, y up converted to
    z up, fps from ``Frame Time``, joints found by name (CMU's names built in).
``array``
    Generic arrays (``.npy``, ``.npz``, ``.h5``/``.hdf5``) of shape ``(frames, joints, 3)``
    (:mod:`turn_datasets.mocap.arrays`); their layout, fps, up axis and units are not in the
    file and must be given.

This module finds the files (:func:`discover`, by the releases' layouts or by sniffing a
named file) and hands each to its reader (:func:`read_source`).

Bad input raises :class:`TurnbenchError` naming the file (and the sequence inside it):
a truncated or corrupt file, a wrong shape, infinite values, hips that are NaN in every
frame, hips that coincide (fewer than two frames with a usable hip vector, as
:func:`turn_datasets.geometry.usable_frames` decides), an unknown layout or action name
(:mod:`turn_datasets.mocap.checks`).
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import h5py

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import walk_files
from turn_datasets.mocap.arrays import read_arrays
from turn_datasets.mocap.bvh import read_bvh_source
from turn_datasets.mocap.checks import CORRUPT, OnBadSequence
from turn_datasets.mocap.h36m import (
    H36M_H5_DATASET,
    VIDEOPOSE_KEY,
    read_h36m_cdf,
    read_h36m_h5,
    read_videopose_npz,
)
from turn_datasets.render.order import natural_key
from turn_datasets.skeleton import (
    Layout,
    MocapSequence,
)

__all__ = [
    "FORMATS",
    "SourceFile",
    "discover",
    "passed_over_reason",
    "sorted_sources",
    "read_source",
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


# --- Human3.6M action names ---------------------------------------------------------------


# --- finding the files --------------------------------------------------------------------


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
    except CORRUPT:
        return None


def _h5_has_root_dataset(path: Path, name: str) -> bool | None:
    try:
        with h5py.File(path, "r") as fh:
            return isinstance(fh.get(name), h5py.Dataset)
    except CORRUPT:
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
        return "videopose-npz" if VIDEOPOSE_KEY in members else "array"
    if suffix in (".h5", ".hdf5"):
        has = _h5_has_root_dataset(path, H36M_H5_DATASET)
        if has is None:
            raise TurnbenchError("cannot open this HDF5 file (truncated or corrupt?)", file=path)
        return "h36m-h5" if has else "array"
    return None


#: The one npz a walk takes: VideoPose3D's file, at a dataset root. Its data is a pickle,
#: and unpickling can run code, so an npz met deeper in a tree is never read as one.
VIDEOPOSE_FILE = "data_3d_h36m.npz"


def _detect_in_folder(path: Path, root: Path) -> str | None:
    """The format of a file met while walking the dataset root ``root``, by the releases'
    layouts.

    Only world-coordinate 3-D positions are taken: ``D3_Positions`` (not ``D3_Positions_mono``,
    which is in camera coordinates, nor ``D2_Positions`` or ``D3_Angles``), 3d-pose-baseline's
    ``3D_positions``, :data:`VIDEOPOSE_FILE` directly in ``root`` (VideoPose3D's 2-D files are
    left alone, and so is any other npz: a ``cache.npz`` deep in a tree is not a file the
    user meant to unpickle), and any BVH.
    """
    suffix = path.suffix.lower()
    if suffix == ".bvh":
        return "bvh"
    if suffix == ".cdf" and path.absolute().parent.name == "D3_Positions":
        return "cdf"
    if suffix in (".h5", ".hdf5") and path.absolute().parent.name == "3D_positions":
        return "h36m-h5"
    if suffix == ".npz" and path.name == VIDEOPOSE_FILE and path.parent == root:
        # an unreadable or foreign one is reported when read, not skipped unseen
        return "videopose-npz"
    return None


#: Suffixes of files that may hold motion data: a walk that passes one over says so.
_MOTION_SUFFIXES = frozenset(x for xs in _FORMAT_SUFFIXES.values() for x in xs)


def passed_over_reason(path: Path, root: Path, fmt: str | None = None) -> str | None:
    """Why a walk of ``root`` does not read ``path``, a file that may hold motion data, and
    what to run instead; None if it is no such file (or the walk reads it).

    A walk reads only the releases' layouts (:func:`discover`), so a file of another layout
    (a ``data_3d_h36m.npz`` one folder down, an array, a camera-coordinate ``.cdf``) would
    otherwise be left out with nothing said, and the index would quietly miss its subjects.
    """
    suffix = path.suffix.lower()
    if suffix not in _MOTION_SUFFIXES:
        return None
    kind = "array" if fmt == "array" and suffix in _FORMAT_SUFFIXES["array"] else None
    kind = kind or (_detect_in_folder(path, root) if fmt != "array" else None)
    if kind is not None and (fmt is None or kind == fmt):
        return None
    if kind is not None:
        return f"a {kind} file, not the forced --format {fmt}: name it, or drop --format"
    if path.name == VIDEOPOSE_FILE:
        return (
            "VideoPose3D's npz (a pickle) is read only at the top of the folder given: "
            f"run on {path.parent} or name the file"
        )
    if suffix == ".cdf":
        return (
            f"not world 3-D positions (a walk reads D3_Positions/*.cdf, this is in "
            f"{path.parent.name}/): name the file if it is"
        )
    if fmt is not None:
        return f"not a {fmt} file: name it, or force its format"
    return (
        "a generic array, read only when named or with --format array "
        "(and --layout, --fps, --up-axis, --units)"
    )


def discover(
    sources: str | os.PathLike[str] | Iterable[str | os.PathLike[str]],
    *,
    fmt: str | None = None,
    on_unreadable: Callable[[Path, TurnbenchError], None] | None = None,
    on_passed_over: Callable[[Path, str], None] | None = None,
) -> list[SourceFile]:
    """The motion-capture files in the given dataset roots and files, each with its format.

    Parameters
    ----------
    sources
        Dataset roots (folders, walked recursively), files, or a mix.
    fmt
        Force one format (one of :data:`FORMATS`). A named file is then read as that format
        unless its suffix is another format's (``walking.dat`` is read as forced, an ``.npz``
        forced as ``cdf`` is refused); in a folder only files of that format are taken, found as
        below, except ``array``, which takes every ``.npy``/``.npz``/``.h5``/``.hdf5``.
    on_unreadable
        Called with a subfolder that cannot be read and the error naming it; without it,
        that error is raised (a folder is never dropped in silence).
    on_passed_over
        Called with each walked file that may hold motion data but is not read, and why
        (:func:`passed_over_reason`).

    Returns
    -------
    list of SourceFile
        Sorted by path (digit runs as numbers, so S2 before S11), each file once.

    Notes
    -----
    Without ``fmt``, a folder is searched for the layouts of the releases: ``.cdf`` files in
    a ``D3_Positions`` folder (``S*/MyPoseFeatures/D3_Positions``), ``.h5`` files in a
    ``3D_positions`` folder (``S*/MyPoses/3D_positions``), ``data_3d_h36m.npz`` directly in
    the root (VideoPose3D's pickle: no other npz met in a walk is ever unpickled), and
    ``.bvh`` files anywhere; subfolders reached through symbolic links included. Generic
    arrays in a folder are taken only with ``fmt="array"`` (read without unpickling): a
    dataset root holds many arrays that are not skeletons. A file named directly is
    recognised by its suffix and, for ``.npz`` and ``.h5``, by whether it holds
    ``positions_3d`` or ``3D_positions`` (else it is an array).

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
            unreadable: list[tuple[Path, TurnbenchError]] = []

            def report(folder: Path, exc: OSError, unreadable=unreadable) -> None:
                error = TurnbenchError(
                    f"cannot read this folder: {exc.strerror or exc}", file=folder
                )
                if on_unreadable is None:
                    raise error
                unreadable.append((folder, error))
                on_unreadable(folder, error)

            files = walk_files(item, on_unreadable=report)
            if not files and not unreadable:
                raise TurnbenchError("the folder is empty", file=item)
            hits = []
            for f in files:
                if fmt == "array":
                    kind = "array" if f.suffix.lower() in _FORMAT_SUFFIXES["array"] else None
                else:
                    kind = _detect_in_folder(f, item)
                    if fmt is not None and kind != fmt:
                        kind = None
                if kind is not None:
                    hits.append(SourceFile(f, kind))
                elif on_passed_over is not None and (why := passed_over_reason(f, item, fmt)):
                    on_passed_over(f, why)
            if not hits and not unreadable:
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
                suffix = item.suffix.lower()
                known = {x for xs in _FORMAT_SUFFIXES.values() for x in xs}
                # Forced: a suffix no format uses (walking.dat) is the user's to vouch for;
                # another format's suffix (an .npz forced as cdf) is more likely a slip.
                if suffix in known and suffix not in _FORMAT_SUFFIXES[fmt]:
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
        yield from read_h36m_cdf(path)
    elif src.fmt == "h36m-h5":
        yield from read_h36m_h5(path)
    elif src.fmt == "videopose-npz":
        yield from read_videopose_npz(path, on_bad_sequence)
    elif src.fmt == "bvh":
        yield from read_bvh_source(
            path, units=units, joint_map=joint_map, skip_first_frame=skip_first_frame
        )
    elif src.fmt == "array":
        yield from read_arrays(
            path, layout=layout, fps=fps, up_axis=up_axis, units=units, on_bad=on_bad_sequence
        )
    else:
        raise TurnbenchError(
            f"unknown format {src.fmt!r}; choose one of {', '.join(FORMATS)}", file=path
        )


# --- writing (the exact inverse layouts; for tests and the demo corpus) -------------------


# --- generic arrays -----------------------------------------------------------------------
