"""What every motion-capture reader checks, and how it reports a bad file or sequence."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import usable_frames
from turn_datasets.skeleton import (
    Layout,
)

__all__ = [
    "OnBadSequence",
    "CORRUPT",
    "check_joint_count",
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
