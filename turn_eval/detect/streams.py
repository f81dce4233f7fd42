"""Skeleton streams: the one reader of pose estimators' array files for ``predict`` and ``detect``.

A *stream* is the skeleton of one person over a whole recording: ``(frames, joints, 3)``
positions, NaN on frames where the person is not seen. Files hold streams as
:func:`turn_datasets.mocap.arrays.iter_arrays` reads them:

``.npz``
    One array per person; the file's stem is the **session**, each key a **subject**
    (``P01_home.npz`` with keys ``P01`` and ``P01-partner``).
``.h5`` / ``.hdf5``
    One dataset per person; the stem is the session, the dataset path (nested groups
    joined by ``/``) the subject.
``.npy``
    One person. The stem names both: ``SESSION__SUBJECT.npy`` (split at the first double
    underscore); a stem without ``__`` is a session of one person, whose subject is the
    stem itself.

A folder given as input is walked (sorted, sub-folders included) for these suffixes.
Positions may be absolute or root-relative (the pelvis at the origin, as most 2D-to-3D
lifters write them); any length unit. They are turned to DESIGN.md's z-up frame here, once,
with :func:`turn_datasets.skeleton.to_z_up`, in the stored precision (float32 stays float32:
a day at 30 fps is 0.5 GB instead of 1 GB), and checked for impossible magnitudes
(:func:`turn_datasets.mocap.checks.check_magnitude`).

``turn-eval predict`` reads clips with :func:`turn_datasets.mocap.arrays.iter_arrays` given
the layout (one array per clip id, named as stored); ``turn-eval detect`` reads streams with
:func:`read_streams`.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import walk_files
from turn_datasets.mocap.arrays import ARRAY_SUFFIXES, iter_arrays
from turn_datasets.mocap.checks import check_magnitude
from turn_datasets.render.order import natural_key
from turn_datasets.skeleton import AUTO, H36M17, Layout, to_z_up
from turn_datasets.up_axis import AxesFound, resolve_up_axis

__all__ = [
    "STREAM_SUFFIXES",
    "Stream",
    "axes_found",
    "read_streams",
    "stream_files",
    "stream_names",
]

#: Suffixes of the files a stream is read from (a folder is walked for these).
STREAM_SUFFIXES = ARRAY_SUFFIXES
_NPY_SEPARATOR = "__"


@dataclass(frozen=True)
class Stream:
    """One person's skeleton over one recording.

    Attributes
    ----------
    session, subject
        Names (see the module docstring for where they come from).
    positions
        ``(frames, joints, 3)`` float32 or float64 as stored (other types float64), z up,
        in the file's own unit; NaN where unseen.
    source
        The file it was read from.
    key
        The array's name inside the file (the stem for ``.npy``).
    up_axis
        The file's axis that was turned to z: stated, a named format's own, or inferred
        (``--up-axis auto``, :mod:`turn_datasets.up_axis`).
    """

    session: str
    subject: str
    positions: np.ndarray
    source: str
    key: str
    up_axis: str = "z"

    @property
    def n_frames(self) -> int:
        return int(self.positions.shape[0])


def stream_files(
    paths: Iterable[str | os.PathLike[str]],
    *,
    skipped: list[tuple[Path, str]] | None = None,
) -> list[Path]:
    """The files to read: files as given, folders walked; sorted by path, each once.

    A file reached by several names (a symbolic link beside its target, ``alias.npz ->
    pair01_day1.npz``) is read once, under the real file's name, since its stem names the
    session; a link to a file that does not exist is passed over. Each path passed over is
    appended to ``skipped`` with the reason, for the caller to say.

    Raises
    ------
    TurnbenchError
        A path that does not exist, a file with another suffix, or a folder without any.
    """
    out: list[Path] = []
    passed: list[tuple[Path, str]] = []
    for raw in paths:
        path = Path(raw)
        if path.is_dir():
            # the one folder walk (links followed once, hidden skipped, unreadable named)
            listed = [p for p in walk_files(path) if p.suffix.lower() in STREAM_SUFFIXES]
            found = [p for p in listed if p.is_file()]
            passed += [
                (p, f"a symbolic link to {os.readlink(p)}, which does not exist")
                for p in listed
                if p.is_symlink() and not p.exists()
            ]
            if not found:
                raise TurnbenchError(
                    f"the folder holds no skeleton stream ({', '.join(STREAM_SUFFIXES)})",
                    file=path,
                )
            out.extend(found)
        elif path.is_file():
            from turn_eval.estimate.formats import refuse_2d

            refuse_2d([path])  # AlphaPose's 2D output: say why it cannot serve
            if path.suffix.lower() not in STREAM_SUFFIXES:
                raise TurnbenchError(
                    f"not a skeleton stream file (expected one of {', '.join(STREAM_SUFFIXES)})",
                    file=path,
                )
            out.append(path)
        else:
            raise TurnbenchError("no such file or folder", file=path)
    names: dict[Path, list[Path]] = {}
    for p in sorted(out, key=lambda q: natural_key(str(q))):
        names.setdefault(p.resolve(), []).append(p)
    chosen = []
    for real, given in names.items():
        # the real file's own name, else the first link to it
        keep = next((p for p in given if not p.is_symlink()), given[0])
        chosen.append(keep)
        passed += [
            (p, f"the same file as {keep}: read once, as {real.name}") for p in given if p != keep
        ]
    if skipped is not None:
        skipped += passed
    return sorted(chosen, key=lambda q: natural_key(str(q)))


def stream_names(path: str | os.PathLike[str], key: str) -> tuple[str, str]:
    """``(session, subject)`` of the array ``key`` of file ``path`` (module docstring)."""
    p = Path(path)
    if p.suffix.lower() == ".npy":
        session, sep, subject = p.stem.partition(_NPY_SEPARATOR)
        return (session, subject) if sep and session and subject else (p.stem, p.stem)
    return p.stem, key


def _named_streams(
    path: str | os.PathLike[str], source_format: str, up_axis: str | None
) -> Iterator[tuple[str, str, str, str, np.ndarray]]:
    """``(session, subject, key, up axis, z-up positions)`` of another estimator's file, read
    by :func:`turn_eval.estimate.formats.read_estimator_output` (the one reader of those)."""
    from turn_eval.estimate.formats import read_estimator_output

    spec, named = read_estimator_output(path, source_format)
    for name, array in named:
        # turnbench's npz: stem = session, key = track; the others: one clip per file
        session, subject = stream_names(path, name) if spec.name == "turnbench" else (name, name)
        check_magnitude(array, path=path, item=name)  # first: the axis inference reads it
        try:
            axis = resolve_up_axis(array, H36M17, up_axis or spec.up_axis, item=name)
        except TurnbenchError as exc:
            raise TurnbenchError(exc.message, file=path, item=name, hint=exc.hint) from None
        yield session, subject, name, axis, to_z_up(array, axis)


def read_streams(
    path: str | os.PathLike[str],
    *,
    layout: Layout,
    up_axis: str | None,
    source_format: str = "arrays",
) -> Iterator[Stream]:
    """The streams of one file, z up, in the stored float type, one at a time (memory: one
    array).

    Parameters
    ----------
    path
        A ``.npz``, ``.h5``/``.hdf5`` or ``.npy`` file.
    layout
        The joint layout every array must have (``h36m17`` for a named format).
    up_axis
        The files' vertical axis: ``z``, ``y``, ``-y`` (camera axes, y down), ``x``, ``-x``,
        ``-z``, or ``auto`` (inferred per stream from the trunk,
        :func:`turn_datasets.up_axis.infer_up_axis`); None means ``auto`` for generic arrays
        and the format's own for a named format. Each stream records the axis used.
    source_format
        ``arrays`` (generic files, named as in the module docstring) or an estimator's
        name (:data:`turn_eval.estimate.formats.FORMAT_CHOICES`): ``turnbench`` for
        ``turn-eval estimate``'s npz (stem = session, track key = subject), or
        ``strided-transformer``, ``videopose3d``, ``motionbert`` (one person per file, the
        clip's name as session and subject).

    Raises
    ------
    TurnbenchError
        An unreadable file, an array declaring more values than the bound or the machine's
        memory, an array of the wrong shape or joint count, infinite or implausibly large
        values, naming the file and the array.
    """
    if source_format != "arrays":
        if layout.name != "h36m17":
            raise TurnbenchError(f"--from {source_format} files are in the h36m17 layout")
        for session, subject, key, axis, positions in _named_streams(path, source_format, up_axis):
            yield Stream(session, subject, _stored_float(positions), str(path), key, axis)
        return
    for key, array in iter_arrays(path, layout=layout):
        # (checked first: the axis inference reads the positions)
        check_magnitude(array, path=path, item=key)
        try:
            axis = resolve_up_axis(array, layout, up_axis or AUTO, item=key)
        except TurnbenchError as exc:
            raise TurnbenchError(exc.message, file=path, item=key, hint=exc.hint) from None
        # to_z_up exchanges and negates axes, exact in any float type: the stream keeps the
        # stored precision (float32 from estimators), is never widened whole to float64, and
        # is turned in place (the array was just read for this stream alone)
        positions = _z_up_in_place(_stored_float(array), axis)
        del array
        session, subject = stream_names(path, key)
        yield Stream(session, subject, positions, str(path), key, axis)


def _z_up_in_place(p: np.ndarray, up_axis: str) -> np.ndarray:
    """:func:`~turn_datasets.skeleton.to_z_up` of ``p`` written into ``p`` itself: the
    rotation is a signed exchange of axes (read off the unit vectors), so each output axis is
    one input axis, and only an axis overwritten before it is read is copied (one third of
    the array for ``y`` and ``-y``, instead of a whole second array)."""
    rotation = to_z_up(np.eye(3), up_axis)  # row i: where input axis i goes
    source = [int(np.flatnonzero(rotation[:, j])[0]) for j in range(3)]
    if not p.flags.writeable or any(np.count_nonzero(rotation[:, j]) != 1 for j in range(3)):
        return _stored_float(to_z_up(p, up_axis))  # not ours to change, or not an exchange
    saved: dict[int, np.ndarray] = {}
    for j in range(3):
        i = source[j]
        sign = rotation[i, j]
        if i == j and sign > 0:
            continue
        if any(source[k] == j for k in range(j + 1, 3)):
            saved[j] = p[..., j].copy()  # still to be read for a later axis
        column = saved.get(i, p[..., i])
        if sign > 0:
            p[..., j] = column
        else:
            np.negative(column, out=p[..., j])
    return p


def _stored_float(array: np.ndarray) -> np.ndarray:
    """``array`` as a C-contiguous float32 or float64 array, as stored when it is one of
    those (no copy then); other types (integers, float16) widened to float64."""
    a = np.asarray(array)
    dtype = a.dtype if a.dtype in (np.float32, np.float64) else np.float64
    return np.ascontiguousarray(a, dtype=dtype)


def axes_found(inputs: Iterable[dict], option: str) -> AxesFound:
    """The vertical axis each stream was read with (``DetectRun.inputs``: files with their
    ``streams``, each with its ``key`` and ``up_axis``), for the one line on stderr."""
    found = AxesFound(option)
    for f in inputs:
        for s in f["streams"]:
            found.record(f"{f['file']}:{s['key']}", s["up_axis"])
    return found
