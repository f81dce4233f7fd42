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
    check_declared_size,
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
    "npy_header",
    "read_h5_dataset",
    "read_npz_member",
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


def npy_header(fh) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and dtype an ``.npy`` stream's header declares (the stream is left after
    the header): read before NumPy allocates what they add up to."""
    version = np.lib.format.read_magic(fh)
    read = (
        np.lib.format.read_array_header_1_0
        if version == (1, 0)
        else np.lib.format.read_array_header_2_0
    )
    shape, _, dtype = read(fh)
    return tuple(shape), np.dtype(dtype)


def _np_load(p: Path, suffix: str):
    """``np.load`` without pickles; a file it cannot read is a :class:`TurnbenchError`. An
    ``.npy``'s declared size is checked first (:func:`~turn_datasets.mocap.checks.check_declared_size`)."""
    if suffix == ".npy":
        with unreadable("the .npy header", p), open(p, "rb") as fh:
            shape, dtype = npy_header(fh)
        check_declared_size(shape, dtype, path=p, item=None)
    with unreadable(suffix, p):
        return np.load(p, allow_pickle=False)


def read_npz_member(archive, key: str, path: Path) -> np.ndarray:
    """Member ``key`` of an open ``.npz`` (``np.load``'s ``NpzFile``), the size its ``.npy``
    header declares checked before it is inflated (a few megabytes of deflated zeros can
    declare gigabytes)."""
    name = f"{key}.npy" if f"{key}.npy" in archive.zip.namelist() else key
    with unreadable("this array", path, item=key, guess="pickled, truncated or corrupt?"):
        with archive.zip.open(name) as fh:
            shape, dtype = npy_header(fh)
    check_declared_size(shape, dtype, path=path, item=key)
    with unreadable("this array", path, item=key, guess="pickled, truncated or corrupt?"):
        return archive[key]


def read_h5_dataset(fh: h5py.File, name: str, path: Path) -> np.ndarray:
    """Dataset ``name`` of an open HDF5 file, read whole after two checks: its declared size
    (:func:`~turn_datasets.mocap.checks.check_declared_size`), and that its data are in this
    file. A virtual dataset or one with external storage reads other files, which the
    manifest (the sha256 of each input) would not record: refused, naming them."""
    with unreadable("this dataset", path, item=name):
        dset = fh[name]
        shape, dtype = tuple(dset.shape or ()), dset.dtype
        virtual = bool(dset.is_virtual)
        external = dset.external
    if virtual or external:
        where = (
            sorted({str(m.file_name) for m in dset.virtual_sources()})
            if virtual
            else sorted({str(e[0]) for e in external})
        )
        kind = "a virtual dataset" if virtual else "stored in external files"
        raise TurnbenchError(
            f"the dataset is {kind}, reading {', '.join(where)}: only data held in the file "
            "itself is read (its sha256 is what the manifest records)",
            file=path,
            item=name,
            hint="copy the data into the file (h5repack, or h5py: f[name] = f[name][()])",
        )
    if dtype.kind in "fiu":
        check_declared_size(shape, dtype, path=path, item=name)
    with unreadable("this dataset", path, item=name):
        return np.asarray(dset[()])


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
                return key, _checked(read_npz_member(archive, key, p), layout, path=p, key=key)

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
            return name, _checked(read_h5_dataset(fh, name, p), layout, path=p, key=name)

        yield from skip_bad(names, dataset, on_bad_array)
