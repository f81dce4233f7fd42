"""Mine turning clips from motion capture: the Turn-H3.6M rule, automatic and documented.

The paper (Cheng et al., "Your Turn", its Turn-H3.6M set and Table 3) found 619 clips
(45.2° to 234.7°) by searching Human3.6M by hand for runs where the hip vector turns by 45°
or more about the vertical axis. This module makes that search a rule that any motion capture can be run
through, so that the clip index can be regenerated and audited.

The rule, per sequence
----------------------
1. **Hip yaw.** The frontal vector of the hips (left minus right hip on the ground plane,
   the paper's equation 1) gives a yaw per frame (:func:`turn_datasets.geometry.frame_yaw_deg`),
   unwrapped, so a turn of 360° reads as 360°. It is unwrapped as a *line*, modulo 180°:
   no person turns by 90° between two frames, but an estimator's left/right swap, or its
   depth noise when the hips line up with the camera ray, flips the hip *vector* by 180°
   for a frame or a few; the line does not flip, so such flips are not turns.
2. **Dropouts.** Frames whose hip vector is unusable (NaN, or hips coinciding) are gaps. A
   gap of at most ``max_gap_s`` inside the sequence is bridged by linear interpolation of the
   hip positions; a longer gap cuts the sequence into pieces mined separately (a turn cannot
   be followed through a long dropout). Leading and trailing gaps are dropped.
3. **Noise.** The hip positions of each piece are low-passed with a zero-phase Butterworth
   filter at ``position_cutoff_hz`` (6 Hz, the usual cut-off for marker trajectories of
   gait, Winter 2009), so joint noise does not enter the yaw. Pelvic rotation in gait
   (about 1 Hz) passes unchanged.
4. **Stride.** Walking rotates the pelvis back and forth once per stride, about ±4° to ±8°
   in healthy adults (transverse pelvic rotation: Saunders, Inman & Eberhart 1953, "The
   major determinants in normal and pathological gait", J Bone Joint Surg 35-A:543-558;
   Perry & Burnfield 2010, *Gait Analysis*, ch. 7; measured here on CMU's walks: ±1.4° to
   ±6°, see ``tests/test_miner_cmu.py``). Whatever the heading does, this sway repeats with
   the stride, so it is removed by comparing the yaw with itself one stride apart, or by
   averaging it over one stride. The stride period of each piece is read from the knees'
   fore-aft swing (left minus right knee along the direction the hips face: once per
   stride, more than a hip width when walking), as the lag of its highest autocorrelation
   between ``min_stride_s`` and ``max_stride_s``; without knees in the layout, from the
   periodicity of the hip's own yaw where it is not turning. A piece that does not walk
   (standing, turning in place) has no sway to remove: its window is ``no_sway_window_s``,
   short enough to keep the pauses between turns in place apart.
5. **Runs of heading change (hysteresis).** The yaw is smoothed by a moving mean over
   ``smooth_s`` (joint noise), and the heading rate is its change over one stride (the
   derivative of its mean over a stride: the sway cancels between the two ends, which are
   in the same gait phase). A candidate is a maximal run of frames whose heading rate
   exceeds ``stop_speed_deg_s`` in one direction and, somewhere in the run, exceeds
   ``start_speed_deg_s`` (a double threshold, as in El-Gohary et al. 2014, "Continuous
   monitoring of turning in patients with movement disability", Sensors 14(1):356-369, and
   mobgap's ``TdElGohary``). Two runs in the same direction separated by at most
   ``merge_gap_s``, with no run the other way between them, are one turn. A turn the other
   way, however soon, is a new clip. Because the rate is taken over a stride, neither the
   sway of a slow walking turn nor joint noise splits it or starts a false one.
   **Pauses.** Continuous turning is one run however many turns it holds: a person who
   turns 90° four times with pauses of 0.1-0.3 s (CMU's trial 69_19) keeps the stride
   rate above the stop threshold throughout. A run is split at a minimum of its heading
   rate where the rate falls to ``pause_speed_deg_s`` (5 °/s, the boundary of a turn in
   El-Gohary et al. 2014), if each side turns by ``min_turn_deg``; deepest minimum first,
   then within each side. Walking, the rate is the stride's (the sway cancels); standing,
   over ``split_window_s`` (0.4 s), long enough to average a monocular estimator's
   jitter: a standstill of 0.3 s between two smooth turns in place shows, and so do
   69_19's shorter pauses, before which the real turns slow down. Walking on, two turns in
   quick succession never bring the stride rate near a standstill: a dip of
   ``walking_dip_deg_s`` (25 °/s) below the peaks on both sides, to at most half the lower
   peak, splits them. A slowing that does not
   come near a standstill (69_17's first 182° turn slows to 13 °/s halfway) is one turn:
   Shah et al. (2021), on merged and discrete turns, count a hesitation inside a turn as part of
   it, and turns apart only when the body stops.
6. **Boundaries.** A run of the stride rate sees a turn coming half a stride early, so its
   ends are not the turn's. The stride before the run is the heading before the turn; each
   later frame's departure from it is measured at the same gait phase (a whole number of
   strides back, so the sway cancels). A turn's heading starts smoothly, its rate growing
   from zero (a minimum-jerk movement: Flash & Hogan 1985, J Neurosci 5:1688-1703), so
   the departure grows with the square of the time since the start: a straight line fitted
   to its square root, where it rises from ``onset_deg`` to four times that, meets zero at
   the start. The end is found the same way, backwards from the stride after the run.
   The clip is ``[start, end)``, from where the heading starts to change to where it stops,
   not a sway extreme.
7. **Angle: the change of heading.** A clip's ``angle_deg`` is the mean yaw over the stride
   after its end minus the mean yaw over the stride before its start
   (:func:`turn_datasets.geometry.heading_change_deg`), each window cut at the neighbouring
   turns and at the piece's ends: over a whole stride the pelvic sway averages out, so the
   angle is the change of the walking direction, not of the pelvis' phase at two frames.
   A turn from or to a standstill (a turn in place) has no sway, and the means are the
   standing headings: the net rotation. El-Gohary et al. (2014) integrate the yaw rate from
   a turn's start to its end, which is this measure with the ends taken at single frames;
   the paper's criterion ("the hip vector turns by 45° or more") is kept, measured on the
   heading. ``hip_rotation_deg`` keeps the paper's own quantity beside it: the net
   rotation of the (filtered) hip vector from the clip's first frame to its last
   (:func:`turn_datasets.geometry.turning_angle`, ``method="net"``), which carries the
   pelvis' phase at both ends (a median +2.5° on synthetic walking turns with 3-5° sway,
   up to +9° on CMU's walking turns).
8. **Keep.** A candidate is a clip when its heading changes by at least ``min_turn_deg``
   the way its run turns; the windows of the clips are then cut only at the neighbouring
   clips (a smaller rotation nearby, such as the counter-rotation before a step turn, is
   part of the heading before).

9. **Bounds.** What is left is checked against what a person does
   (:func:`rejection_reasons`): turning that lasts longer than ``max_turn_s`` (10 s,
   El-Gohary et al. 2014 and mobgap's ``TdElGohary`` keep 0.5-10 s) is a *circling*
   episode, such as Human3.6M's walks round a loop at about 40 °/s for half a minute,
   not a turn of 600°; a mean speed above ``max_turn_speed_deg_s``
   (:data:`turn_datasets.limits.MAX_TURN_MEAN_SPEED_DEG_S`, 300 °/s: real turns run at
   19-154 °/s on average) is an artefact: a left/right swap, an identity break, the hip
   line flipping under noise. Neither is a clip; :func:`mine_sequence_report` returns them
   with their reason and the manifests count them.

Straight walking and standing give no clip: the sway cancels in the stride rate
(``tests/test_miner.py``, ``benchmarks/eval_miner.py``). Measured (``benchmarks/eval_miner.py``,
40 sequences a set, each in the three Human3.6M layouts): easy turns (45-160°/s, 3-5°
sway, 10 mm noise) and hard ones (25-60°/s, 6-8° sway, 20 mm noise, dropouts) are all
found, with no false clip; see the README for the angle and boundary errors.

Departures from the paper: the paper's search was manual; its clip boundaries and angles
are therefore not reproduced exactly, only its criterion (the body turning by 45° or
more). Angles are heading changes, not equation 3's sum of absolute frame-to-frame angles
(the sum grows with jitter; see :mod:`turn_datasets.geometry`) nor the hip's net rotation
between two frames (``hip_rotation_deg``).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from textwrap import indent
from types import MappingProxyType
from typing import NamedTuple

import numpy as np
import pandas as pd
from scipy import signal

from turn_datasets import limits
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import (
    direction_of,
    frame_yaw_deg,
    frontal_lengths,
    frontal_vectors,
    heading_change_deg,
    turning_angle,
    unwrap_rad,
    usable_frames,
    vectors_yaw_deg,
)
from turn_datasets.h36m.clip_index import SequenceClips, build_index
from turn_datasets.params import check_params, describe_params, param
from turn_datasets.skeleton import Layout, MocapSequence

__all__ = [
    "MinerParams",
    "SEQUENCE_CLIP_DTYPES",
    "CANDIDATE_DTYPES",
    "find_turns",
    "mine_sequence",
    "mine_sequence_report",
    "MinedSequence",
    "rejection_reasons",
    "mine_heading",
    "mine_heading_report",
    "heading_runs",
    "HeadingRuns",
    "knee_gait",
    "measure_clip",
    "mine_clips",
    "mine",
    "iter_clips",
    "check_position_cutoff",
]

#: The clips of one sequence, from :func:`mine_sequence`.
SEQUENCE_CLIP_DTYPES = MappingProxyType(
    {
        "start_frame": "int64",
        "end_frame": "int64",
        "angle_deg": "float64",
        "net_deg": "float64",
        "hip_rotation_deg": "float64",
        "direction": "str",
    }
)
#: Runs of rotation from :func:`find_turns` (direction +1 left, -1 right).
CANDIDATE_DTYPES = MappingProxyType(
    {
        "start_frame": "int64",
        "end_frame": "int64",
        "sign": "int64",
        "net_deg": "float64",
        "hip_net_deg": "float64",
    }
)

# Only the hips are needed: mining on a two-joint array keeps the work (and the float64
# copy geometry makes) to 2 of Human3.6M's 32 joints.
_HIPS = Layout("hips", 2, MappingProxyType({"left_hip": 0, "right_hip": 1}))
#: An autocorrelation at least this high at one lag is a stride period worth believing.
_MIN_STRIDE_CORRELATION = 0.3
#: Walking swings the knees fore and aft by more than this (r.m.s., hip widths); measured
#: 1.1 to 1.4 in CMU's walks, 0.2 turning in place (69_17).
_MIN_KNEE_SWING = 0.5
_BUTTER_ORDER = 2  # applied forwards and backwards: squared magnitude, zero phase


@dataclass(frozen=True)
class MinerParams:
    """Every parameter of the miner, with its default (see the module docstring for the rule).

    Each field is declared once, with its unit in its name and its help and bounds in its
    metadata (:func:`turn_datasets.params.param`); ``turn-datasets h36m mine`` makes its
    options from them. A ``position_cutoff_hz`` outside 1e-4 to 0.45 times the frame rate
    (too low for the filter's precision, or too near the Nyquist frequency to filter) leaves
    the hips unfiltered as 0 does (:func:`position_filter_applies`); ``detect`` refuses it
    (:func:`check_position_cutoff`).
    """

    min_turn_deg: float = param(
        45.0,
        "Smallest heading change of a clip, in degrees (the paper's 45).",
        min=0,
        min_open=True,
        max=limits.MAX_ANGLE_DEG,
    )
    max_gap_s: float = param(
        0.25,
        "Dropouts up to this long (seconds) are bridged; longer ones cut the sequence.",
        min=0,
        max=limits.MAX_DURATION_S,
    )
    smooth_s: float = param(
        0.3,
        "Moving-mean window of the hip yaw against joint noise, in seconds.",
        min=0,
        min_open=True,
        max=limits.MAX_DURATION_S,
    )
    start_speed_deg_s: float = param(
        20.0,
        "A turn's heading must somewhere change faster than this, in degrees per second.",
        min=0,
        min_open=True,
        max=limits.MAX_SPEED_DEG_S,
    )
    stop_speed_deg_s: float = param(
        10.0,
        "A turn lasts while its heading changes faster than this, in degrees per second.",
        min=0,
        max=limits.MAX_SPEED_DEG_S,
    )
    merge_gap_s: float = param(
        0.3,
        "Rotations in the same direction this close (seconds) are one turn.",
        min=0,
        max=limits.MAX_DURATION_S,
    )
    position_cutoff_hz: float = param(
        6.0,
        "Zero-phase low-pass of the hip positions against joint noise, in Hz (0: off).",
        min=0,
        max=limits.MAX_FPS_HZ,
    )
    stride_s: float = param(
        1.1,
        "Typical stride period, in seconds: the first guess when looking for the sway's period.",
        min=0,
        min_open=True,
        max=limits.MAX_DURATION_S,
    )
    min_stride_s: float = param(
        0.8,
        "Shortest stride period looked for in the knees' swing or the hip's sway, in seconds.",
        min=0,
        min_open=True,
        max=limits.MAX_DURATION_S,
    )
    max_stride_s: float = param(
        1.6,
        "Longest stride period looked for in the knees' swing or the hip's sway, in seconds.",
        min=0,
        min_open=True,
        max=limits.MAX_DURATION_S,
    )
    no_sway_window_s: float = param(
        0.6,
        "Heading-rate window where no stride shows (standing, turning in place), in seconds.",
        min=0,
        min_open=True,
        max=limits.MAX_DURATION_S,
    )
    split_window_s: float = param(
        0.4,
        "Heading-rate window (seconds) in which the pauses between turns in place are looked for.",
        min=0,
        min_open=True,
        max=limits.MAX_DURATION_S,
    )
    pause_speed_deg_s: float = param(
        5.0,
        "Continuous turning is split into turns where its heading rate (over split_window_s) "
        "falls to this, in degrees per second (El-Gohary et al. 2014's turn boundary).",
        min=0,
        max=limits.MAX_SPEED_DEG_S,
    )
    walking_dip_deg_s: float = param(
        25.0,
        "Walking, turning splits where its stride rate dips this far (degrees per second) "
        "below the peaks on both sides: two turns in quick succession.",
        min=0,
        min_open=True,
        max=limits.MAX_SPEED_DEG_S,
    )
    max_turn_s: float = param(
        limits.MAX_TURN_DURATION_S,
        "Turning that lasts longer than this (seconds) after splitting is not one turn but a "
        "circling episode, reported apart (El-Gohary et al. 2014: 0.5-10 s).",
        min=0,
        min_open=True,
        max=limits.MAX_DURATION_S,
    )
    circling_gap_s: float = param(
        0.5,
        "Turns the same way less than this far apart (seconds) are one episode for "
        "max_turn_s: a moment's wobble of an estimator's heading does not cut a circle into "
        "turns.",
        min=0,
        max=limits.MAX_DURATION_S,
    )
    max_turn_speed_deg_s: float = param(
        limits.MAX_TURN_MEAN_SPEED_DEG_S,
        "A turn faster than this on average (degrees per second) is an artefact (a left/right "
        "swap, an identity break, a noise flip), rejected and counted.",
        min=0,
        min_open=True,
        max=limits.MAX_SPEED_DEG_S,
    )
    onset_deg: float = param(
        6.0,
        "Heading departure (degrees) from which, to four times it, boundaries are fitted.",
        min=0,
        min_open=True,
        max=limits.MAX_ANGLE_DEG,
    )

    def __post_init__(self) -> None:
        check_params(self)
        if self.stop_speed_deg_s > self.start_speed_deg_s:
            raise TurnbenchError(
                f"stop_speed_deg_s ({self.stop_speed_deg_s}) must not exceed "
                f"start_speed_deg_s ({self.start_speed_deg_s}): the hysteresis needs a lower "
                "threshold to end a turn than to start one"
            )
        if self.min_stride_s > self.max_stride_s:
            raise TurnbenchError(
                f"min_stride_s ({self.min_stride_s}) must not exceed max_stride_s "
                f"({self.max_stride_s})"
            )

    def as_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and (exclusive) end indices of the runs of True in a boolean array."""
    edges = np.diff(np.concatenate(([0], mask.view(np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _frames(seconds: float, fps_hz: float) -> int:
    # a tolerance so that 0.3 s at 50 Hz is 15 frames, not 14 by rounding error
    return int(np.floor(seconds * fps_hz + 1e-9))


def find_turns(
    yaw_deg: np.ndarray,
    *,
    fps_hz: float,
    params: MinerParams | None = None,
    **overrides: float,
) -> pd.DataFrame:
    """Turns in a continuous yaw series: steps 4 to 8 of the rule.

    Parameters
    ----------
    yaw_deg
        Unwrapped yaw per frame, degrees, without NaN (one piece of a sequence).
    fps_hz
        Frame rate.
    params, **overrides
        :class:`MinerParams` (defaults when None), any field replaced by a keyword.

    Returns
    -------
    DataFrame
        :data:`CANDIDATE_DTYPES`: ``start_frame``, ``end_frame`` (exclusive) and ``sign``
        (+1 left, -1 right) of each turn, its heading change ``net_deg`` (signed, step 7)
        and the hip's net rotation between the boundaries ``hip_net_deg``, in time order.
        A series shorter than the heading-rate window has no turn (too short to tell a turn
        from sway). Without knees, the stride is read from the yaw's own sway.
    """
    p = replace(params or MinerParams(), **overrides)
    yaw = np.asarray(yaw_deg, dtype=float)
    if yaw.ndim != 1:
        raise TurnbenchError(f"yaw must be one-dimensional, got shape {yaw.shape}")
    if not np.isfinite(yaw).all():
        raise TurnbenchError("yaw holds NaN: bridge or split dropouts first (mine_sequence does)")
    if not (np.isfinite(fps_hz) and fps_hz > 0):
        raise TurnbenchError(f"fps must be positive, got {fps_hz}")
    start, end, sign, net, hip = _piece_turns(yaw, fps_hz, p)
    frame = pd.DataFrame(
        {"start_frame": start, "end_frame": end, "sign": sign, "net_deg": net, "hip_net_deg": hip}
    )
    return typed_frame(frame, CANDIDATE_DTYPES)


def _moving_mean(x: np.ndarray, window: int) -> np.ndarray:
    """Centred moving mean over ``window`` frames (shrinking at the ends), by cumulative sums.

    ``scipy.ndimage.uniform_filter1d`` gives the same mean inside the series (tested) but has
    no shrinking window at the ends; its ``mode`` pads instead, which would move the stride
    estimate and the heading at a piece's ends.
    """
    n = x.shape[0]
    if window <= 1 or n == 0:
        return x.copy()
    csum = np.concatenate(([0.0], np.cumsum(x)))
    idx = np.arange(n)
    lo = np.maximum(idx - window // 2, 0)
    hi = np.minimum(idx - window // 2 + window, n)
    return (csum[hi] - csum[lo]) / (hi - lo)


def _stride_rate(mean_yaw: np.ndarray, stride: int, fps_hz: float) -> np.ndarray:
    """Heading rate (degrees per second): the change of the smoothed yaw over one stride.

    ``(m[t + T - T//2] - m[t - T//2]) / T``, the derivative of the yaw's moving mean over one
    stride ``T``: the pelvic rotation, periodic with the stride, cancels exactly between the
    two ends (they are in the same phase of the gait cycle). At the ends of the series the
    span shrinks and the difference is divided by the frames it spans.
    """
    n = mean_yaw.shape[0]
    idx = np.arange(n)
    lo = np.maximum(idx - stride // 2, 0)
    hi = np.minimum(idx - stride // 2 + stride, n - 1)
    span = np.maximum(hi - lo, 1)
    return (mean_yaw[hi] - mean_yaw[lo]) * fps_hz / span


def _period(signal_: np.ndarray, valid: np.ndarray, lo: int, hi: int) -> tuple[int, float, float]:
    """Lag in ``[lo, hi]`` of the highest autocorrelation of ``signal_`` over its ``valid``
    frames (normalised by the number of valid pairs at each lag), that correlation, and the
    correlation at half that lag.

    The number of valid pairs at a lag is a whole number, and a lag with fewer than
    ``hi / 2`` of them is not believed: the counts come out of the FFT with its rounding
    error (about 1e-14, and not the same from one NumPy version to the next, whose FFTs
    differ), so they are rounded to whole numbers before they are compared, or a count equal
    to ``hi / 2`` would be kept or dropped by that error.
    """
    n = signal_.shape[0]
    x = np.where(valid, signal_, 0.0)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    spec = np.fft.rfft(x, size)
    ac = np.fft.irfft(spec * spec.conj(), size)[: hi + 1]
    vspec = np.fft.rfft(valid.astype(float), size)
    pairs = np.rint(np.fft.irfft(vspec * vspec.conj(), size)[: hi + 1])
    if not ac[0] > 0:
        return lo, 0.0, 0.0
    corr = (ac / np.maximum(pairs, 1.0)) / (ac[0] / pairs[0])
    corr[pairs < 0.5 * hi] = -np.inf
    lag = lo + int(np.argmax(corr[lo : hi + 1]))
    return lag, float(corr[lag]), float(corr[lag // 2])


def _stride_frames(
    mean_yaw: np.ndarray, fps_hz: float, p: MinerParams, gait: np.ndarray | None = None
) -> int:
    """The window of the heading rate for one piece, in frames (:func:`_stride_and_walking`)."""
    return _stride_and_walking(mean_yaw, fps_hz, p, gait)[0]


def _stride_and_walking(
    mean_yaw: np.ndarray, fps_hz: float, p: MinerParams, gait: np.ndarray | None = None
) -> tuple[int, np.ndarray | None]:
    """The window of the heading rate for one piece, in frames: its stride, if it walks; and
    the frames that walk (:func:`_knee_swing`) where the knees were read for it (None
    without knees, or in a piece too short to tell).

    With knees in the layout the stride is read from their fore-aft swing (:func:`knee_gait`,
    once per stride, larger than the hips' width when walking; Perry & Burnfield 2010): the
    lag of its highest autocorrelation between ``min_stride_s`` and ``max_stride_s`` over
    the frames that walk (a running r.m.s. swing of at least half a hip width over a
    stride), if there are two strides' worth of them, the correlation is clear (at least
    0.3) and the swing is anti-correlated at half that lag (the legs swap every half stride;
    a jump of the signal, such as an identity switch, is not). Without knees, the hip's own yaw is used the same
    way: the pelvis rotates once per stride, so the yaw's deviation from its running mean
    repeats with the stride, over the frames that are not turning. A piece that shows no
    stride (standing, turning in place, too little walking to tell) has no sway to remove
    and gets the shorter ``no_sway_window_s``, which keeps the short pauses between turns in
    place apart.
    """
    default = max(_frames(p.no_sway_window_s, fps_hz), 2)
    guess = max(_frames(p.stride_s, fps_hz), 2)
    lo = max(_frames(p.min_stride_s, fps_hz), 2)
    hi = _frames(p.max_stride_s, fps_hz)
    n = mean_yaw.shape[0]
    if n < 2 * hi:
        return default, None
    if gait is not None:
        dev, walking = _knee_swing(gait, guess)
        # a sequence that mostly stands and walks a few strides still has its stride read
        # from those
        if int(walking.sum()) < 2 * hi:
            return default, walking
        lag, corr, half = _period(dev, walking, lo, hi)
        # the legs swap every half stride: a gait's swing is anti-correlated there, which a
        # jump of the signal (an identity switch, a dropout's edge) is not
        return (lag if corr >= _MIN_STRIDE_CORRELATION and half < 0.0 else default), walking
    quiet = np.abs(_stride_rate(mean_yaw, guess, fps_hz)) < p.stop_speed_deg_s
    # a turn leaves its curvature in the deviation for half a stride around it
    quiet = _moving_mean(quiet.astype(float), guess) > 1.0 - 1e-9
    if int(quiet.sum()) < 1.5 * hi:
        return default, None
    lag, corr, half = _period(mean_yaw - _moving_mean(mean_yaw, guess), quiet, lo, hi)
    return (lag if corr >= _MIN_STRIDE_CORRELATION and half < 0.0 else default), None


#: Walking, a valley splits turning only where the stride rate falls to at most this share of
#: the lower peak beside it: a turn shorter than the stride has a ragged top (its rate over a
#: stride ripples with the steps, down to about 0.7 of its peak), two turns in quick
#: succession a valley of 0.06-0.35 of their peaks on the synthetic sessions.
_WALKING_VALLEY_OF_PEAK = 0.5


def _knee_swing(gait: np.ndarray, guess: int) -> tuple[np.ndarray, np.ndarray]:
    """The knee gait (:func:`knee_gait`) less its running mean over a stride (``guess``
    frames), 0 where it is unknown, and the frames that walk: where that swing's running
    r.m.s. over a stride is at least half a hip width."""
    valid = np.isfinite(gait)
    g = np.where(valid, gait, 0.0)
    dev = g - _moving_mean(g, guess)
    return dev, valid & (np.sqrt(_moving_mean(dev * dev, guess)) >= _MIN_KNEE_SWING)


def _hysteresis_runs(
    rate: np.ndarray, fps_hz: float, p: MinerParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 5: runs of rotation one way, with a double threshold, merged across short gaps."""
    empty = np.zeros(0, dtype=np.int64)
    starts, ends, signs = [empty], [empty], [empty]
    for sign in (1, -1):
        signed = sign * rate
        a, b = _runs(signed > p.stop_speed_deg_s)
        if a.size == 0:
            continue
        # A run counts only if it somewhere reaches the start threshold (hysteresis). reduceat
        # takes each maximum from a run's start to the next run's start; the frames between
        # are at most stop_speed_deg_s <= start_speed_deg_s, so they cannot change the verdict.
        keep = np.maximum.reduceat(signed, a) > p.start_speed_deg_s
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
    new_group[1:] = (sgn[1:] != sgn[:-1]) | (start[1:] - end[:-1] > _frames(p.merge_gap_s, fps_hz))
    first = np.flatnonzero(new_group)
    last = np.append(first[1:], start.shape[0]) - 1
    return start[first], end[last], sgn[first]


def _split_runs(
    rate: np.ndarray,
    walking: np.ndarray,
    mean_yaw: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    sign: np.ndarray,
    fps_hz: float,
    p: MinerParams,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 5's pauses: each run of turning split where it stops (:func:`_valleys`)."""
    max_frames = _frames(p.max_turn_s, fps_hz)
    out: list[tuple[int, int, int]] = []
    for a, b, g in zip(start.tolist(), end.tolist(), sign.tolist(), strict=True):
        # walking dips split only what could be turns: turning on for longer than a turn
        # lasts without a standstill is a circling episode (step 9), not turns in succession
        dips = walking[a:b] & (b - a <= max_frames)
        cuts = _valleys(g * rate[a:b], dips, g * mean_yaw[a:b], p)
        edges = [a, *(a + c for c in cuts), b]
        out += [(lo, hi, g) for lo, hi in zip(edges[:-1], edges[1:], strict=True)]
    arr = np.asarray(out, dtype=np.int64).reshape(-1, 3)
    return arr[:, 0], arr[:, 1], arr[:, 2]


def _valleys(x: np.ndarray, walking: np.ndarray, heading: np.ndarray, p: MinerParams) -> list[int]:
    """Where one run of turning (rate ``x``, one way) splits: deepest valley first, then
    within each side. A valley splits where the rate falls to ``pause_speed_deg_s`` (a
    standstill) or, walking, dips by ``walking_dip_deg_s`` below the peaks on both sides
    (two turns in quick succession while walking on, whose stride rate never stops) to at
    most half the lower peak, and each side turns by ``min_turn_deg``."""
    if x.shape[0] < 5:
        return []
    found, _ = signal.find_peaks(-x)
    best = None
    for v in found[np.argsort(x[found], kind="stable")]:
        if x[v] > p.pause_speed_deg_s:
            peak = min(float(x[:v].max()), float(x[v:].max()))
            dip = peak - x[v] >= p.walking_dip_deg_s and x[v] <= _WALKING_VALLEY_OF_PEAK * peak
            if not (walking[v] and dip):
                continue
        if min(heading[v] - heading[0], heading[-1] - heading[v]) >= p.min_turn_deg:
            best = int(v)
            break
    if best is None:
        return []
    left = _valleys(x[:best], walking[:best], heading[:best], p)
    right = _valleys(x[best:], walking[best:], heading[best:], p)
    return [*left, best, *(best + c for c in right)]


def _onset(departure: np.ndarray, onset_deg: float) -> float:
    """Where a departure from the heading before (or after) a turn began, in frames.

    ``departure`` rises from about zero through the turn's first degrees. A turn's heading
    starts smoothly, its rate growing from zero (as a minimum-jerk movement does), so the
    departure grows as the square of the time since the start, and its square root along a
    straight line that meets zero at the start. That line is fitted (least squares) to the
    frames where the departure is between ``onset_deg / 2`` and ``4 * onset_deg``, just
    before it first stays above ``4 * onset_deg``; a fit over many frames resists noise that
    a single threshold crossing does not.
    """
    n = departure.shape[0]
    high = departure >= 4.0 * onset_deg
    first = int(high.argmax()) if n else 0  # 0 also where no frame is high
    top = first if n and high[first] else n
    low = np.flatnonzero(departure[:top] < onset_deg)
    bottom = int(low[-1]) + 1 if low.size else 0
    m = top - bottom
    if m < 3:
        return float(bottom)
    r = np.sqrt(np.maximum(departure[bottom:top], 0.0))
    # least-squares line through (k, r[k]), k = 0..m-1, in closed form (cheaper than polyfit)
    k = np.arange(m) - 0.5 * (m - 1)
    slope = float(k @ r) * 12.0 / (m * (m * m - 1.0))
    if not slope > 0:
        return float(bottom)
    root = bottom + 0.5 * (m - 1) - float(r.sum()) / m / slope  # r.sum() / m is r.mean()
    # On an exact parabola the start lies 0.55 x (top - bottom) before the bottom; noise may
    # tilt the line, so the start is kept within one such span of the fitted frames.
    return min(max(root, bottom - m), bottom)


def _departure(mean_yaw: np.ndarray, frames: np.ndarray, ref_lo: int, ref_hi: int, stride: int):
    """``mean_yaw[frames]`` minus the mean yaw at the same gait phase in ``[ref_lo, ref_hi)``.

    Each frame is compared with the frame a whole number of strides away that falls in the
    reference stretch, so the pelvic rotation of the step cancels (same phase of the gait
    cycle) whatever the frame's distance from the reference; a reference shorter than a
    stride (cut at a neighbouring turn) is used as far as it goes.
    """
    if ref_hi <= ref_lo:
        return mean_yaw[frames] - mean_yaw[min(max(ref_lo, 0), mean_yaw.shape[0] - 1)]
    if frames[0] >= ref_hi:  # after the reference: step back by whole strides
        ref = frames - stride * ((frames - ref_hi) // stride + 1)
    else:  # before it: step forward
        ref = frames + stride * ((ref_lo - frames - 1) // stride + 1)
    return mean_yaw[frames] - mean_yaw[np.minimum(np.maximum(ref, ref_lo), ref_hi - 1)]


def _refine(
    mean_yaw: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    sign: np.ndarray,
    stride: int,
    onset_deg: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Step 6: each run's boundaries moved to where its heading starts and stops changing.

    A run of the stride rate starts up to half a stride before the turn (the stride's mean
    sees it coming), so the stride before that is still the heading before the turn: each
    later frame's departure from it is measured at the same gait phase
    (:func:`_departure`, the sway cancels), and :func:`_onset` finds where the departure
    began. The end is found the same way, backwards from the stride after the run.
    Boundaries are kept in order: a turn never starts before the previous one ended, and the
    reference strides stop at the neighbouring runs.
    """
    n = mean_yaw.shape[0]
    half = stride // 2
    new_start = start.copy()
    new_end = end.copy()
    prev_end = np.concatenate(([0], end[:-1]))
    next_start = np.concatenate((start[1:], [n]))
    for i in range(start.shape[0]):
        a, b, sg = int(start[i]), int(end[i]), int(sign[i])
        ref_hi = max(a - half, int(prev_end[i]), 0)
        ref_lo = max(ref_hi - stride, int(prev_end[i]), 0)
        u = np.arange(ref_hi, b + half) if b + half <= n else np.arange(ref_hi, n)
        if u.size:
            before = sg * _departure(mean_yaw, u, ref_lo, ref_hi, stride)
            new_start[i] = int(round(ref_hi + _onset(before, onset_deg)))
        ref_lo = min(b + half, int(next_start[i]), n)
        ref_hi = min(ref_lo + stride, int(next_start[i]), n)
        u = np.arange(ref_lo - 1, max(a - half, 0) - 1, -1)  # backwards from after the turn
        if u.size:
            after = -sg * _departure(mean_yaw, u, ref_lo, ref_hi, stride)
            new_end[i] = int(round(ref_lo - 1 - _onset(after, onset_deg))) + 1
    new_start = np.clip(new_start, 0, n)
    new_end = np.clip(new_end, 0, n)
    # neighbours: a turn starts no earlier than the previous one ends
    if new_start.size > 1:
        new_start[1:] = np.maximum(new_start[1:], new_end[:-1])
    return new_start, new_end


def _piece_turns(
    yaw: np.ndarray, fps_hz: float, p: MinerParams, gait: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Steps 4 to 7 on one piece's yaw (and knee gait): ``(start, end, sign, net, hip_net)``."""
    empty = np.zeros(0, dtype=np.int64)
    window = max(_frames(p.smooth_s, fps_hz), 1)
    if yaw.shape[0] < max(window, 3):
        return empty, empty, empty, np.zeros(0), np.zeros(0)
    mean_yaw = _moving_mean(yaw, window)
    stride, found = _stride_and_walking(mean_yaw, fps_hz, p, gait)
    if yaw.shape[0] < stride:
        return empty, empty, empty, np.zeros(0), np.zeros(0)
    rate = _stride_rate(mean_yaw, stride, fps_hz)
    start, end, sign = _hysteresis_runs(rate, fps_hz, p)
    if start.size == 0:
        return empty, empty, empty, np.zeros(0), np.zeros(0)
    # Pauses (step 5). Walking, the stride's rate is the finest free of the sway; where the
    # knees do not swing (standing, turning in place), over split_window_s, which shows the
    # short pauses between turns in place.
    fine = _stride_rate(mean_yaw, max(_frames(p.split_window_s, fps_hz), 2), fps_hz)
    walking = np.zeros(yaw.shape[0], dtype=bool)
    if stride != max(_frames(p.no_sway_window_s, fps_hz), 2):
        # a stride read from the knees came with the frames that walk; one read from the
        # yaw's sway (no knees) walks throughout
        walking = np.ones_like(walking) if found is None else found
        fine = np.where(walking, rate, fine)
    start, end, sign = _split_runs(fine, walking, mean_yaw, start, end, sign, fps_hz, p)
    start, end = _refine(mean_yaw, start, end, sign, stride, p.onset_deg)
    ok = end - start >= 2  # a span squeezed to nothing by its neighbours is no turn
    start, end, sign = start[ok], end[ok], sign[ok]
    # Steps 7 and 8: the heading change, first with each window cut at the neighbouring runs;
    # a run that turns by less than min_turn_deg, or against its own rotation, is no turn,
    # and the windows of the turns are then cut only at the neighbouring turns.
    net = _heading_changes(yaw, start, end, stride)
    keep = (np.abs(net) >= p.min_turn_deg) & (np.sign(net) == sign)
    if not keep.all():
        start, end, sign = start[keep], end[keep], sign[keep]
        net = _heading_changes(yaw, start, end, stride)
    hip = yaw[end - 1] - yaw[start]
    return start, end, sign, net, hip


def _heading_changes(yaw: np.ndarray, start: np.ndarray, end: np.ndarray, stride: int):
    """:func:`~turn_datasets.geometry.heading_change_deg` over one stride on each side, the
    windows cut at the neighbouring spans and the piece's ends."""
    lower = np.concatenate(([0], end[:-1]))
    upper = np.concatenate((start[1:], [yaw.shape[0]]))
    return heading_change_deg(
        yaw, start, end, before_frames=stride, after_frames=stride, lower=lower, upper=upper
    )


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


#: A hip low-pass cut-off must lie below this fraction of the frame rate: nearer the Nyquist
#: frequency a second-order Butterworth is not a filter.
FILTER_MAX_FRACTION_OF_FPS = 0.45
#: ... and at or above this fraction: lower, the filter's coefficients lose their precision
#: (at 1e-5 of the frame rate its gain at rest is off by 4e-8, at 1e-8 by 3%, and near 1e-10
#: its initial conditions are a singular system). 1e-4 of 30 fps is 0.003 Hz, far below any
#: cut-off that keeps a turn.
FILTER_MIN_FRACTION_OF_FPS = 1e-4


def position_filter_applies(cutoff_hz: float, fps_hz: float) -> bool:
    """Whether ``position_cutoff_hz`` low-passes the hips of a sequence at ``fps_hz``: the one
    rule of ``h36m mine`` and ``detect``, from at least :data:`FILTER_MIN_FRACTION_OF_FPS` to
    below :data:`FILTER_MAX_FRACTION_OF_FPS` times the rate (0: no filter, by choice)."""
    lo, hi = FILTER_MIN_FRACTION_OF_FPS * fps_hz, FILTER_MAX_FRACTION_OF_FPS * fps_hz
    return lo <= cutoff_hz < hi


def check_position_cutoff(cutoff_hz: float, fps_hz: float) -> None:
    """Refuse a non-zero ``position_cutoff_hz`` that cannot filter at ``fps_hz``
    (:func:`position_filter_applies`), where the rate is one option for every stream
    (``detect``'s ``--fps``). ``h36m mine``, whose files bring their own rates, mines such a
    sequence unfiltered and says so (a warning and the manifest's ``position_filter``).

    Raises
    ------
    TurnbenchError
        Naming the cut-off, the frame rate and the range they allow.
    """
    lo, hi = FILTER_MIN_FRACTION_OF_FPS * fps_hz, FILTER_MAX_FRACTION_OF_FPS * fps_hz
    if cutoff_hz != 0 and not position_filter_applies(cutoff_hz, fps_hz):
        raise TurnbenchError(
            f"--position-cutoff-hz {cutoff_hz:g} cannot filter at {fps_hz:g} fps: it must be 0 "
            f"(no filter) or from {FILTER_MIN_FRACTION_OF_FPS:g} x fps ({lo:.3g} Hz) to below "
            f"{FILTER_MAX_FRACTION_OF_FPS:g} x fps ({hi:.3g} Hz)",
            hint="the default 6 Hz suits rates from 13.4 fps up",
        )


def _prepare_piece(
    hips: np.ndarray, usable: np.ndarray, fps_hz: float, cutoff_hz: float
) -> np.ndarray:
    """Bridge the gaps of one piece by linear interpolation, then low-pass the hip positions.

    Only the ground-plane coordinates are worked on (the frontal vector of equation 1 is
    projected on the ground); the height of the result is zero.
    """
    n = hips.shape[0]
    xy = _bridged(np.ascontiguousarray(hips[:, :, :2]).reshape(n, 4), usable, fps_hz, cutoff_hz)
    out = np.zeros((n, 2, 3))
    out[:, :, :2] = xy.reshape(n, 2, 2)
    return out


def _bridged(xy: np.ndarray, usable: np.ndarray, fps_hz: float, cutoff_hz: float) -> np.ndarray:
    """:func:`_prepare_piece` on ground-plane coordinates ``(frames, columns)``, each column
    on its own (``xy`` is the caller's copy, bridged in place)."""
    n = xy.shape[0]
    bad = ~usable
    if bad.any():
        idx = np.arange(n)
        gaps, known, known_xy = idx[bad], idx[usable], xy[usable]
        for c in range(xy.shape[1]):
            xy[bad, c] = np.interp(gaps, known, known_xy[:, c])
    if position_filter_applies(cutoff_hz, fps_hz) and n > 3:
        xy = _zero_phase_lowpass(xy, cutoff_hz, fps_hz)
    return xy


@lru_cache(maxsize=32)
def _butter(cutoff_hz: float, fps_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Butterworth low-pass coefficients and their steady-state initial conditions, once."""
    b, a = signal.butter(_BUTTER_ORDER, cutoff_hz, fs=fps_hz)
    return b, a, signal.lfilter_zi(b, a)


def _zero_phase_lowpass(x: np.ndarray, cutoff_hz: float, fps_hz: float) -> np.ndarray:
    """``scipy.signal.filtfilt(b, a, x, axis=0)`` of a 2nd-order Butterworth, per column.

    The same forward-backward filtering with odd extension and steady-state initial
    conditions as filtfilt (its default pad of 3 x 3 samples; tested equal), with the
    coefficients and initial conditions computed once instead of per call: the miner filters
    hundreds of pieces, and on a 200-frame piece scipy's ``butter`` and ``filtfilt`` take 27
    times as long as this (2.3 times on 3000 frames; measured on the shared 2-core machine).
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


def knee_gait(frontal: np.ndarray, left_knee: np.ndarray, right_knee: np.ndarray) -> np.ndarray:
    """Fore-aft separation of the knees per frame, in hip widths (NaN where unknown).

    ``frontal`` is the frontal vector on the ground plane (left minus right hip, or any
    vector of the hips' width facing as the body does), ``(frames, 2)``; the knees are their
    ground-plane positions, ``(frames, 2)`` each. Left knee minus right knee, along the
    direction the body faces (the frontal vector turned 90° clockwise seen from above). In
    walking it swings back and forth once per stride by more than a hip width; standing, it
    stays near zero. The miner reads the stride period from it.
    """
    hip = np.asarray(frontal, dtype=float)
    knee = np.asarray(left_knee, dtype=float) - np.asarray(right_knee, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        width2 = hip[:, 0] ** 2 + hip[:, 1] ** 2
        return (knee[:, 0] * hip[:, 1] - knee[:, 1] * hip[:, 0]) / width2


def _hips_and_gait(positions: np.ndarray, layout: Layout) -> tuple[np.ndarray, np.ndarray | None]:
    """The hips on the ground plane, ``(frames, 2, 3)`` with zero height, and the knee gait
    (:func:`knee_gait`; None when the layout has no knees)."""
    p = np.asarray(positions)
    if p.ndim != 3 or p.shape[2] != 3 or p.shape[1] != layout.n_joints:
        raise TurnbenchError(
            f"positions must have shape (frames, {layout.n_joints}, 3) for layout "
            f"{layout.name!r}, got {p.shape}"
        )
    names = ["left_hip", "right_hip"]
    has_knees = "left_knee" in layout.joints and "right_knee" in layout.joints
    if has_knees:
        names += ["left_knee", "right_knee"]
    # one gather of the few joints needed (a row of 32 joints is read once, not per joint);
    # np.take copies whole joints, a third faster than indexing a list and a slice at once
    ground = np.take(p, [layout.index(j) for j in names], axis=1)[:, :, :2].astype(
        float, copy=False
    )
    hips = np.zeros((p.shape[0], 2, 3))
    hips[:, :, :2] = ground[:, :2]
    if not has_knees:
        return hips, None
    return hips, knee_gait(ground[:, 0] - ground[:, 1], ground[:, 2], ground[:, 3])


def _prepared_pieces(
    hips: np.ndarray, gait: np.ndarray | None, fps_hz: float, params: MinerParams
) -> Iterator[tuple[int, np.ndarray, np.ndarray | None]]:
    """Steps 2 and 3 of the rule: ``(first frame, bridged and filtered hips, knee gait)``.

    ``hips`` are the two hips on the ground plane, ``(frames, 2, 3)``; ``gait`` the knee gait
    (:func:`knee_gait`) or None.
    """
    usable = usable_frames(hips, _HIPS)
    for a, b in _checked_pieces(usable, fps_hz, params):
        piece = _prepare_piece(hips[a:b], usable[a:b], fps_hz, params.position_cutoff_hz)
        yield a, piece, None if gait is None else gait[a:b]


def _prepared_frontal(
    frontal: np.ndarray, gait: np.ndarray | None, fps_hz: float, params: MinerParams
) -> list[tuple[int, np.ndarray, np.ndarray | None]]:
    """:func:`_prepared_pieces` of a frontal vector ``(frames, 2)`` (NaN where unknown):
    ``(first frame, bridged and filtered frontal vector, knee gait)`` per piece. The same
    numbers as the hips' pieces with the right hip at the origin, whose zero coordinates
    stay zero through the bridging and the filter and are not worked on here."""
    usable = frontal_lengths(frontal).usable
    out = []
    for a, b in _checked_pieces(usable, fps_hz, params):
        piece = _bridged(frontal[a:b].copy(), usable[a:b], fps_hz, params.position_cutoff_hz)
        out.append((a, piece, None if gait is None else gait[a:b]))
    return out


def _checked_pieces(
    usable: np.ndarray, fps_hz: float, params: MinerParams
) -> list[tuple[int, int]]:
    """The pieces of :func:`_pieces` (gaps up to ``max_gap_s`` bridged), after the checks
    that the rule can run: a positive frame rate, two usable frames."""
    if not (np.isfinite(fps_hz) and fps_hz > 0):
        raise TurnbenchError(f"fps must be positive, got {fps_hz}")
    if int(usable.sum()) < 2:
        raise TurnbenchError(
            "fewer than two frames with a usable hip vector (hips missing or coinciding)"
        )
    return _pieces(usable, _frames(params.max_gap_s, fps_hz))


def mine_sequence(
    positions: np.ndarray,
    *,
    layout: Layout,
    fps_hz: float,
    params: MinerParams | None = None,
    **overrides: float,
) -> pd.DataFrame:
    """The turning clips of one sequence: the whole rule (see the module docstring).

    This is the miner's public entry point for any skeleton stream: z-up positions, a frame
    rate and a layout in, the turns out.

    Parameters
    ----------
    positions
        ``(n_frames, n_joints, 3)``, z up, any length unit; NaN frames are dropouts.
    layout
        The joint layout (it must name ``left_hip`` and ``right_hip``).
    fps_hz
        Frame rate of ``positions``.
    params
        The rule's parameters (:class:`MinerParams`; its defaults when None).
    **overrides
        Any :class:`MinerParams` field, replacing the one in ``params``
        (``min_turn_deg=60``, ``max_gap_s=0.5``, ...).

    Returns
    -------
    DataFrame
        :data:`SEQUENCE_CLIP_DTYPES`, in time order: ``start_frame``, ``end_frame``
        (exclusive, 0-based in ``positions``), ``angle_deg`` (magnitude of the change of
        heading, step 7), ``net_deg`` (the same, signed, positive = left),
        ``hip_rotation_deg`` (magnitude of the net hip rotation from ``start_frame`` to
        ``end_frame - 1``, the paper's quantity) and ``direction``.

    Raises
    ------
    TurnbenchError
        Positions of the wrong shape, a layout without hips, a bad parameter, or fewer than
        two frames with a usable hip vector.
    """
    return mine_sequence_report(
        positions, layout=layout, fps_hz=fps_hz, params=params, **overrides
    ).turns


class MinedSequence(NamedTuple):
    """What :func:`mine_sequence_report` returns: the turns, and what was not a turn."""

    #: :data:`SEQUENCE_CLIP_DTYPES`, the turns (as :func:`mine_sequence` returns them).
    turns: pd.DataFrame
    #: The same columns and ``reason`` (:func:`rejection_reasons`): circling episodes and
    #: turns too fast for a person, left out of ``turns``.
    rejected: pd.DataFrame


def mine_sequence_report(
    positions: np.ndarray,
    *,
    layout: Layout,
    fps_hz: float,
    params: MinerParams | None = None,
    **overrides: float,
) -> MinedSequence:
    """:func:`mine_sequence`, with the circling episodes and impossible turns it left out."""
    p = replace(params or MinerParams(), **overrides)
    hips, gait = _hips_and_gait(positions, layout)
    return _report(_with_reasons(*_mine_hips(hips, gait, fps_hz, p), fps_hz, p))


class HeadingRuns(NamedTuple):
    """The rule's runs of turning as arrays (:func:`heading_runs`), in time order: what
    :class:`MinedSequence` tabulates, for a caller that mines many pieces and wants one table."""

    #: First frame of each run.
    start: np.ndarray
    #: One past its last frame.
    end: np.ndarray
    #: Its net heading change, degrees (positive: left).
    net_deg: np.ndarray
    #: The frontal vector's own net rotation over it, degrees (signed).
    hip_deg: np.ndarray
    #: Why it is not a turn (:func:`rejection_reasons`), or ``""`` where it is one.
    reason: np.ndarray


def _with_reasons(
    start: np.ndarray,
    end: np.ndarray,
    net: np.ndarray,
    hip: np.ndarray,
    fps_hz: float,
    p: MinerParams,
) -> HeadingRuns:
    return HeadingRuns(start, end, net, hip, rejection_reasons(start, end, net, fps_hz, p))


def _report(runs: HeadingRuns) -> MinedSequence:
    """The mined runs split into turns and what step 9 rejects (:func:`rejection_reasons`)."""
    ok = runs.reason == ""
    start, end, net, hip = runs.start, runs.end, runs.net_deg, runs.hip_deg
    rejected = _sequence_frame(start[~ok], end[~ok], net[~ok], hip[~ok])
    rejected["reason"] = pd.Series(runs.reason[~ok], index=rejected.index, dtype=object)
    return MinedSequence(_sequence_frame(start[ok], end[ok], net[ok], hip[ok]), rejected)


def mine_heading(
    frontal: np.ndarray,
    *,
    fps_hz: float,
    valid: np.ndarray | None = None,
    gait: np.ndarray | None = None,
    params: MinerParams | None = None,
    **overrides: float,
) -> pd.DataFrame:
    """:func:`mine_heading_report`'s turns (as :func:`mine_sequence` is
    :func:`mine_sequence_report`'s)."""
    return mine_heading_report(
        frontal, fps_hz=fps_hz, valid=valid, gait=gait, params=params, **overrides
    ).turns


def mine_heading_report(
    frontal: np.ndarray,
    *,
    fps_hz: float,
    valid: np.ndarray | None = None,
    gait: np.ndarray | None = None,
    params: MinerParams | None = None,
    **overrides: float,
) -> MinedSequence:
    """The turning clips of a heading series: the whole rule, from step 2, on a frontal vector.

    The entry point for a caller that makes its own heading (the detector combines the
    frontal vectors of several joint pairs): the series is bridged, filtered and mined
    exactly as the hips' frontal vector of :func:`mine_sequence` is.

    Parameters
    ----------
    frontal
        ``(n_frames, 2)``: the frontal vector on the ground plane per frame (left minus right,
        at the hips' width; its direction is the heading); NaN where unknown.
    fps_hz
        Frame rate of the series.
    valid
        Frames whose vector is usable (default: every finite one); the others are gaps.
    gait
        The stride signal: the knees' fore-aft separation in hip widths per frame
        (:func:`knee_gait`), or None (the stride is then read from the heading's own sway).
    params, **overrides
        As :func:`mine_sequence`.

    Returns
    -------
    MinedSequence
        As :func:`mine_sequence_report`; ``hip_rotation_deg`` is the frontal vector's own
        net rotation over each clip.
    """
    return _report(
        heading_runs(frontal, fps_hz=fps_hz, valid=valid, gait=gait, params=params, **overrides)
    )


def heading_runs(
    frontal: np.ndarray,
    *,
    fps_hz: float,
    valid: np.ndarray | None = None,
    gait: np.ndarray | None = None,
    params: MinerParams | None = None,
    **overrides: float,
) -> HeadingRuns:
    """:func:`mine_heading_report` as arrays, the rejected runs among them (same arguments):
    no table is built, for a caller that mines a stream piece by piece."""
    # the caller's parameters as they are: a copy checks every field again, for each piece
    p = (
        params
        if params is not None and not overrides
        else replace(params or MinerParams(), **overrides)
    )
    v = np.asarray(frontal, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2:
        raise TurnbenchError(f"the frontal vector must have shape (frames, 2), got {v.shape}")
    # The vector is mined as the hips' would be with the right hip at the origin (the left
    # minus the right is the vector itself, bit for bit, through the bridging and filtering:
    # both linear, so a zero column stays zero), without that column.
    if valid is not None:
        v = v.copy()
        v[~np.asarray(valid, dtype=bool)] = np.nan
    return _with_reasons(*_mine_pieces(_prepared_frontal(v, gait, fps_hz, p), fps_hz, p), fps_hz, p)


def _sequence_frame(
    start: np.ndarray, end: np.ndarray, net: np.ndarray, hip: np.ndarray
) -> pd.DataFrame:
    frame = pd.DataFrame(
        {
            "start_frame": start,
            "end_frame": end,
            "angle_deg": np.abs(net),
            "net_deg": net,
            "hip_rotation_deg": np.abs(hip),
            "direction": [direction_of(v) for v in net],
        }
    )
    return typed_frame(frame, SEQUENCE_CLIP_DTYPES)


def _mine_hips(
    hips: np.ndarray, gait: np.ndarray | None, fps_hz: float, params: MinerParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The rule on the hips' ground positions (:func:`_prepared_pieces`): ``(start, end,
    net_deg, hip_net_deg)``, in time order."""
    pieces = [
        (a, frontal_vectors(piece, _HIPS), g)
        for a, piece, g in _prepared_pieces(hips, gait, fps_hz, params)
    ]
    return _mine_pieces(pieces, fps_hz, params)


def _mine_pieces(
    pieces: list[tuple[int, np.ndarray, np.ndarray | None]], fps_hz: float, params: MinerParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Steps 1 and 4 to 8 on the prepared pieces' frontal vectors ``(first frame, (frames,
    2), knee gait)``: ``(start, end, net_deg, hip_net_deg)``, in time order."""
    # One yaw call for all pieces: unwrapping across a cut only shifts the next piece by whole
    # turns, and only differences within a piece are used.
    all_yaw = _hip_line_deg(vectors_yaw_deg([np.concatenate([p for _, p, _ in pieces])]))
    offsets = np.cumsum([0] + [p.shape[0] for _, p, _ in pieces])
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    for (a, _, gait), lo, hi in zip(pieces, offsets[:-1], offsets[1:], strict=True):
        starts, ends, _, net, hip = _piece_turns(all_yaw[lo:hi], fps_hz, params, gait)
        parts.append((a + starts, a + ends, net, hip))
    start = np.concatenate([np.zeros(0, dtype=np.int64), *(p[0] for p in parts)])
    end = np.concatenate([np.zeros(0, dtype=np.int64), *(p[1] for p in parts)])
    net = np.concatenate([np.zeros(0), *(p[2] for p in parts)])
    hip = np.concatenate([np.zeros(0), *(p[3] for p in parts)])
    return start.astype(np.int64), end.astype(np.int64), net, hip


def _hip_line_deg(yaw_deg: np.ndarray) -> np.ndarray:
    """Step 1: the hip line's yaw, unwrapped modulo 180° (a flip of the vector is not a
    turn), from the bridged and filtered vector's yaw (NaN where it is too short to have a
    direction).

    Bridging and filtering fill every gap, but a vector that flips across a gap or within
    the filter's reach passes through zero on the way: where it passes within
    :data:`~turn_datasets.geometry.COINCIDENT_FRACTION` of its length (one frame in 7.6
    hours of the synthetic sessions with 60 mm of white depth error), it has no direction.
    The line is unwrapped over the frames that have one, and those frames take the line
    interpolated between their neighbours: the flip, which the line does not see, leaves
    no trace."""
    seen = np.isfinite(yaw_deg)
    if seen.all():
        return np.degrees(unwrap_rad(np.radians(2.0 * yaw_deg))) / 2.0
    if not seen.any():
        raise TurnbenchError("the hip vector has no direction in any frame after bridging gaps")
    frames = np.arange(yaw_deg.shape[0])
    line = np.degrees(unwrap_rad(np.radians(2.0 * yaw_deg[seen]))) / 2.0
    return np.interp(frames, frames[seen], line)


def rejection_reasons(
    start: np.ndarray, end: np.ndarray, net_deg: np.ndarray, fps_hz: float, p: MinerParams
) -> np.ndarray:
    """Why each turn is not a turn a person makes: ``""`` (it is), ``circling`` or ``too_fast``.

    ``circling``: longer than ``max_turn_s`` after continuous turning was split at its
    pauses (walking round a loop at 40 °/s for half a minute is not one 1000° turn;
    El-Gohary et al. 2014 and mobgap's ``TdElGohary`` keep turns of 0.5-10 s), counted
    over the whole episode: turns the same way less than ``circling_gap_s`` apart (an
    estimator's heading that wobbles back for a moment with the back to the camera cut a
    16 s circle of the demo's sessions into two "turns" of 7 s).
    ``too_fast``: a mean speed above ``max_turn_speed_deg_s``
    (:data:`turn_datasets.limits.MAX_TURN_MEAN_SPEED_DEG_S`), which only a left/right swap,
    an identity break or a noise flip of the hip line reaches.
    """
    start = np.asarray(start, dtype=np.int64)
    end = np.asarray(end, dtype=np.int64)
    net = np.asarray(net_deg, dtype=float)
    duration = (end - start) / fps_hz
    speed = np.abs(net) / np.maximum(duration, 1.0 / fps_hz)
    return np.where(
        _episode_s(start, end, net, fps_hz, p) > p.max_turn_s,
        "circling",
        np.where(speed > p.max_turn_speed_deg_s, "too_fast", ""),
    ).astype(object)


def _episode_s(
    start: np.ndarray, end: np.ndarray, net: np.ndarray, fps_hz: float, p: MinerParams
) -> np.ndarray:
    """Each turn's episode length, seconds: from the first to the last of its neighbours
    (in time order) that turn its way with gaps below ``circling_gap_s``."""
    if start.size == 0:
        return np.zeros(0)
    order = np.argsort(start, kind="stable")
    s, e, g = start[order], end[order], np.sign(net[order])
    joined = (g[1:] == g[:-1]) & (s[1:] - e[:-1] < p.circling_gap_s * fps_hz)
    episode = np.concatenate(([0], np.cumsum(~joined)))
    first = np.full(episode[-1] + 1, np.iinfo(np.int64).max)
    last = np.zeros(episode[-1] + 1, dtype=np.int64)
    np.minimum.at(first, episode, s)
    np.maximum.at(last, episode, e)
    out = np.empty(start.shape[0])
    out[order] = (last[episode] - first[episode]) / fps_hz
    return out


@dataclass(frozen=True)
class ClipMeasure:
    """What :func:`measure_clip` returns: a clip's two angles, degrees (positive = left)."""

    net_deg: float
    hip_net_deg: float
    stride_frames: int

    @property
    def angle_deg(self) -> float:
        return abs(self.net_deg)

    @property
    def hip_rotation_deg(self) -> float:
        return abs(self.hip_net_deg)

    @property
    def direction(self) -> str:
        return direction_of(self.net_deg)


def measure_clip(
    positions: np.ndarray,
    *,
    layout: Layout,
    fps_hz: float,
    start_frame: int,
    end_frame: int,
    lower_frame: int = 0,
    upper_frame: int | None = None,
    params: MinerParams | None = None,
    **overrides: float,
) -> ClipMeasure:
    """A clip's heading change and hip rotation over frames ``[start_frame, end_frame)``.

    ``params`` (default :class:`MinerParams`), with any field given by keyword replaced.
    Used for a curator's ``adjust`` override: the hips are bridged and filtered exactly as in
    :func:`mine_sequence` (same ``max_gap_s`` and ``position_cutoff_hz``), the stride is
    estimated on the piece as the miner does, and the heading change is
    :func:`turn_datasets.geometry.heading_change_deg` over one stride on each side, the
    windows cut at ``lower_frame`` and ``upper_frame`` (the neighbouring turns' end and
    start, as the miner cuts them; by default only the piece's ends); the hip rotation is
    :func:`turn_datasets.geometry.turning_angle` (``method="net"``) on the slice.

    Raises
    ------
    TurnbenchError
        Frames outside the sequence, or not inside one piece (they cross a dropout longer
        than ``max_gap_s``, or reach frames without usable hips at either end).
    """
    p = MinerParams(**overrides) if params is None else replace(params, **overrides)
    n = int(np.asarray(positions).shape[0])
    if not (0 <= start_frame and start_frame + 2 <= end_frame <= n):
        raise TurnbenchError(
            f"frames {start_frame}-{end_frame} are not a span of at least two frames within "
            f"the sequence's {n}"
        )
    hips, knees = _hips_and_gait(positions, layout)
    for a, piece, gait in _prepared_pieces(hips, knees, fps_hz, p):
        if a <= start_frame and end_frame <= a + piece.shape[0]:
            yaw = frame_yaw_deg(piece, _HIPS)
            window = max(_frames(p.smooth_s, fps_hz), 1)
            stride = _stride_frames(_moving_mean(yaw, window), fps_hz, p, gait)
            s, e = start_frame - a, end_frame - a
            lower = max(lower_frame - a, 0)
            upper = piece.shape[0] if upper_frame is None else min(upper_frame - a, piece.shape[0])
            net = heading_change_deg(
                yaw, s, e, before_frames=stride, after_frames=stride, lower=lower, upper=upper
            )
            hip = turning_angle(piece[s:e], _HIPS, method="net")
            return ClipMeasure(float(net), hip.net_deg, stride)
    raise TurnbenchError(
        f"frames {start_frame}-{end_frame} cross a dropout longer than max_gap_s "
        f"({p.max_gap_s} s) or frames without usable hips"
    )


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
        hips, gait = _hips_and_gait(seq.positions, seq.layout)
        start, end, net, hip = _mine_hips(hips, gait, seq.fps, params)
        reason = rejection_reasons(start, end, net, seq.fps, params)
        ok = reason == ""
        start, end, net, hip = start[ok], end[ok], net[ok], hip[ok]
        rejected = tuple(str(r) for r in reason[~ok])
    except TurnbenchError as exc:
        item = f"{seq.subject}/{seq.action}" + (f" {seq.subaction}" if seq.subaction else "")
        raise TurnbenchError(exc.message, file=seq.source or None, item=item) from None
    return SequenceClips(
        seq.subject,
        seq.action,
        seq.subaction,
        float(seq.fps),
        seq.source,
        start,
        end,
        np.abs(net),
        net,
        np.abs(hip),
        rejected,
    )


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


MinerParams.__doc__ = (
    (MinerParams.__doc__ or "") + "\n" + indent(describe_params(MinerParams), "    ")
)
