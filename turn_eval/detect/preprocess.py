"""What an estimator's stream needs before the miner's rule can read it: identity, swaps.

Motion capture follows one body with labelled markers; a pose estimator guesses a skeleton
per frame from video. Two of its errors would each look like a turn to the miner's rule
(:mod:`turn_datasets.h36m.miner`), and are undone here, on positions, before it runs:

Identity breaks (:func:`identity_pieces`)
    The tracker jumps to another person for a few seconds, without a confidence drop
    (seen on real home video). The skeleton then jumps: its position by more than a body can
    move in one frame, or its size (the length of the trunk, pelvis to thorax to head, and of
    the upper arms: bones that sitting, bending or depth error along the camera ray change
    least). The stream is split at such jumps; each piece gets its median size, and pieces
    whose size differs from the size of most of the stream's frames by more than
    ``identity_size_tolerance`` are someone else's and dropped. Two neighbouring pieces that
    are both kept, split by a change of size alone, each at least the size's window long, are
    joined again: the depth error inflates the size as the back turns to the camera (on the
    synthetic sessions by up to a fifth within a turn), which no other person explains when
    both sides have the person's own size; left split, the turn was cut in two. A shorter
    piece stays apart: MediaPipe's first 11 frames on the real video, while its tracker
    settles, are such a piece, and joined they made a false 50° turn. Root-relative streams
    (the pelvis at the origin) have no position, so only their size is used.
Left/right swaps (:func:`repair_swaps`)
    For a few frames the estimator exchanges the left and right joints, mostly when the
    person faces away: the hip vector jumps by about 180° in one frame, which no body does
    (a fast turn, 225° in 1.3 s, peaks near 6° per frame at 30 fps). Within each run of
    frames without a gap longer than ``max_gap_s``, every jump of the hip vector by more than
    90° between consecutive usable frames toggles a parity; the parity held by fewer frames
    is the swapped one (swaps are brief) and its frames get their left and right joints
    exchanged back.

Gaps (dropouts, absences) are the miner's: bridged by interpolation when at most
``max_gap_s`` long, cut otherwise, so a turn is never followed through a long absence.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter

from turn_datasets.geometry import frontal_vectors, median, usable_frames
from turn_datasets.skeleton import Layout

__all__ = ["SIZE_JOINTS", "body_size", "identity_pieces", "repair_swaps", "runs"]

# Bones whose length is the body's size: trunk and upper arms (see the module docstring).
_SIZE_BONES = (
    ("pelvis", "thorax"),
    ("thorax", "head"),
    ("left_shoulder", "left_elbow"),
    ("right_shoulder", "right_elbow"),
)
#: The joints :func:`body_size` reads.
SIZE_JOINTS = tuple(dict.fromkeys(j for bone in _SIZE_BONES for j in bone))
# Limbs whose sides a swap exchanges.
_SIDES = ("hip", "knee", "foot", "shoulder", "elbow", "wrist")


def runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and (exclusive) end indices of the runs of True in a boolean array."""
    edges = np.diff(np.concatenate(([0], np.asarray(mask, dtype=np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def body_size(
    positions: np.ndarray, layout: Layout, frames: np.ndarray | None = None
) -> np.ndarray:
    """Per-frame size of the body: the summed length of the trunk and upper-arm bones (NaN
    where one is missing), in the positions' own unit; of ``frames`` only, when given."""
    total = np.zeros(positions.shape[0])
    for a, b in _SIZE_BONES:
        # strided views of the two joints' columns, not gathers of rows
        d = positions[:, layout.index(a), :] - positions[:, layout.index(b), :]
        total += np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2 + d[:, 2] ** 2)
    return total if frames is None else total[frames]


def identity_pieces(
    positions: np.ndarray,
    layout: Layout,
    usable: np.ndarray,
    *,
    fps_hz: float,
    jump_sizes: float,
    size_change: float,
    size_tolerance: float,
    window_s: float = 1.0,
) -> list[tuple[int, int]]:
    """Spans ``[a, b)`` of frames that show the stream's own person (module docstring).

    Parameters
    ----------
    positions, layout
        The stream, z up.
    usable
        Frames with a usable hip vector.
    fps_hz
        Frame rate.
    jump_sizes
        A move of the mid-hip point by more than this many body sizes between two consecutive
        usable frames (plus what walking at 2 m/s covers over a gap) is a jump to someone else.
    size_change
        A change of the median size over ``window_s`` before and after a frame by more than
        this fraction is a jump to someone else.
    size_tolerance
        Pieces whose median size differs from the stream's by more than this fraction are
        someone else's and left out; kept neighbours split by a change of size alone, both at
        least ``window_s`` long, are one piece.
    """
    n = positions.shape[0]
    idx = np.flatnonzero(usable)
    if idx.size < 2:
        return []
    size = body_size(positions, layout, idx)
    ok = np.isfinite(size) & (size > 0)
    if ok.sum() < 2:
        return [(int(idx[0]), int(idx[-1]) + 1)]
    size = np.interp(np.arange(idx.size), np.flatnonzero(ok), size[ok])
    cuts = set()  # position jumps
    size_cuts = set()
    left, right = layout.index("left_hip"), layout.index("right_hip")
    hips = (0.5 * (positions[:, left, :2] + positions[:, right, :2]))[idx]
    step = np.hypot(*np.diff(hips, axis=0).T)
    # a body covers at most ~2 m/s; a body size (trunk + arms) is ~1.1 m: 2 sizes per second
    allowed = jump_sizes + 2.0 * np.diff(idx) / fps_hz
    cuts.update((np.flatnonzero(step > allowed * size[1:]) + 1).tolist())
    w = max(int(round(window_s * fps_hz)), 3) | 1  # odd
    if idx.size > 3 * w:
        # median of the w frames before frame i against the w frames from frame i on: a
        # sustained change of size, not the flicker of one frame
        centred = median_filter(size, size=w, mode="nearest")
        half = w // 2
        before = np.concatenate((np.full(half + 1, centred[0]), centred[: -half - 1]))
        after = np.concatenate((centred[half:], np.full(half, centred[-1])))
        change = np.abs(np.log(after / before))
        # one cut per excursion above the threshold, in its middle: the medians turn a step
        # of size into a plateau of change centred on it, about one window wide
        for a, b in zip(*runs(change > np.log1p(size_change)), strict=True):
            size_cuts.add(int((a + b) // 2))
    size_cuts -= cuts
    cuts |= size_cuts
    bounds = [0, *sorted(cuts), idx.size]
    spans = [
        (bounds[i], bounds[i + 1]) for i in range(len(bounds) - 1) if bounds[i + 1] > bounds[i]
    ]
    sizes = np.array([median(size[a:b]) for a, b in spans])
    weights = np.array([b - a for a, b in spans], dtype=float)
    order = np.argsort(sizes)
    own = sizes[order][np.searchsorted(np.cumsum(weights[order]), 0.5 * weights.sum())]
    keep = np.abs(sizes / own - 1.0) <= size_tolerance
    out: list[tuple[int, int]] = []
    for (a, b), k in zip(spans, keep, strict=True):
        if not k:
            continue
        # the person's own size on both sides of a change of size: no one else came between
        # (where each side is long enough to show its size as precisely as the cut was made)
        joined = out and out[-1][1] == a and a in size_cuts
        if joined and min(a - out[-1][0], b - a) >= w:
            out[-1] = (out[-1][0], b)
        else:
            out.append((a, b))
    return [(int(idx[a]), int(idx[b - 1]) + 1 if b < idx.size else n) for a, b in out]


def repair_swaps(
    positions: np.ndarray,
    layout: Layout,
    *,
    fps_hz: float,
    max_gap_s: float,
    usable: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """Undo left/right swaps (module docstring); returns the repaired positions (a copy when
    any frame was repaired, else the input itself) and the number of frames whose sides were
    exchanged back. ``usable``: the frames with a usable hip vector, when the caller has
    found them (:func:`~turn_datasets.geometry.usable_frames` of these positions' hips)."""
    positions = np.asarray(positions, dtype=float)
    if usable is None:
        usable = usable_frames(positions, layout, ("hip",))
    idx = np.flatnonzero(usable)
    if idx.size < 2:
        return positions, 0
    v = frontal_vectors(positions, layout, "hip")[idx]  # every frame's, then the usable ones
    flip = np.einsum("ij,ij->i", v[1:], v[:-1]) < 0
    linked = np.diff(idx) <= max(int(round(max_gap_s * fps_hz)), 1)
    parity = np.concatenate(([0], np.cumsum(flip & linked) % 2))
    # each run of linked frames decides alone which parity is the person's own
    piece = np.concatenate(([0], np.cumsum(~linked)))
    ones = np.bincount(piece, weights=parity)
    count = np.bincount(piece)
    # the parity held by fewer frames of its run is the swapped one
    swapped_parity = (2 * ones < count).astype(parity.dtype)
    swapped = parity == swapped_parity[piece]
    frames = idx[swapped]
    if frames.size == 0:
        return positions, 0  # nothing to undo: no copy
    p = positions.copy(order="K")  # the input's memory order: a joint-major stream stays so
    for side in _SIDES:
        a, b = f"left_{side}", f"right_{side}"
        if a in layout.joints and b in layout.joints:
            ia, ib = layout.index(a), layout.index(b)
            p[frames, ia], p[frames, ib] = positions[frames, ib], positions[frames, ia]
    return p, int(frames.size)
