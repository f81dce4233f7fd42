"""Motion-capture readers: every source into z-up world positions, one sequence at a time.

Generic arrays
    ``.npy`` (one array), ``.npz`` (one array per key) and ``.h5``/``.hdf5`` (one array per
    dataset) of shape ``(frames, joints, 3)``, read by :func:`iter_arrays`.
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np

from turn_datasets.errors import TurnbenchError

__all__ = ["iter_arrays"]

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


def iter_arrays(path: str | os.PathLike[str]) -> Iterator[tuple[str, np.ndarray]]:
    """Yield ``(name, array)`` for each ``(frames, joints, 3)`` array in a generic array file.

    Parameters
    ----------
    path
        ``.npy`` -> one ``(file stem, array)``; ``.npz`` -> one ``(key, array)`` per array, in
        the archive's sorted key order, loaded without pickles; ``.h5``/``.hdf5`` -> one
        ``(dataset path, array)`` per dataset, nested groups walked, sorted by path.

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
        except (ValueError, OSError, EOFError) as exc:
            raise TurnbenchError(f"cannot read .npy (truncated or corrupt?): {exc}", file=p) from None
        yield p.stem, _check_tj3(array, path=p, key=p.stem)
        return
    if suffix == ".npz":
        try:
            archive = np.load(p, allow_pickle=False)
        except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
            raise TurnbenchError(f"cannot read .npz (truncated or corrupt?): {exc}", file=p) from None
        with archive:
            keys = sorted(archive.files)
            if not keys:
                raise TurnbenchError("the .npz archive holds no array", file=p)
            for key in keys:
                try:
                    array = archive[key]
                except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
                    raise TurnbenchError(
                        f"cannot read this array (pickled, truncated or corrupt?): {exc}",
                        file=p,
                        item=key,
                    ) from None
                yield key, _check_tj3(array, path=p, key=key)
        return
    try:
        fh = h5py.File(p, "r")
    except OSError as exc:
        raise TurnbenchError(f"cannot read HDF5 (truncated or corrupt?): {exc}", file=p) from None
    with fh:
        names = _h5_dataset_names(fh)
        if not names:
            raise TurnbenchError("the HDF5 file holds no dataset", file=p)
        for name in names:
            try:
                array = fh[name][()]
            except (OSError, TypeError, ValueError) as exc:
                raise TurnbenchError(
                    f"cannot read this dataset (truncated or corrupt?): {exc}", file=p, item=name
                ) from None
            yield name, _check_tj3(np.asarray(array), path=p, key=name)
