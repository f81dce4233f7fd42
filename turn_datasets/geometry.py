"""The turning-angle geometry of the paper, in one place.

Cheng et al., "Your Turn: At Home Turning Angle Estimation for Parkinson's Disease Severity
Assessment", Section 4:

- Equations 1 and 2: the frontal vector of a joint pair, left minus right (hip, knee or
  shoulder), projected on the ground plane.
- Equation 3: the turning angle, the sum over consecutive frames of
  ``arcsin(|a_t x a_{t+1}| / (|a_t| |a_{t+1}|))``, averaged over the chosen joint pairs.
- Equation 4: the angular speed, the turning angle over the turn's duration.

Two ways to add up a rotation are offered, because the paper's formula and the paper's
claim about it differ:

``method="paper"``
    Equation 3 as printed. Every frame-to-frame rotation counts with its magnitude, so jitter
    and a turn back add up instead of cancelling, and a rotation of more than 90° between two
    frames is folded (arcsin cannot exceed 90°). On a noisy skeleton this grows with the
    number of frames.
``method="net"``
    The signed net rotation: the unwrapped ``atan2`` yaw of the frontal vector at the last
    frame minus the first. This is what the paper means when it says the frame-by-frame sum
    equals using the first and last frames; jitter and a turn back cancel. It assumes less
    than 180° between two usable frames (true of any real turn at 50 Hz).

Positions are ``(n_frames, n_joints, 3)`` in the z-up frame of DESIGN.md (convert with
:func:`turn_datasets.skeleton.to_z_up` first). Angles are in degrees, ``left`` is
counter-clockwise seen from above (increasing yaw).

Unusable frames
    A frame whose needed joints are NaN, or whose left and right joints coincide on the
    ground plane (frontal vector shorter than ``1e-3`` of the sequence's median, so its
    direction means nothing), is skipped: the sums run over consecutive *usable* frames,
    bridging the gap, and the number of skipped frames is reported in
    :attr:`TurningAngle.n_skipped_frames`. With several joint pairs a frame is usable only if
    all of them are. Fewer than two usable frames is an error, never a silent NaN.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from turn_datasets import limits
from turn_datasets.errors import TurnbenchError
from turn_datasets.params import param
from turn_datasets.skeleton import JOINT_PAIRS, Layout

__all__ = [
    "BinParams",
    "BIN_WIDTH_DEG",
    "METHODS",
    "TurningAngle",
    "frontal_vectors",
    "usable_frames",
    "frame_yaw_deg",
    "vectors_yaw_deg",
    "FrontalLengths",
    "frontal_lengths",
    "median",
    "unwrap_rad",
    "yaw_rate_deg_s",
    "window_means",
    "heading_change_deg",
    "turning_angle",
    "angular_speed_deg_s",
    "direction_of",
    "quantise_deg",
    "parse_joints",
]

METHODS = ("paper", "net")
#: A frontal vector shorter than this fraction of the sequence's median length is "coincident".
COINCIDENT_FRACTION = 1e-3


def parse_joints(joints: str | Sequence[str]) -> tuple[str, ...]:
    """``"hip,knee"`` or ``["hip", "knee"]`` -> ``("hip", "knee")``, checked, duplicates dropped."""
    items = joints.split(",") if isinstance(joints, str) else list(joints)
    out: list[str] = []
    for item in items:
        name = item.strip().lower()
        if name not in JOINT_PAIRS:
            raise TurnbenchError(
                f"unknown joint pair {item!r}; choose any of {', '.join(JOINT_PAIRS)}"
            )
        if name not in out:
            out.append(name)
    if not out:
        raise TurnbenchError("no joint pair given; choose any of hip, knee, shoulder")
    return tuple(out)


def _check_positions(positions: np.ndarray, layout: Layout) -> np.ndarray:
    p = np.asarray(positions, dtype=float)
    if p.ndim != 3 or p.shape[2] != 3:
        raise TurnbenchError(f"positions must have shape (frames, joints, 3), got {p.shape}")
    if p.shape[1] != layout.n_joints:
        raise TurnbenchError(
            f"positions have {p.shape[1]} joints but layout {layout.name!r} has {layout.n_joints}"
        )
    return p


def frontal_vectors(positions: np.ndarray, layout: Layout, joint: str = "hip") -> np.ndarray:
    """Equations 1 and 2: left minus right joint, on the ground plane; shape ``(n_frames, 2)``."""
    p = _check_positions(positions, layout)
    left, right = JOINT_PAIRS[parse_joints(joint)[0]]
    with np.errstate(invalid="ignore"):  # inf - inf is NaN: an unusable frame, not a warning
        return p[:, layout.index(left), :2] - p[:, layout.index(right), :2]


_FULL_TURN_RAD = 2 * np.pi
_HALF_TURN_RAD = _FULL_TURN_RAD / 2


def unwrap_rad(angles: np.ndarray) -> np.ndarray:
    """``np.unwrap`` of a one-dimensional float64 series of angles (radians, its defaults:
    a period of 2 pi, jumps of pi or more corrected), the same numbers bit for bit.

    ``np.unwrap`` takes the remainder modulo 2 pi of every frame-to-frame difference, and
    then throws it away wherever the difference is under pi: on a heading, every frame but
    the few where it crosses the branch cut. Here the remainder is taken of those few
    alone (with ``np.unwrap``'s own formula and its rule for a difference of exactly pi),
    which takes a fifth of the time on a 10-minute stream and half on a turn's stretch;
    the miner unwraps every stream twice and the step counter every turn's stretch
    (``tests/test_geometry.py`` checks that both agree bit for bit, NaN included)."""
    p = np.asarray(angles, dtype=np.float64)
    out = p.copy()
    if p.shape[0] < 2:
        return out
    dd = np.diff(p)
    far = np.flatnonzero(~(np.abs(dd) < _HALF_TURN_RAD))  # NaN differences among them
    correct = np.zeros(dd.shape[0])
    if far.size:
        d = dd[far]
        wrapped = np.mod(d + _HALF_TURN_RAD, _FULL_TURN_RAD) - _HALF_TURN_RAD
        wrapped[(wrapped == -_HALF_TURN_RAD) & (d > 0)] = _HALF_TURN_RAD
        correct[far] = wrapped - d
    out[1:] = p[1:] + correct.cumsum()
    return out


def _unwrapped_yaw_rad(vectors: np.ndarray) -> np.ndarray:
    return unwrap_rad(np.arctan2(vectors[:, 1], vectors[:, 0]))


class FrontalLengths(NamedTuple):
    """What :func:`frontal_lengths` returns for one pair's frontal vectors."""

    #: The vector's length per frame (NaN where a joint is missing).
    length: np.ndarray
    #: Frames whose vector is usable: finite and longer than ``COINCIDENT_FRACTION`` of
    #: the median length.
    usable: np.ndarray
    #: The median of the finite lengths (NaN when none is finite).
    median: float


#: Up to this many values, :func:`median` partitions them itself; beyond, ``np.median``.
SMALL_MEDIAN = 1000


def median(values: np.ndarray) -> np.floating:
    """``np.median`` of a one-dimensional array without NaN, the same number.

    ``np.median``'s own bookkeeping costs 15-20 us a call, where partitioning a few hundred
    values takes 1-3 us; the step counter takes the median of two pairs' lengths over
    every turn's stretch of a stream. So up to :data:`SMALL_MEDIAN` values it is found
    here, as ``np.median`` finds it (the middle value, or the mean of the two middle values:
    their sum over 2), and beyond by ``np.median`` (``tests/test_geometry.py`` checks that
    both agree bit for bit)."""
    n = values.shape[0]
    if n > SMALL_MEDIAN or n == 0:
        return np.median(values)
    k = n // 2
    if n % 2:
        return np.partition(values, k)[k]
    part = np.partition(values, (k - 1, k))
    return (part[k - 1] + part[k]) / 2


def frontal_lengths(vectors: np.ndarray) -> FrontalLengths:
    """Lengths of a pair's frontal vectors ``(frames, 2)``, which of them are usable (the
    module docstring's rule), and their median: for a caller that weighs pairs by their
    width and needs the lengths and the mask as well."""
    norms = np.hypot(vectors[:, 0], vectors[:, 1])
    finite = np.isfinite(norms)
    if not finite.any():
        return FrontalLengths(norms, finite, float("nan"))
    scale = median(norms[finite])
    return FrontalLengths(norms, finite & (norms > COINCIDENT_FRACTION * scale), float(scale))


def usable_frames(
    positions: np.ndarray, layout: Layout, joints: str | Sequence[str] = ("hip",)
) -> np.ndarray:
    """Boolean mask of frames whose frontal vectors are usable for every chosen pair."""
    mask = np.ones(np.asarray(positions).shape[0], dtype=bool)
    for joint in parse_joints(joints):
        mask &= frontal_lengths(frontal_vectors(positions, layout, joint)).usable
    return mask


def frame_yaw_deg(
    positions: np.ndarray, layout: Layout, joints: str | Sequence[str] = ("hip",)
) -> np.ndarray:
    """Yaw of the frontal vector per frame, unwrapped across usable frames, NaN elsewhere.

    With several joint pairs, each pair's unwrapped yaw is put on the branch of the first
    pair (a whole number of turns added) and the pairs are averaged, so the series turns as
    the body does. Yaw is the direction of the left-minus-right vector: a person's heading is
    this minus 90°; only differences of yaw matter here.
    """
    return vectors_yaw_deg([frontal_vectors(positions, layout, j) for j in parse_joints(joints)])


def vectors_yaw_deg(vectors: Sequence[np.ndarray]) -> np.ndarray:
    """:func:`frame_yaw_deg` of frontal vectors already taken: one ``(frames, 2)`` array per
    joint pair, the first pair's branch kept (a caller that reads the yaw over many stretches
    of one stream takes the vectors once and passes slices of them)."""
    mask = np.ones(vectors[0].shape[0], dtype=bool)
    for v in vectors:
        mask &= frontal_lengths(v).usable
    if not mask.any():
        return np.full(mask.shape[0], np.nan)
    every = bool(mask.all())  # mostly: then no frame is gathered or scattered
    series: list[np.ndarray] = []
    for v in vectors:
        yaw = _unwrapped_yaw_rad(v if every else v[mask])
        if series:
            yaw = yaw - 2 * np.pi * np.round((yaw[0] - series[0][0]) / (2 * np.pi))
        series.append(yaw)
    # the pairs' mean as np.mean takes it over a stack of them (their sum in order, over
    # their count), without the stack; one pair's mean is itself
    mean = series[0]
    if len(series) > 1:
        mean = series[0] + series[1]
        for yaw in series[2:]:
            mean += yaw
        mean /= len(series)
    if every:
        return np.degrees(mean)
    out = np.full(mask.shape[0], np.nan)
    out[mask] = np.degrees(mean)
    return out


def yaw_rate_deg_s(yaw_deg: np.ndarray, fps: float) -> np.ndarray:
    """Per-frame yaw rate (degrees per second) by central differences; NaN stays NaN."""
    if fps <= 0:
        raise TurnbenchError(f"fps must be positive, got {fps}")
    yaw = np.asarray(yaw_deg, dtype=float)
    if yaw.shape[0] < 2:
        return np.full(yaw.shape, np.nan)
    return np.gradient(yaw) * fps


def window_means(values: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Mean of ``values[start[i]:end[i]]`` for every window at once (cumulative sums).

    An empty window (``end <= start``) gives the value at ``start`` (clipped to the series),
    so a turn at the very first frame of a series is measured from that frame.
    """
    v = np.asarray(values, dtype=float)
    a = np.clip(np.asarray(start, dtype=np.int64), 0, v.shape[0] - 1)
    b = np.clip(np.asarray(end, dtype=np.int64), 0, v.shape[0])
    csum = np.concatenate([[0.0], np.cumsum(v)])
    n = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = (csum[np.maximum(b, a)] - csum[a]) / n
    return np.where(n > 0, mean, v[a])


def heading_change_deg(
    yaw_deg: np.ndarray,
    start: np.ndarray | int,
    end: np.ndarray | int,
    *,
    before_frames: np.ndarray | int,
    after_frames: np.ndarray | int,
    lower: np.ndarray | int = 0,
    upper: np.ndarray | int | None = None,
) -> np.ndarray:
    """Signed change of heading over turns ``[start, end)``, free of the step's pelvic rotation.

    The heading before a turn is the mean unwrapped yaw over the ``before_frames`` frames
    just before ``start`` (not before ``lower``); the heading after, the mean over the
    ``after_frames`` frames from ``end`` on (not from ``upper`` on). Over exactly one stride
    the pelvis' transverse rotation, periodic with the stride, averages out (its mean over a
    period is zero; Perry & Burnfield 2010, *Gait Analysis*, ch. 7; Saunders, Inman &
    Eberhart 1953), so the difference is the change of the walking direction, not of the
    phase of the pelvis at the two frames. Where nothing precedes (follows) the turn, the
    yaw at its first (last) frame is used: a turn from or to a standstill has no sway to
    remove. Returned in degrees, positive = left (counter-clockwise from above).

    Parameters
    ----------
    yaw_deg
        Unwrapped yaw per frame, degrees, without NaN.
    start, end
        Frames of each turn, ``end`` exclusive.
    before_frames, after_frames
        Window lengths (frames), per turn or one for all: about one stride.
    lower, upper
        Windows are cut here (the neighbouring turns' end and start; the series' ends).
    """
    yaw = np.asarray(yaw_deg, dtype=float)
    s = np.asarray(start, dtype=np.int64)
    e = np.asarray(end, dtype=np.int64)
    hi = yaw.shape[0] if upper is None else upper
    a = np.maximum(s - before_frames, lower)
    before = window_means(yaw, np.minimum(a, s), s)
    before = np.where(a < s, before, yaw[np.clip(s, 0, yaw.shape[0] - 1)])
    b = np.minimum(e + after_frames, hi)
    after = window_means(yaw, e, np.maximum(b, e))
    after = np.where(b > e, after, yaw[np.clip(e - 1, 0, yaw.shape[0] - 1)])
    return after - before


@dataclass(frozen=True)
class TurningAngle:
    """The result of :func:`turning_angle`.

    ``angle_deg`` is the magnitude by the chosen method; ``net_deg`` the signed net rotation
    (positive = left), which gives ``direction`` whatever the method.
    """

    angle_deg: float
    net_deg: float
    direction: str
    method: str
    joints: tuple[str, ...]
    n_frames: int
    n_skipped_frames: int


def _paper_sum_deg(v: np.ndarray) -> float:
    a, b = v[:-1], v[1:]
    cross = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    norms = np.hypot(a[:, 0], a[:, 1]) * np.hypot(b[:, 0], b[:, 1])
    return float(np.degrees(np.arcsin(np.clip(cross / norms, 0.0, 1.0))).sum())


def turning_angle(
    positions: np.ndarray,
    layout: Layout,
    *,
    joints: str | Sequence[str] = ("hip",),
    method: str = "net",
) -> TurningAngle:
    """Turning angle of a sequence (equation 3), averaged over the chosen joint pairs.

    Parameters
    ----------
    positions
        ``(n_frames, n_joints, 3)``, z up.
    layout
        The joint layout of ``positions``.
    joints
        Any of ``hip``, ``knee``, ``shoulder`` (the paper's Table 7 ablation); the paper's
        default is the hip.
    method
        ``paper`` (equation 3 as printed) or ``net`` (signed net rotation); see the module
        docstring for where they differ.

    Raises
    ------
    TurnbenchError
        Fewer than two usable frames, an unknown method or joint, a wrong shape.
    """
    if method not in METHODS:
        raise TurnbenchError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    names = parse_joints(joints)
    p = _check_positions(positions, layout)
    mask = usable_frames(p, layout, names)
    n_usable = int(mask.sum())
    if n_usable < 2:
        raise TurnbenchError(
            f"fewer than two usable frames ({n_usable} of {p.shape[0]}): the "
            f"{'/'.join(names)} joints are missing or coincide"
        )
    magnitudes, nets = [], []
    for joint in names:
        v = frontal_vectors(p, layout, joint)[mask]
        yaw = _unwrapped_yaw_rad(v)
        net = float(np.degrees(yaw[-1] - yaw[0]))
        nets.append(net)
        magnitudes.append(_paper_sum_deg(v) if method == "paper" else abs(net))
    net_deg = float(np.mean(nets))
    return TurningAngle(
        angle_deg=float(np.mean(magnitudes)),
        net_deg=net_deg,
        direction=direction_of(net_deg),
        method=method,
        joints=names,
        n_frames=int(p.shape[0]),
        n_skipped_frames=int(p.shape[0] - n_usable),
    )


def angular_speed_deg_s(angle_deg: float | np.ndarray, duration_s: float | np.ndarray):
    """Equation 4: mean angular speed, the turning angle over the turn's duration.

    Where a duration is not positive the speed is NaN (a table may lack durations).
    """
    angle = np.asarray(angle_deg, dtype=float)
    duration = np.asarray(duration_s, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        speed = np.where(duration > 0, angle / np.where(duration > 0, duration, 1.0), np.nan)
    return float(speed) if speed.ndim == 0 else speed


def direction_of(net_deg: float) -> str:
    """``left`` for a counter-clockwise (positive) net rotation seen from above, else ``right``.

    Exactly zero rotation is ``none``.
    """
    if net_deg > 0:
        return "left"
    if net_deg < 0:
        return "right"
    return "none"


@dataclass(frozen=True)
class BinParams:
    """How angles are binned for the accuracy, WPrec and kappa (DESIGN.md's bins)."""

    bin_width_deg: float = param(
        45.0,
        "Width of the angle bins (the paper's 45°).",
        min=0.0,
        min_open=True,
        max=limits.MAX_BIN_WIDTH_DEG,
    )


#: The paper's bin width: the default of every function that bins (:class:`BinParams`).
BIN_WIDTH_DEG: float = BinParams().bin_width_deg


def quantise_deg(angle_deg, bin_width_deg: float = BIN_WIDTH_DEG):
    """Nearest multiple of the bin width: ``45 * floor(angle / 45 + 0.5)`` (DESIGN.md).

    Halves round up (22.5 -> 45), as the floor formula does; works on scalars and arrays.
    """
    if bin_width_deg <= 0:
        raise TurnbenchError(f"bin width must be positive, got {bin_width_deg}")
    a = np.asarray(angle_deg, dtype=float)
    out = bin_width_deg * np.floor(a / bin_width_deg + 0.5)
    return float(out) if out.ndim == 0 else out
