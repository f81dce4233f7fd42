"""Generic arrays of positions: ``.npy``, ``.npz``, ``.h5``/``.hdf5`` of shape ``(frames, joints, 3)``.

Their layout, fps and units are not in the file and must be given; their vertical axis is
given or inferred per array (``auto``, :mod:`turn_datasets.up_axis`) and recorded in each
sequence's ``meta["up_axis"]``. The parent
folder's name is the ``subject``, the file stem (with the array key for ``.npz``/``.h5``)
the ``action``, so two files of the same name in different folders stay apart.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap.checks import (
    OnBadSequence,
    check_joint_count,
    checked_positions,
    skip_bad,
    unreadable,
)
from turn_datasets.skeleton import (
    AUTO,
    UP_AXIS_CHOICES,
    Layout,
    MocapSequence,
    get_layout,
    to_z_up,
)
from turn_datasets.up_axis import resolve_up_axis

__all__ = [
    "UNITS",
    "ARRAY_SUFFIXES",
    "iter_arrays",
    "load_numpy",
    "read_arrays",
]


#: Unit names a generic array may be declared in (a label: positions are not rescaled).
UNITS = ("mm", "cm", "m", "in")


def read_arrays(
    path: Path,
    *,
    layout: str | Layout | None,
    fps: float | None,
    up_axis: str | None,
    units: str | None,
    on_bad: OnBadSequence | None,
) -> Iterator[MocapSequence]:
    # the vertical axis, unless stated, is inferred per array (--up-axis auto)
    up_axis = up_axis or AUTO
    missing = [
        opt
        for opt, value in (
            ("--layout", layout),
            ("--fps", fps),
            ("--units", units),
        )
        if value is None
    ]
    if missing:
        raise TurnbenchError(
            f"a generic array does not say its {', '.join(m.lstrip('-') for m in missing)}",
            file=path,
            hint=f"give {' '.join(missing)} (layout: h36m32 or h36m17; units: {'/'.join(UNITS)})",
        )
    assert fps is not None and units is not None  # both given (above)
    try:
        lay = layout if isinstance(layout, Layout) else get_layout(str(layout))
    except TurnbenchError as exc:
        raise TurnbenchError(exc.message, file=path) from None
    if not (np.isfinite(fps) and fps > 0):
        raise TurnbenchError(f"fps must be positive, got {fps}", file=path)
    if up_axis not in UP_AXIS_CHOICES:
        raise TurnbenchError(
            f"unknown up axis {up_axis!r}; choose one of {', '.join(UP_AXIS_CHOICES)}", file=path
        )
    if units not in UNITS:
        raise TurnbenchError(
            f"unknown units {units!r}; choose one of {', '.join(UNITS)}", file=path
        )
    single = path.suffix.lower() == ".npy"

    axes: dict[str, str] = {}

    def z_up(named: tuple[str, np.ndarray]) -> tuple[str, np.ndarray]:
        key, array = named
        item = None if single else key
        try:
            axes[key] = resolve_up_axis(array, lay, up_axis, item=item)
        except TurnbenchError as exc:
            raise TurnbenchError(exc.message, file=path, item=item, hint=exc.hint) from None
        positions = to_z_up(np.asarray(array, dtype=np.float64), axes[key])
        return key, checked_positions(positions, lay, path=path, item=item)

    arrays = iter_arrays(path, layout=lay, on_bad_array=on_bad)
    for key, positions in skip_bad(arrays, z_up, None if single else on_bad):
        yield MocapSequence(
            subject=path.absolute().parent.name,
            action=path.stem if single else f"{path.stem}.{key.replace('/', '.')}",
            subaction="",
            positions=positions,
            layout=lay,
            fps=float(fps),
            units=units,
            source=str(path),
            meta={"format": "array", "key": key, "up_axis": axes[key], "up_axis_option": up_axis},
        )


ARRAY_SUFFIXES = (".npy", ".npz", ".h5", ".hdf5")


def _checked(array: np.ndarray, layout: Layout | None, *, path: Path, key: str) -> np.ndarray:
    if array.ndim != 3 or array.shape[2] != 3 or array.shape[0] < 1 or array.shape[1] < 1:
        # 2D keypoints (a REMAP Open skeletons_2d.npz, a detector's output) have no depth to
        # turn about a vertical axis: say what to do, not only what the shape is
        flat = array.ndim == 3 and array.shape[2] == 2
        raise TurnbenchError(
            f"array has shape {tuple(array.shape)}, expected (frames, joints, 3)"
            + ("; these are 2D keypoints" if flat else ""),
            file=path,
            item=key,
            hint="lift them to 3D first" if flat else None,
        )
    if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
        raise TurnbenchError(
            f"array has dtype {array.dtype}, expected numbers", file=path, item=key
        )
    return array if layout is None else check_joint_count(array, layout, path=path, item=key)


def _h5_dataset_names(group: h5py.Group) -> list[str]:
    names: list[str] = []

    def visit(name: str, obj: object) -> None:
        if isinstance(obj, h5py.Dataset):
            names.append(name)

    group.visititems(visit)
    return sorted(names)


def _check_numpy_container(path: Path, suffix: str) -> None:
    """Refuse a file that is not what its suffix says before NumPy guesses: np.load takes
    anything that is neither a zip nor an .npy for a pickle, and a text file named .npz was
    "pickled (object) data"."""
    if not path.is_file() or suffix not in (".npy", ".npz"):
        return
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError:
        return  # reported by the reader with its own message
    expected = b"PK" if suffix == ".npz" else b"\x93NUMPY"
    if not head.startswith(expected):
        what = "an .npz archive (a zip of .npy arrays)" if suffix == ".npz" else "an .npy array"
        raise TurnbenchError(
            f"cannot open this {suffix}: it is not {what} (it starts with {head!r})", file=path
        )


def _np_load(p: Path, suffix: str):
    """``np.load`` without pickles; a file it cannot read is a :class:`TurnbenchError`."""
    with unreadable(suffix, p):
        return np.load(p, allow_pickle=False)


def load_numpy(path: str | os.PathLike[str]):
    """``np.load`` of an ``.npy`` (an array) or ``.npz`` (an ``NpzFile``), the one guarded way.

    The file's first bytes are checked against its suffix before NumPy guesses, nothing is
    unpickled, and anything NumPy, zipfile or zlib raises is one :class:`TurnbenchError`
    naming the file. An ``.npz`` member read later may still be corrupt: read it inside
    :func:`turn_datasets.mocap.checks.unreadable`.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    _check_numpy_container(p, suffix)
    return _np_load(p, suffix)


def iter_arrays(
    path: str | os.PathLike[str],
    *,
    layout: Layout | None = None,
    on_bad_array: OnBadSequence | None = None,
) -> Iterator[tuple[str, np.ndarray]]:
    """Yield ``(name, array)`` for each ``(frames, joints, 3)`` array in a generic array file.

    Parameters
    ----------
    path
        ``.npy`` -> one ``(file stem, array)``; ``.npz`` -> one ``(key, array)`` per array, in
        the archive's sorted key order, loaded without pickles; ``.h5``/``.hdf5`` -> one
        ``(dataset path, array)`` per dataset, nested groups walked, sorted by path.
    layout
        When given, an array with another number of joints is bad as well.
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
    _check_numpy_container(p, suffix)
    if suffix == ".npy":
        yield p.stem, _checked(_np_load(p, suffix), layout, path=p, key=p.stem)
        return
    if suffix == ".npz":
        with _np_load(p, suffix) as archive:
            keys = sorted(archive.files)
            if not keys:
                raise TurnbenchError("the .npz archive holds no array", file=p)

            def member(key: str) -> tuple[str, np.ndarray]:
                with unreadable("this array", p, item=key, guess="pickled, truncated or corrupt?"):
                    array = archive[key]
                return key, _checked(array, layout, path=p, key=key)

            yield from skip_bad(keys, member, on_bad_array)
        return
    with unreadable("HDF5", p):
        fh = h5py.File(p, "r")
    with fh:
        with unreadable("the list of datasets", p):
            names = _h5_dataset_names(fh)
        if not names:
            raise TurnbenchError("the HDF5 file holds no dataset", file=p)

        def dataset(name: str) -> tuple[str, np.ndarray]:
            with unreadable("this dataset", p, item=name):
                array = np.asarray(fh[name][()])
            return name, _checked(array, layout, path=p, key=name)

        yield from skip_bad(names, dataset, on_bad_array)
