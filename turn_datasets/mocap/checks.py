"""What every motion-capture reader checks, and how it reports a bad file or sequence."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

import numpy as np

from turn_datasets import limits, machine
from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import usable_frames
from turn_datasets.machine import gigabytes
from turn_datasets.skeleton import (
    Layout,
)

__all__ = [
    "OnBadSequence",
    "CORRUPT",
    "DEFLATE_MAX_RATIO",
    "check_declared_size",
    "check_inflation",
    "check_joint_count",
    "check_magnitude",
    "checked_positions",
    "skip_bad",
    "unreadable",
]

T = TypeVar("T")
U = TypeVar("U")


# What a library may raise when it parses a truncated or corrupt file. Truncating and
# flipping bytes of files of every format met ValueError, OSError, EOFError, KeyError,
# IndexError from all of them, but also h5py's RuntimeError (a damaged symbol table),
# cdflib's MemoryError and OverflowError (a record size read from garbage), zlib.error (a
# damaged deflate stream) and tokenize.TokenError (a damaged .npy header), and unpickling
# VideoPose3D's dict can raise anything. So each read site wraps the library call alone (no
# code of ours inside) and reports any exception from it as an unreadable file, naming it.
CORRUPT = (Exception,)


@contextmanager
def unreadable(
    what: str,
    path: Path,
    *,
    item: str | None = None,
    guess: str = "truncated or corrupt?",
) -> Iterator[None]:
    """Report anything the library call inside raises (:data:`CORRUPT`) as one error.

    The message is ``cannot read <what> (<guess>): <exc>``, naming ``path`` and ``item``. A
    :class:`TurnbenchError` raised inside is already ours and passes unchanged.
    """
    try:
        yield
    except TurnbenchError:
        raise
    except CORRUPT as exc:
        raise TurnbenchError(f"cannot read {what} ({guess}): {exc}", file=path, item=item) from None


#: Bytes per declared value that reading one array takes at most: the array as stored plus
#: one float64 working copy (the detector's gather of the joints it reads, a reader's
#: widening), beside the stored values' own size.
_WORKING_BYTES_PER_VALUE = 8


def check_declared_size(
    shape: tuple[int, ...],
    dtype: np.dtype | str,
    *,
    path: str | os.PathLike[str] | None,
    item: str | None,
    what: str = "the array",
) -> None:
    """Refuse an array whose declared size is past the bound or the machine, before reading.

    A file's header (an ``.npy`` header, an HDF5 dataset's shape, a CDF variable's record
    count and dimensions, a zip member's size, the shape a pickled array gives NumPy)
    declares how big the array is; compression lets a few kilobytes declare gigabytes. The
    bound is :data:`turn_datasets.limits.MAX_ARRAY_VALUES`; the machine's is its free memory
    (:func:`turn_datasets.machine.available_memory_bytes`) against the stored size plus one
    float64 working copy. ``what`` names the array in the message.

    Raises
    ------
    TurnbenchError
        Naming the file, the array, its declared shape and type and the bound it passes.
    """
    dt = np.dtype(dtype)
    values = math.prod(int(n) for n in shape)
    stored = values * dt.itemsize
    declared = (
        f"declares {' x '.join(str(int(n)) for n in shape)} {dt.name} values ({gigabytes(stored)})"
    )
    if values > limits.MAX_ARRAY_VALUES:
        raise TurnbenchError(
            f"{what} {declared}: more than the {limits.MAX_ARRAY_VALUES:,} values turnbench "
            "reads in one array (corrupt, or a recording to split into files)",
            file=path,
            item=item,
        )
    need = values * (dt.itemsize + _WORKING_BYTES_PER_VALUE)
    free = machine.available_memory_bytes()
    if free is not None and need > free:
        raise TurnbenchError(
            f"{what} {declared}: reading it needs about {gigabytes(need)} and this machine has "
            f"{gigabytes(free)} free",
            file=path,
            item=item,
            hint="free memory, or split the recording into shorter files",
        )


#: The most one byte of deflate (gzip, zlib) data inflates to (zlib's technical notes:
#: 1032:1, reached by long runs of one byte); run-length coding, cdflib's other method,
#: inflates at most 128-fold.
DEFLATE_MAX_RATIO = 1032


def check_inflation(
    compressed_bytes: int,
    *,
    path: str | os.PathLike[str],
    item: str | None,
    what: str,
    hint: str | None = None,
) -> None:
    """Refuse compressed data that a library inflates whole, with no bound of its own, unless
    the most it can inflate to (:data:`DEFLATE_MAX_RATIO` times its bytes) fits in free
    memory: what such data declares does not bound what it inflates to.

    Raises
    ------
    TurnbenchError
        Naming the file, what is compressed, the worst case and the free memory.
    """
    worst = compressed_bytes * DEFLATE_MAX_RATIO
    free = machine.available_memory_bytes()
    if free is not None and worst > free:
        raise TurnbenchError(
            f"{what} is inflated whole when read: up to {gigabytes(worst)} from its "
            f"{compressed_bytes:,} bytes (deflate inflates at most {DEFLATE_MAX_RATIO}-fold), "
            f"and this machine has {gigabytes(free)} free",
            file=path,
            item=item,
            hint=hint,
        )


#: Frames checked per pass of :func:`check_magnitude`: bounds its temporary memory.
_MAGNITUDE_CHUNK_VALUES = 1 << 22


def check_magnitude(
    array: np.ndarray, *, path: str | os.PathLike[str] | None, item: str | None
) -> None:
    """Refuse positions holding an infinity or a coordinate beyond
    :data:`turn_datasets.limits.MAX_POSITION_ABS` (NaN is an unseen joint and passes).

    The one magnitude check of every reader of skeletons (``h36m mine``, ``predict``,
    ``detect``). It reads the array in chunks with NaN-ignoring minimum and maximum, so it
    makes no full-size temporary.
    """
    a = np.asarray(array)
    if a.size == 0 or a.dtype.kind not in "fiu":
        return
    flat = a.reshape(-1) if a.flags.c_contiguous else a.ravel(order="K")
    lo, hi = math.inf, -math.inf
    for start in range(0, flat.size, _MAGNITUDE_CHUNK_VALUES):
        chunk = flat[start : start + _MAGNITUDE_CHUNK_VALUES]
        if a.dtype.kind == "f":
            cmin, cmax = np.fmin.reduce(chunk), np.fmax.reduce(chunk)
        else:
            cmin, cmax = chunk.min(), chunk.max()
        if not np.isnan(cmin):
            lo, hi = min(lo, float(cmin)), max(hi, float(cmax))
    if lo > hi:
        return  # every value NaN: nothing seen, which the callers judge
    if math.isinf(lo) or math.isinf(hi):
        raise TurnbenchError("positions hold infinite values (corrupt?)", file=path, item=item)
    if max(-lo, hi) > limits.MAX_POSITION_ABS:
        raise TurnbenchError(
            f"positions hold a coordinate of {lo if -lo > hi else hi:g}, beyond the "
            f"plausible +-{limits.MAX_POSITION_ABS:g} in any unit (corrupt, or the wrong unit?)",
            file=path,
            item=item,
        )


def check_joint_count(
    array: np.ndarray, layout: Layout, *, path: Path, item: str | None
) -> np.ndarray:
    """``array`` (frames, joints, 3) if its joints are ``layout``'s, else a TurnbenchError."""
    if array.shape[1] != layout.n_joints:
        raise TurnbenchError(
            f"array has {array.shape[1]} joints but layout {layout.name!r} has "
            f"{layout.n_joints} (shape {tuple(array.shape)})",
            file=path,
            item=item,
            hint="choose the layout with --layout",
        )
    return array


#: Called with the error of one unusable sequence of a multi-sequence file (see
#: :func:`read_source`'s ``on_bad_sequence``).
OnBadSequence = Callable[[TurnbenchError], None]


def skip_bad(
    items: Iterable[T], check: Callable[[T], U], on_bad: OnBadSequence | None
) -> Iterator[U]:
    """``check(item)`` of each item; an item it refuses goes to ``on_bad``, or is raised.

    The one policy of a multi-sequence file: with ``on_bad`` given, a bad sequence is
    reported to it and the others are still read; without, the first bad one is the error.
    """
    for item in items:
        try:
            out = check(item)
        except TurnbenchError as exc:
            if on_bad is None:
                raise
            on_bad(exc)
            continue
        yield out


def checked_positions(
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
    check_magnitude(p, path=path, item=item)
    p = np.ascontiguousarray(p, dtype=np.float64)
    n_usable = int(usable_frames(p, layout, "hip").sum())
    if n_usable < 2:
        # a frame with a NaN hip is never usable: which is the cause is asked only here
        hips = p[:, [layout.index("left_hip"), layout.index("right_hip")], :2]
        if not np.isfinite(hips).all(axis=(1, 2)).any():
            raise TurnbenchError(
                "the left or right hip is NaN in every frame", file=path, item=item
            )
        raise TurnbenchError(
            f"the left and right hips coincide (or are missing) in all but {n_usable} of "
            f"{p.shape[0]} frames: no hip direction to measure",
            file=path,
            item=item,
        )
    return p
