"""Mine turning clips from motion capture: the Turn-H3.6M rule, automatic and documented.

The paper (Cheng et al., "Your Turn", its Turn-H3.6M set and Table 3) found 619 clips
(45.2° to 234.7°) by searching Human3.6M by hand for runs where the hip vector turns by 45°
or more about the vertical axis. This module makes that search a rule that any motion capture can be run
through, so that the clip index can be regenerated and audited.

The rule, per sequence
----------------------
1. **Hip yaw.** The frontal vector of the hips (left minus right hip on the ground plane,
   the paper's equation 1) gives a yaw per frame (:func:`turn_datasets.geometry.frame_yaw_deg`),
   unwrapped, so a turn of 360° reads as 360°.
2. **Dropouts.** Frames whose hip vector is unusable (NaN, or hips coinciding) are gaps. A
   gap of at most ``max_gap_s`` inside the sequence is bridged by linear interpolation of the
   hip positions; a longer gap cuts the sequence into pieces mined separately (a turn cannot
   be followed through a long dropout). Leading and trailing gaps are dropped.
3. **Noise.** The hip positions of each piece are low-passed with a zero-phase Butterworth
   filter at ``position_cutoff_hz`` (6 Hz, the usual cut-off for marker trajectories of
   gait, Winter 2009), so joint noise does not enter the yaw. Pelvic rotation in gait
   (about 1 Hz) passes unchanged.
4. **Yaw rate.** The yaw rate is the first derivative of a Savitzky-Golay fit (quadratic,
   window ``smooth_s``) to the yaw. The window spans about one step: it averages out joint
   noise and damps the back-and-forth pelvic rotation of every step, while keeping the start
   and stop of a turn sharp. Walking's sway that survives is handled by the next two steps.
5. **Runs of rotation (hysteresis).** A candidate is a maximal run of frames whose yaw rate
   exceeds ``stop_speed_deg_s`` in one direction and, somewhere in the run, exceeds
   ``start_speed_deg_s`` (a double threshold, as in El-Gohary et al. 2014, "Continuous
   monitoring of turning in patients with movement disability", Sensors 14(1):356-369, and
   mobgap's ``TdElGohary``). The run starts when the rotation starts (the rate rises past
   the lower threshold) and ends when it stops (falls back below it). Two runs in the same
   direction separated by at most ``merge_gap_s``, with no run the other way between them,
   are one turn: a brief sway against the turn, or a hesitation, does not split it. A turn
   the other way, however soon, is a new clip.
6. **Angle.** A clip's ``angle_deg`` is the net rotation of the (filtered) hip vector from
   its first frame to its last (``end_frame - 1``): the magnitude of
   :func:`turn_datasets.geometry.turning_angle` with ``method="net"`` on those frames,
   positive (``left``) counter-clockwise seen from above. All candidates of a piece are
   measured at once as differences of the piece's unwrapped yaw from
   :func:`~turn_datasets.geometry.frame_yaw_deg` (every frame of a prepared piece is usable,
   so this is exactly what ``turning_angle`` returns on each slice; the tests check it, and
   :func:`measure_clip` calls ``turning_angle`` itself). A candidate is kept when the angle
   is at least ``min_turn_deg`` and turns the way its run does.

Sway of 3° to 6° per stride never reaches ``start_speed_deg_s`` after smoothing and never
adds up to ``min_turn_deg``, so straight walking and standing give no clip (measured on the
synthetic corpus of :mod:`turn_datasets.synthetic.mocap`; see ``tests/test_miner.py``).

Departures from the paper: the paper's search was manual; its clip boundaries and angles
are therefore not reproduced exactly, only its criterion (the hip vector turning by 45° or
more). Angles use the net method, not equation 3's sum of absolute frame-to-frame angles,
because the sum grows with jitter (see :mod:`turn_datasets.geometry`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from dataclasses import asdict, dataclass
from functools import lru_cache
from types import MappingProxyType

import numpy as np
import pandas as pd
from scipy import signal

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import (
    TurningAngle,
    angular_speed_deg_s,
    direction_of,
    frame_yaw_deg,
    quantise_deg,
    turning_angle,
    usable_frames,
)
from turn_datasets.render.order import natural_key
from turn_datasets.skeleton import Layout, MocapSequence

__all__ = [
    "MinerParams",
    "CLIP_INDEX_DTYPES",
    "SEQUENCE_CLIP_DTYPES",
    "CANDIDATE_DTYPES",
    "TRAIN_SUBJECTS",
    "TEST_SUBJECTS",
    "split_of",
    "clip_id_of",
    "find_turns",
    "mine_sequence",
    "measure_clip",
    "SequenceClips",
    "mine_clips",
    "build_index",
    "mine",
    "iter_clips",
]

#: The clip index (DESIGN.md), column order and dtypes.
CLIP_INDEX_DTYPES = MappingProxyType(
    {
        "clip_id": "str",
        "subject": "str",
        "action": "str",
        "subaction": "str",
        "split": "str",
        "start_frame": "int64",
        "end_frame": "int64",
        "n_frames": "int64",
        "fps": "float64",
        "start_s": "float64",
        "end_s": "float64",
        "duration_s": "float64",
        "angle_deg": "float64",
        "direction": "str",
        "bin_deg": "int64",
        "speed_deg_s": "float64",
        "source": "str",
    }
)
#: The clips of one sequence, from :func:`mine_sequence`.
SEQUENCE_CLIP_DTYPES = MappingProxyType(
    {
        "start_frame": "int64",
        "end_frame": "int64",
        "angle_deg": "float64",
        "net_deg": "float64",
        "direction": "str",
    }
)
#: Runs of rotation from :func:`find_turns` (direction +1 left, -1 right).
CANDIDATE_DTYPES = MappingProxyType({"start_frame": "int64", "end_frame": "int64", "sign": "int64"})

#: Human3.6M's usual protocol: train on S1, S5, S6, S7, S8, test on S9 and S11.
TRAIN_SUBJECTS = ("S1", "S5", "S6", "S7", "S8")
TEST_SUBJECTS = ("S9", "S11")

# Only the hips are needed: mining on a two-joint array keeps the work (and the float64
# copy geometry makes) to 2 of Human3.6M's 32 joints.
_HIPS = Layout("hips", 2, MappingProxyType({"left_hip": 0, "right_hip": 1}))
_SG_POLYORDER = 2
_BUTTER_ORDER = 2  # applied forwards and backwards: squared magnitude, zero phase


@dataclass(frozen=True)
class MinerParams:
    """Every parameter of the miner, with its default (see the module docstring for the rule).

    Attributes
    ----------
    min_turn_deg
        Smallest net hip rotation of a clip, degrees (the paper's 45).
    max_gap_s
        Longest dropout bridged by interpolation, seconds; longer ones cut the sequence.
    smooth_s
        Savitzky-Golay window of the yaw rate, seconds (about one step).
    start_speed_deg_s
        A turn must somewhere rotate faster than this, degrees per second.
    stop_speed_deg_s
        A turn lasts while it rotates faster than this, degrees per second (hysteresis).
    merge_gap_s
        Runs in the same direction this close (seconds) are one turn.
    position_cutoff_hz
        Low-pass cut-off of the hip positions, Hz (0 turns the filter off, as does a cut-off
        at or above 0.45 times the frame rate, too near the Nyquist frequency to filter).
    """

    min_turn_deg: float = 45.0
    max_gap_s: float = 0.25
    smooth_s: float = 0.6
    start_speed_deg_s: float = 20.0
    stop_speed_deg_s: float = 10.0
    merge_gap_s: float = 0.3
    position_cutoff_hz: float = 6.0

    def __post_init__(self) -> None:
        positive = ("min_turn_deg", "smooth_s", "start_speed_deg_s")
        for name, value in asdict(self).items():
            ok = value > 0 if name in positive else value >= 0
            if not (np.isfinite(value) and ok):
                kind = "positive" if name in positive else "non-negative"
                raise TurnbenchError(f"{name} must be a finite {kind} number, got {value}")
        if self.stop_speed_deg_s > self.start_speed_deg_s:
            raise TurnbenchError(
                f"stop_speed_deg_s ({self.stop_speed_deg_s}) must not exceed "
                f"start_speed_deg_s ({self.start_speed_deg_s}): the hysteresis needs a lower "
                "threshold to end a turn than to start one"
            )

    def as_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}


def split_of(subject: str) -> str:
    """``train`` for S1, S5, S6, S7, S8; ``test`` for S9, S11; ``""`` for anything else."""
    if subject in TRAIN_SUBJECTS:
        return "train"
    if subject in TEST_SUBJECTS:
        return "test"
    return ""


def clip_id_of(subject: str, action: str, subaction: str, start_frame: int, end_frame: int) -> str:
    """``{subject}_{action}_{start}-{end}`` (DESIGN.md), spaces in the action replaced by ``-``.

    The action is written as on disk, trial included (``Walking 1`` -> ``Walking-1``), so
    the two trials of an action never share an id.
    """
    name = f"{action} {subaction}" if subaction else action
    name = re.sub(r"\s+", "-", name.strip())
    return f"{subject}_{name}_{int(start_frame)}-{int(end_frame)}"


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and (exclusive) end indices of the runs of True in a boolean array."""
    edges = np.diff(np.concatenate(([0], mask.view(np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _frames(seconds: float, fps_hz: float) -> int:
    # a tolerance so that 0.3 s at 50 Hz is 15 frames, not 14 by rounding error
    return int(np.floor(seconds * fps_hz + 1e-9))


def _odd_window(seconds: float, fps_hz: float) -> int:
    n = max(int(round(seconds * fps_hz)), _SG_POLYORDER + 1)
    return n if n % 2 else n + 1


def find_turns(
    yaw_deg: np.ndarray,
    *,
    fps_hz: float,
    smooth_s: float = MinerParams.smooth_s,
    start_speed_deg_s: float = MinerParams.start_speed_deg_s,
    stop_speed_deg_s: float = MinerParams.stop_speed_deg_s,
    merge_gap_s: float = MinerParams.merge_gap_s,
) -> pd.DataFrame:
    """Runs of rotation in one direction in a continuous yaw series (steps 4 and 5 of the rule).

    Parameters
    ----------
    yaw_deg
        Unwrapped yaw per frame, degrees, without NaN (one piece of a sequence).
    fps_hz
        Frame rate.
    smooth_s, start_speed_deg_s, stop_speed_deg_s, merge_gap_s
        See :class:`MinerParams`.

    Returns
    -------
    DataFrame
        ``start_frame``, ``end_frame`` (exclusive) and ``sign`` (+1 left, -1 right) of each
        candidate, in time order. The net-rotation test (``min_turn_deg``) is
        :func:`mine_sequence`'s, which measures angles on positions. A series shorter than
        the smoothing window has no candidate (too short to tell a turn from sway).
    """
    yaw = np.asarray(yaw_deg, dtype=float)
    if yaw.ndim != 1:
        raise TurnbenchError(f"yaw must be one-dimensional, got shape {yaw.shape}")
    if not np.isfinite(yaw).all():
        raise TurnbenchError("yaw holds NaN: bridge or split dropouts first (mine_sequence does)")
    if not (np.isfinite(fps_hz) and fps_hz > 0):
        raise TurnbenchError(f"fps must be positive, got {fps_hz}")
    start, end, sign = _find_runs(
        yaw,
        fps_hz=fps_hz,
        smooth_s=smooth_s,
        start_speed_deg_s=start_speed_deg_s,
        stop_speed_deg_s=stop_speed_deg_s,
        merge_gap_s=merge_gap_s,
    )
    return typed_frame(
        pd.DataFrame({"start_frame": start, "end_frame": end, "sign": sign}), CANDIDATE_DTYPES
    )


@lru_cache(maxsize=32)
def _savgol_rate_filters(window: int, fps_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Savitzky-Golay first-derivative kernel and the two edge operators, computed once.

    Inside, the rate is a convolution with ``scipy.signal.savgol_coeffs``. In the first and
    last half-window it is the derivative of the quadratic least-squares fit to the first
    (last) ``window`` samples, evaluated at each sample, which is what
    ``scipy.signal.savgol_filter(mode="interp")`` does; as that fit is linear in the samples
    it is a fixed ``(half, window)`` matrix.
    """
    kernel = signal.savgol_coeffs(window, _SG_POLYORDER, deriv=1, delta=1.0 / fps_hz, use="conv")
    half = window // 2
    t = np.arange(window, dtype=float) / fps_hz
    vander = np.vander(t, _SG_POLYORDER + 1, increasing=True)  # columns 1, t, t^2
    fit = np.linalg.pinv(vander)  # samples -> polynomial coefficients
    powers = np.arange(1, _SG_POLYORDER + 1)
    deriv_at = powers * t[:, None] ** (powers - 1)  # d/dt of t^k at every sample
    edge = deriv_at @ fit[1:]  # samples -> derivative at every sample
    return kernel, edge[:half], edge[-half:]


def _yaw_rate(yaw: np.ndarray, window: int, fps_hz: float) -> np.ndarray:
    """Savitzky-Golay first derivative (degrees per second), as savgol_filter(mode="interp")."""
    kernel, head, tail = _savgol_rate_filters(window, fps_hz)
    rate = np.convolve(yaw, kernel, mode="same")
    half = window // 2
    rate[:half] = head @ yaw[:window]
    rate[-half:] = tail @ yaw[-window:]
    return rate


def _find_runs(
    yaw: np.ndarray,
    *,
    fps_hz: float,
    smooth_s: float,
    start_speed_deg_s: float,
    stop_speed_deg_s: float,
    merge_gap_s: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`find_turns` on arrays: ``(start, end, sign)`` int64 arrays, in time order."""
    empty = np.zeros(0, dtype=np.int64)
    window = _odd_window(smooth_s, fps_hz)
    if yaw.shape[0] < window:
        return empty, empty, empty
    rate = _yaw_rate(yaw, window, fps_hz)
    starts, ends, signs = [empty], [empty], [empty]
    for sign in (1, -1):
        signed = sign * rate
        a, b = _runs(signed > stop_speed_deg_s)
        if a.size == 0:
            continue
        # A run counts only if it somewhere reaches the start threshold (hysteresis). reduceat
        # takes each maximum from a run's start to the next run's start; the frames between
        # are at most stop_speed_deg_s <= start_speed_deg_s, so they cannot change the verdict.
        keep = np.maximum.reduceat(signed, a) > start_speed_deg_s
        starts.append(a[keep])
        ends.append(b[keep])
        signs.append(np.full(int(keep.sum()), sign, dtype=np.int64))
    start = np.concatenate(starts).astype(np.int64)
    if start.size == 0:
        return empty, empty, empty
    end = np.concatenate(ends).astype(np.int64)
    sgn = np.concatenate(signs)
    order = np.argsort(start, kind="stable")
    start, end, sgn = start[order], end[order], sgn[order]
    # Merge neighbours of the same sign closer than merge_gap_s; runs of the two signs never
    # overlap, so "neighbours in time order" means no run the other way lies between them.
    new_group = np.ones(start.shape[0], dtype=bool)
    new_group[1:] = (sgn[1:] != sgn[:-1]) | (start[1:] - end[:-1] > _frames(merge_gap_s, fps_hz))
    first = np.flatnonzero(new_group)
    last = np.append(first[1:], start.shape[0]) - 1
    return start[first], end[last], sgn[first]


def _pieces(usable: np.ndarray, max_gap_frames: int) -> list[tuple[int, int]]:
    """Spans ``[a, b)`` of usable frames joined across interior gaps of at most ``max_gap_frames``."""
    a, b = _runs(usable)
    if a.size == 0:
        return []
    gap = a[1:] - b[:-1]
    cut = np.flatnonzero(gap > max_gap_frames)
    piece_starts = np.concatenate(([a[0]], a[cut + 1]))
    piece_ends = np.concatenate((b[cut], [b[-1]]))
    return list(zip(piece_starts.tolist(), piece_ends.tolist(), strict=True))


def _prepare_piece(
    hips: np.ndarray, usable: np.ndarray, fps_hz: float, cutoff_hz: float
) -> np.ndarray:
    """Bridge the gaps of one piece by linear interpolation, then low-pass the hip positions.

    Only the ground-plane coordinates are worked on (the frontal vector of equation 1 is
    projected on the ground); the height of the result is zero.
    """
    n = hips.shape[0]
    xy = np.ascontiguousarray(hips[:, :, :2]).reshape(n, 4)
    bad = ~usable
    if bad.any():
        idx = np.arange(n)
        for c in range(4):
            xy[bad, c] = np.interp(idx[bad], idx[usable], xy[usable, c])
    if cutoff_hz > 0 and cutoff_hz < 0.45 * fps_hz and n > 3:
        xy = _zero_phase_lowpass(xy, cutoff_hz, fps_hz)
    out = np.zeros((n, 2, 3))
    out[:, :, :2] = xy.reshape(n, 2, 2)
    return out


@lru_cache(maxsize=32)
def _butter(cutoff_hz: float, fps_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Butterworth low-pass coefficients and their steady-state initial conditions, once."""
    b, a = signal.butter(_BUTTER_ORDER, cutoff_hz, fs=fps_hz)
    return b, a, signal.lfilter_zi(b, a)


def _zero_phase_lowpass(x: np.ndarray, cutoff_hz: float, fps_hz: float) -> np.ndarray:
    """``scipy.signal.filtfilt(b, a, x, axis=0)`` of a 2nd-order Butterworth, per column.

    The same forward-backward filtering with odd extension and steady-state initial
    conditions as filtfilt (its default pad of 3 x 3 samples), with the coefficients and
    initial conditions computed once instead of per call: the miner filters hundreds of
    pieces.
    """
    b, a, zi = _butter(cutoff_hz, fps_hz)
    pad = min(3 * max(len(a), len(b)), x.shape[0] - 1)
    xt = x.T
    ext = np.concatenate(
        [2 * xt[:, :1] - xt[:, pad:0:-1], xt, 2 * xt[:, -1:] - xt[:, -2 : -pad - 2 : -1]], axis=1
    )
    y, _ = signal.lfilter(b, a, ext, axis=1, zi=zi[None, :] * ext[:, :1])
    y = y[:, ::-1]
    y, _ = signal.lfilter(b, a, y, axis=1, zi=zi[None, :] * y[:, :1])
    return np.ascontiguousarray(y[:, ::-1][:, pad : ext.shape[1] - pad].T)


def _prepared_pieces(
    positions: np.ndarray, layout: Layout, fps_hz: float, params: MinerParams
) -> Iterator[tuple[int, np.ndarray]]:
    """Steps 2 and 3 of the rule: ``(first frame, bridged and filtered hips)`` per piece."""
    if not (np.isfinite(fps_hz) and fps_hz > 0):
        raise TurnbenchError(f"fps must be positive, got {fps_hz}")
    p = np.asarray(positions)
    if p.ndim != 3 or p.shape[2] != 3 or p.shape[1] != layout.n_joints:
        raise TurnbenchError(
            f"positions must have shape (frames, {layout.n_joints}, 3) for layout "
            f"{layout.name!r}, got {p.shape}"
        )
    hips = np.zeros((p.shape[0], 2, 3))
    hips[:, :, :2] = p[:, [layout.index("left_hip"), layout.index("right_hip")], :2]
    usable = usable_frames(hips, _HIPS)
    if int(usable.sum()) < 2:
        raise TurnbenchError(
            "fewer than two frames with a usable hip vector (hips missing or coinciding)"
        )
    for a, b in _pieces(usable, _frames(params.max_gap_s, fps_hz)):
        yield a, _prepare_piece(hips[a:b], usable[a:b], fps_hz, params.position_cutoff_hz)


def mine_sequence(
    positions: np.ndarray,
    *,
    layout: Layout,
    fps_hz: float,
    min_turn_deg: float = MinerParams.min_turn_deg,
    max_gap_s: float = MinerParams.max_gap_s,
    smooth_s: float = MinerParams.smooth_s,
    start_speed_deg_s: float = MinerParams.start_speed_deg_s,
    stop_speed_deg_s: float = MinerParams.stop_speed_deg_s,
    merge_gap_s: float = MinerParams.merge_gap_s,
    position_cutoff_hz: float = MinerParams.position_cutoff_hz,
) -> pd.DataFrame:
    """The turning clips of one sequence (the whole rule; see the module docstring).

    Parameters
    ----------
    positions
        ``(n_frames, n_joints, 3)``, z up, any length unit; NaN frames are dropouts.
    layout
        The joint layout (it must name ``left_hip`` and ``right_hip``).
    fps_hz
        Frame rate of ``positions``.
    min_turn_deg
        Smallest net hip rotation of a clip, degrees (paper: 45).
    max_gap_s
        Dropouts up to this long (seconds) are bridged; longer ones cut the sequence.
    smooth_s
        Savitzky-Golay window of the yaw rate, seconds.
    start_speed_deg_s
        Yaw rate a turn must exceed somewhere, degrees per second.
    stop_speed_deg_s
        Yaw rate below which a turn has stopped, degrees per second.
    merge_gap_s
        Runs of rotation in the same direction at most this far apart (seconds) are merged.
    position_cutoff_hz
        Cut-off of the zero-phase low-pass on the hip positions, Hz; 0 (or 0.45 times the
        frame rate or more) disables it.

    Returns
    -------
    DataFrame
        ``start_frame``, ``end_frame`` (exclusive, 0-based in ``positions``), ``angle_deg``
        (magnitude of the net hip rotation from ``start_frame`` to ``end_frame - 1``),
        ``net_deg`` (signed, positive = left) and ``direction``, in time order.

    Raises
    ------
    TurnbenchError
        Positions of the wrong shape, a layout without hips, a bad parameter, or fewer than
        two frames with a usable hip vector.
    """
    params = MinerParams(
        min_turn_deg=min_turn_deg,
        max_gap_s=max_gap_s,
        smooth_s=smooth_s,
        start_speed_deg_s=start_speed_deg_s,
        stop_speed_deg_s=stop_speed_deg_s,
        merge_gap_s=merge_gap_s,
        position_cutoff_hz=position_cutoff_hz,
    )
    start, end, angle, net = _mine_arrays(positions, layout, fps_hz, params)
    return _sequence_frame(start, end, angle, net)


def _sequence_frame(
    start: np.ndarray, end: np.ndarray, angle: np.ndarray, net: np.ndarray
) -> pd.DataFrame:
    frame = pd.DataFrame(
        {
            "start_frame": start,
            "end_frame": end,
            "angle_deg": angle,
            "net_deg": net,
            "direction": [direction_of(v) for v in net],
        }
    )
    return typed_frame(frame, SEQUENCE_CLIP_DTYPES)


def _mine_arrays(
    positions: np.ndarray, layout: Layout, fps_hz: float, params: MinerParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`mine_sequence` on arrays: ``(start, end, angle_deg, net_deg)``, in time order."""
    pieces = list(_prepared_pieces(positions, layout, fps_hz, params))
    # One yaw call for all pieces: unwrapping across a cut only shifts the next piece by whole
    # turns, and only differences within a piece are used.
    all_yaw = frame_yaw_deg(np.concatenate([p for _, p in pieces]), _HIPS)
    if not np.isfinite(all_yaw).all():
        # interpolation fills every gap and filtering cannot make NaN: a cheap guard
        raise TurnbenchError("the hip yaw is not finite after bridging gaps")
    offsets = np.cumsum([0] + [p.shape[0] for _, p in pieces])
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for (a, _), lo, hi in zip(pieces, offsets[:-1], offsets[1:], strict=True):
        yaw = all_yaw[lo:hi]
        starts, ends, signs = _find_runs(
            yaw,
            fps_hz=fps_hz,
            smooth_s=params.smooth_s,
            start_speed_deg_s=params.start_speed_deg_s,
            stop_speed_deg_s=params.stop_speed_deg_s,
            merge_gap_s=params.merge_gap_s,
        )
        ok = ends - starts >= 2
        starts, ends, signs = starts[ok], ends[ok], signs[ok]
        # Step 6: turning_angle(piece[s:e], method="net") for every candidate at once. Every
        # frame of a prepared piece is usable, so the net rotation of a slice is the
        # difference of the piece's unwrapped yaw (geometry's frame_yaw_deg) between the
        # slice's first and last frames; tests check it equals turning_angle on each slice.
        net = yaw[ends - 1] - yaw[starts]
        keep = (np.abs(net) >= params.min_turn_deg) & (np.sign(net) == signs)
        parts.append((a + starts[keep], a + ends[keep], net[keep]))
    start = np.concatenate([np.zeros(0, dtype=np.int64), *(p[0] for p in parts)])
    end = np.concatenate([np.zeros(0, dtype=np.int64), *(p[1] for p in parts)])
    net = np.concatenate([np.zeros(0), *(p[2] for p in parts)])
    return start.astype(np.int64), end.astype(np.int64), np.abs(net), net


def measure_clip(
    positions: np.ndarray,
    *,
    layout: Layout,
    fps_hz: float,
    start_frame: int,
    end_frame: int,
    **params: float,
) -> TurningAngle:
    """The net hip rotation of frames ``[start_frame, end_frame)``, measured as the miner does.

    Used for a curator's ``adjust`` override: the hips are bridged and filtered exactly as in
    :func:`mine_sequence` (same ``max_gap_s`` and ``position_cutoff_hz``), then
    :func:`turn_datasets.geometry.turning_angle` (``method="net"``) runs on the slice.

    Raises
    ------
    TurnbenchError
        Frames outside the sequence, or not inside one piece (they cross a dropout longer
        than ``max_gap_s``, or reach frames without usable hips at either end).
    """
    p = MinerParams(**params)
    n = int(np.asarray(positions).shape[0])
    if not (0 <= start_frame and start_frame + 2 <= end_frame <= n):
        raise TurnbenchError(
            f"frames {start_frame}-{end_frame} are not a span of at least two frames within "
            f"the sequence's {n}"
        )
    for a, piece in _prepared_pieces(positions, layout, fps_hz, p):
        if a <= start_frame and end_frame <= a + piece.shape[0]:
            return turning_angle(piece[start_frame - a : end_frame - a], _HIPS, method="net")
    raise TurnbenchError(
        f"frames {start_frame}-{end_frame} cross a dropout longer than max_gap_s "
        f"({p.max_gap_s} s) or frames without usable hips"
    )


@dataclass
class SequenceClips:
    """The clips of one sequence with what the index needs to know about the sequence.

    Arrays, not a DataFrame, so that mining a whole corpus builds one table at the end
    (:func:`build_index`). ``start_frame``/``end_frame`` are 0-based, end exclusive.
    """

    subject: str
    action: str
    subaction: str
    fps: float
    source: str
    start_frame: np.ndarray
    end_frame: np.ndarray
    angle_deg: np.ndarray
    net_deg: np.ndarray

    def __len__(self) -> int:
        return int(self.start_frame.shape[0])

    @property
    def clip_ids(self) -> list[str]:
        return [
            clip_id_of(self.subject, self.action, self.subaction, s, e)
            for s, e in zip(self.start_frame.tolist(), self.end_frame.tolist(), strict=True)
        ]

    def replace_clips(
        self, start: np.ndarray, end: np.ndarray, angle: np.ndarray, net: np.ndarray
    ) -> SequenceClips:
        """The same sequence with other clips, sorted by frames."""
        order = np.lexsort((end, start))
        return SequenceClips(
            self.subject,
            self.action,
            self.subaction,
            self.fps,
            self.source,
            np.asarray(start, dtype=np.int64)[order],
            np.asarray(end, dtype=np.int64)[order],
            np.asarray(angle, dtype=float)[order],
            np.asarray(net, dtype=float)[order],
        )

    def to_frame(self) -> pd.DataFrame:
        """Its rows of the clip index."""
        return build_index([self])


def mine_clips(seq: MocapSequence, params: MinerParams | None = None) -> SequenceClips:
    """Mine one sequence as a reader returns it.

    Raises
    ------
    TurnbenchError
        The sequence cannot be mined (no usable hips, a wrong shape), naming its source file
        and the sequence (``subject/action subaction``).
    """
    params = params or MinerParams()
    try:
        start, end, angle, net = _mine_arrays(seq.positions, seq.layout, seq.fps, params)
    except TurnbenchError as exc:
        item = f"{seq.subject}/{seq.action}" + (f" {seq.subaction}" if seq.subaction else "")
        raise TurnbenchError(exc.message, file=seq.source or None, item=item) from None
    return SequenceClips(
        seq.subject, seq.action, seq.subaction, float(seq.fps), seq.source, start, end, angle, net
    )


def build_index(parts: Iterable[SequenceClips]) -> pd.DataFrame:
    """The clip index (DESIGN.md's columns, in order, typed) from mined sequences.

    Rows are ordered by subject (S2 before S11), action, subaction, source and start frame,
    so the index does not depend on the order in which the sources were read.

    Raises
    ------
    TurnbenchError
        Two clips with the same id (the same sequence read twice, for example from both a
        CDF and an h5 copy), naming both sources.
    """
    seqs = sorted(
        (p for p in parts if len(p)),
        key=lambda p: (
            natural_key(p.subject),
            p.action,
            natural_key(p.subaction),
            p.source,
        ),
    )
    if not seqs:
        return typed_frame(pd.DataFrame({c: [] for c in CLIP_INDEX_DTYPES}), CLIP_INDEX_DTYPES)
    counts = [len(p) for p in seqs]

    def per_clip(values: list) -> np.ndarray:
        return np.repeat(np.asarray(values, dtype=object), counts)

    start = np.concatenate([p.start_frame for p in seqs])
    end = np.concatenate([p.end_frame for p in seqs])
    angle = np.concatenate([p.angle_deg for p in seqs])
    net = np.concatenate([p.net_deg for p in seqs])
    fps = np.repeat(np.asarray([p.fps for p in seqs], dtype=float), counts)
    duration = (end - start) / fps
    frame = pd.DataFrame(
        {
            "clip_id": [c for p in seqs for c in p.clip_ids],
            "subject": per_clip([p.subject for p in seqs]),
            "action": per_clip([p.action for p in seqs]),
            "subaction": per_clip([p.subaction for p in seqs]),
            "split": per_clip([split_of(p.subject) for p in seqs]),
            "start_frame": start,
            "end_frame": end,
            "n_frames": end - start,
            "fps": fps,
            "start_s": start / fps,
            "end_s": end / fps,
            "duration_s": duration,
            "angle_deg": angle,
            "direction": [direction_of(v) for v in net.tolist()],
            "bin_deg": np.asarray(quantise_deg(angle)).astype(np.int64),
            "speed_deg_s": angular_speed_deg_s(angle, duration),
            "source": per_clip([p.source for p in seqs]),
        }
    )
    dup = frame["clip_id"].duplicated(keep=False)
    if dup.any():
        first = frame.loc[dup, "clip_id"].iloc[0]
        sources = sorted(set(frame.loc[frame["clip_id"] == first, "source"]))
        raise TurnbenchError(
            f"clip id {first!r} occurs twice: the same subject and action were read from "
            f"{' and '.join(sources)}",
            hint="give each sequence once (one copy of the dataset)",
        )
    return typed_frame(frame, CLIP_INDEX_DTYPES)


def iter_clips(
    sequences: Iterable[MocapSequence], params: MinerParams | None = None
) -> Iterator[tuple[MocapSequence, SequenceClips]]:
    """Mine each sequence in turn, yielding it with its clips (:func:`mine_clips`)."""
    params = params or MinerParams()
    for seq in sequences:
        yield seq, mine_clips(seq, params)


def mine(sequences: Iterable[MocapSequence], **params: float) -> pd.DataFrame:
    """Mine every sequence into the clip index (DESIGN.md's columns, in order, typed).

    Parameters
    ----------
    sequences
        Sequences as the readers yield them (:func:`turn_datasets.mocap.readers.read_source`).
    **params
        Any of :class:`MinerParams`' fields (``min_turn_deg``, ``max_gap_s``, ...).

    Returns
    -------
    DataFrame
        One row per clip: ``clip_id`` (``{subject}_{action}_{start}-{end}``, unique),
        ``subject``, ``action``, ``subaction``, ``split`` (train S1/S5/S6/S7/S8, test
        S9/S11, else empty), ``start_frame``, ``end_frame`` (exclusive), ``n_frames``,
        ``fps``, ``start_s``, ``end_s``, ``duration_s`` (= n_frames / fps), ``angle_deg``,
        ``direction``, ``bin_deg`` (nearest multiple of 45,
        :func:`turn_datasets.geometry.quantise_deg`), ``speed_deg_s`` (equation 4,
        :func:`turn_datasets.geometry.angular_speed_deg_s`) and ``source``.
    """
    p = MinerParams(**params)
    return build_index(clips for _, clips in iter_clips(sequences, p))
