"""Steps, turn type and peak turning speed of a turn, from a 3D skeleton's ankles and hips.

REMAP's raters counted each turn's steps (``number_of_turning_steps``) and classed it as a
**pivot turn** (one or both feet swivel in place) or a **step turn** (three steps or more
without pivoting); fewer steps per turn in controls is one of the clearest PD differences
reported at home (Mancini et al. 2015, NeuroRehabilitation 37:3-10). From a skeleton with
ankles (Human3.6M's ``left_foot``/``right_foot`` joints are the ankles) they are measured so:

1. **Scale.** Thresholds are in leg lengths (the median hip-to-ankle distance of the stream),
   so a file in metres and one in millimetres give the same answer, and a child's steps are
   judged by a child's legs.
2. **Swings.** Each ankle's position is averaged over ``smooth_s`` (0.2 s; a swing lasts
   0.3-0.5 s), and its horizontal speed (central differences of that average) marks the
   frames a foot is moving: above ``move_legs_s`` leg lengths per second. A pose estimator's
   ankles jitter frame to frame, and it is the positions that are averaged, not the
   speeds: the jitter's own speed is never negative, so an average of speeds keeps it.
   Under a white depth error of 30 mm per frame (and 8 mm of jitter, at 30 fps) a planted
   ankle's speed averaged over 0.1 s has a median of 0.74 m/s, twice the threshold below,
   and nearly every frame would be moving; the speed of its position averaged over 0.2 s
   has a median of 0.19 m/s. A swinging foot moves at 1 to 4 m/s (2 to 4 leg lengths/s) in
   the middle of its swing: 0.4 leg lengths/s (about 0.35 m/s) is far from both. A run of
   moving frames is a swing when the ankle's averaged position travels at least
   ``min_step_legs`` leg lengths over it (0.1, about 9 cm: a shuffle or the slow drift of an
   estimator's depth error is not a step; turning steps in PD are short, so not more).
3. **Steps** are the foot contacts during the turn: swings whose landing lies from the
   turn's first frame to ``landing_margin_s`` after its last. The landing is the run's last
   frame less a quarter of the averaging window (the average still moves for about that
   long after the foot has stopped): on the CMU captures of ``../shared/data/cmu-mocap``
   (56 landings) it then falls a median 0.01 s before the frame where the unaveraged speed
   drops under the threshold (0.04 s after it taken as it is, 0.06 s before it less half
   the window). The heading stops changing as the last foot lands, and a turn's end is
   fitted from the heading (at 15 °/s, a few frames early), so a landing just after it still
   belongs to it.
4. **Turn type** by REMAP's rule: a step turn has three steps or more and no foot that
   swivels; a foot swivels when, planted, it carries at least ``pivot_share`` of the turn's
   rotation (the body heading's change while that foot is down, over the turn's). Stepping
   spreads the rotation over the contacts (with three even steps a stance carries at most
   about 45%); turning on the spot puts most of it over the planted feet.
5. **Peak speed**: the largest heading change over any ``peak_window_s`` within the turn,
   over that window. A half-second window keeps 94% of the peak of a 1.3 s sinusoidal turn
   and averages out two thirds of the pelvis's step-by-step sway (at a stride a second).

The heading is :func:`turn_datasets.geometry.frame_yaw_deg` of the hips and shoulders (the
detector's own pairs).
"""

from __future__ import annotations

from dataclasses import dataclass
from textwrap import indent

import numpy as np
import pandas as pd
from scipy.ndimage import minimum_filter1d, uniform_filter1d

from turn_datasets.geometry import frontal_vectors, vectors_yaw_deg
from turn_datasets.params import check_params, describe_params, param
from turn_datasets.skeleton import Layout
from turn_eval.events.contract import TURN_TYPES

__all__ = ["StepParams", "STEP_COLUMNS", "STEP_JOINTS", "turn_steps", "foot_swings"]

#: What :func:`turn_steps` adds to each turn, in the detections contract's order.
STEP_COLUMNS = {"peak_speed_deg_s": "float64", "steps": "float64", "turn_type": "str"}
_ANKLES = ("right_foot", "left_foot")
#: The joints :func:`turn_steps` reads beside the hips and shoulders: the ankles.
STEP_JOINTS = _ANKLES
_PIVOT, _STEP = TURN_TYPES
_HIPS = ("right_hip", "left_hip")


@dataclass(frozen=True)
class StepParams:
    """The step counter's thresholds (module docstring gives each one's reason)."""

    move_legs_s: float = param(
        0.4,
        "An ankle moving faster than this many leg lengths per second (horizontally) is in "
        "a swing.",
        min=0,
        min_open=True,
        max=100.0,
    )
    min_step_legs: float = param(
        0.1,
        "A swing is a step when the ankle travels at least this many leg lengths.",
        min=0,
        max=10.0,
    )
    lift_legs: float = param(
        0.03,
        "An ankle higher than this many leg lengths above its lowest of the last "
        "ground_window_s (the floor under it) is lifted: in a swing.",
        min=0,
        min_open=True,
        max=10.0,
    )
    min_lift_legs: float = param(
        0.05,
        "A swing that lifts the ankle this many leg lengths is a step, however short.",
        min=0,
        min_open=True,
        max=10.0,
    )
    ground_window_s: float = param(
        2.0,
        "The floor under an ankle is its lowest height within this many seconds.",
        min=0,
        min_open=True,
        max=60.0,
    )
    smooth_s: float = param(
        0.2,
        "Ankle positions are averaged over this many seconds before their speed and height "
        "are read.",
        min=0,
        max=2.0,
    )
    landing_margin_s: float = param(
        0.25,
        "A landing up to this many seconds after a turn's end still counts as its step.",
        min=0,
        max=5.0,
    )
    pivot_share: float = param(
        0.6,
        "A foot that stays planted while the body turns by this share of the turn swivels: "
        "a pivot turn.",
        min=0,
        min_open=True,
        max=1.0,
    )
    peak_window_s: float = param(
        0.5,
        "The peak turning speed is the largest heading change over a window this long.",
        min=0,
        min_open=True,
        max=10.0,
    )

    def __post_init__(self) -> None:
        check_params(self)


StepParams.__doc__ = (StepParams.__doc__ or "") + "\n" + indent(describe_params(StepParams), "    ")


def _leg_length(positions: np.ndarray, layout: Layout) -> float:
    hips = positions[:, [layout.index(j) for j in _HIPS]]
    ankles = positions[:, [layout.index(j) for j in _ANKLES]]
    d = np.linalg.norm(hips - ankles, axis=2)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else float("nan")


def _filled(values: np.ndarray) -> np.ndarray:
    """Rows with a NaN filled by linear interpolation over time (a gap is not a swing unless
    the foot moved across it); all-NaN columns stay NaN."""
    out = np.array(values, dtype=float)
    seen = np.isfinite(out).all(axis=1)
    if seen.any() and not seen.all():
        gaps, known = np.flatnonzero(~seen), np.flatnonzero(seen)
        for k in range(out.shape[1]):
            out[gaps, k] = np.interp(gaps, known, out[known, k])
    return out


def _pinned(p: np.ndarray, layout: Layout, leg: float) -> bool:
    """Whether the stream is root-relative (the hips never leave the origin): then a planted
    foot moves against the pelvis as fast as the person walks, and only its lift tells a
    swing."""
    right, left = (layout.index(j) for j in _HIPS)
    x = 0.5 * (p[:, right, 0] + p[:, left, 0])
    y = 0.5 * (p[:, right, 1] + p[:, left, 1])
    seen = np.isfinite(x) & np.isfinite(y)
    return bool(seen.any()) and max(float(np.ptp(x[seen])), float(np.ptp(y[seen]))) < 0.05 * leg


def foot_swings(
    positions: np.ndarray, layout: Layout, fps_hz: float, params: StepParams | None = None
) -> list[tuple[int, int, int]]:
    """Every swing of both feet: ``(foot, first_frame, landing_frame)``, foot 0 right, 1
    left, in order of landing (module docstring, steps 1 to 3)."""
    prm = params or StepParams()
    p = np.asarray(positions, dtype=float)
    leg = _leg_length(p, layout)
    if not np.isfinite(leg) or leg <= 0 or p.shape[0] < 3:
        return []
    window = max(int(round(prm.smooth_s * fps_hz)), 1)
    ground = max(int(round(prm.ground_window_s * fps_hz)), 1)
    pinned = _pinned(p, layout, leg)
    out = []
    for foot, name in enumerate(_ANKLES):
        xyz = _filled(p[:, layout.index(name)])
        if not np.isfinite(xyz).all():
            continue
        # the positions averaged, not the speeds (module docstring, step 2)
        xyz = uniform_filter1d(xyz, window, axis=0, mode="nearest")
        velocity = np.gradient(xyz[:, :2], axis=0) * fps_hz
        speed = np.hypot(velocity[:, 0], velocity[:, 1])
        height = xyz[:, 2]
        lift = height - minimum_filter1d(height, ground, mode="nearest")
        moving = lift > prm.lift_legs * leg
        if not pinned:
            moving |= speed > prm.move_legs_s * leg
        edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(np.int8), [0]])))
        first, stop = edges[::2], edges[1::2]
        # each run's travel (from the frame before it to its last) and highest lift, for all
        # runs at once: a day's stream has thousands of swings
        moved = xyz[stop - 1, :2] - xyz[np.maximum(first - 1, 0), :2]
        stepped = (np.hypot(moved[:, 0], moved[:, 1]) >= prm.min_step_legs * leg) & (not pinned)
        # the runs and the gaps between them alternate in ``edges``: every other maximum
        highest = np.maximum.reduceat(np.append(lift, 0.0), edges)[::2] if first.size else lift[:0]
        keep = stepped | (highest >= prm.min_lift_legs * leg)
        # the average still moves for about a quarter of its window after the foot has landed
        land = np.maximum(stop[keep] - 1 - window // 4, first[keep])
        out += [(foot, int(a), int(b)) for a, b in zip(first[keep], land, strict=True)]
    return sorted(out, key=lambda s: (s[2], s[0]))


def _stance_share(swings: np.ndarray, yaw: np.ndarray, a: int, b: int) -> float:
    """The largest share of the turn's rotation over one planted foot (steps < 3 aside);
    ``swings`` is :func:`foot_swings`' list as an ``(n, 3)`` integer array."""
    total = abs(yaw[b] - yaw[a])
    if not np.isfinite(total) or total == 0:
        return float("nan")
    best = 0.0
    near = swings[(swings[:, 2] >= a) & (swings[:, 1] <= b)]
    for foot in (0, 1):
        mine = near[near[:, 0] == foot]
        stance = np.column_stack((np.maximum(mine[:, 1], a), np.minimum(mine[:, 2], b)))
        cuts = [a, *stance.ravel().tolist(), b]
        for lo, hi in zip(cuts[::2], cuts[1::2], strict=True):
            if hi > lo:
                best = max(best, abs(yaw[hi] - yaw[lo]) / total)
    return best


def _filled_yaw(vectors: list[np.ndarray]) -> np.ndarray:
    """The heading of a stretch (:func:`~turn_datasets.geometry.vectors_yaw_deg` of the hips'
    and shoulders' frontal vectors over it), its gaps filled by linear interpolation."""
    yaw = vectors_yaw_deg(vectors)
    seen = np.isfinite(yaw)
    if seen.any() and not seen.all():
        frames = np.arange(yaw.shape[0])
        yaw[~seen] = np.interp(frames[~seen], frames[seen], yaw[seen])
    return yaw


#: The heading is read over each turn and this long on either side (beyond the peak
#: speed's window), seconds: enough for a dropout at a turn's edge to be bridged as it is
#: on the whole stream.
_YAW_CONTEXT_S = 1.0


def _turn_yaw(
    p: np.ndarray, layout: Layout, start: np.ndarray, end: np.ndarray, pad: int
) -> np.ndarray:
    """:func:`_filled_yaw` over the turns ``[start, end)`` and ``pad`` frames either side
    (overlapping stretches merged), NaN elsewhere: a day's stream is mostly not turning,
    and the yaw's arctangents are most of the step counter's time. The frontal vectors
    are taken once for the stream, and each stretch reads its slice of them."""
    n = p.shape[0]
    joints = ("hip", "shoulder") if "left_shoulder" in layout.joints else ("hip",)
    vectors = [frontal_vectors(p, layout, j) for j in joints]
    lo = np.clip(start - pad, 0, n)
    hi = np.clip(end + pad, 0, n)
    yaw = np.full(n, np.nan)
    order = np.argsort(lo, kind="stable")
    w0, w1 = int(lo[order[0]]), int(hi[order[0]])
    for k in [*order[1:].tolist(), None]:
        if k is not None and lo[k] <= w1:
            w1 = max(w1, int(hi[k]))
            continue
        if w1 > w0:
            yaw[w0:w1] = _filled_yaw([v[w0:w1] for v in vectors])
        if k is not None:
            w0, w1 = int(lo[k]), int(hi[k])
    return yaw


def _peak_speeds(
    yaw: np.ndarray, first: np.ndarray, last: np.ndarray, half: int, fps_hz: float
) -> np.ndarray:
    """Each turn's peak speed (module docstring, step 5): the largest heading change over a
    window of ``2 * half`` frames centred on any of its frames ``first..last`` (inclusive;
    windows cut at the stream's ends), over that window's duration; for all turns at once."""
    n = last - first + 1
    offsets = np.concatenate(([0], np.cumsum(n)[:-1]))
    centres = np.arange(int(n.sum())) - np.repeat(offsets - first, n)
    end = yaw.shape[0] - 1
    lo, hi = np.clip(centres - half, 0, end), np.clip(centres + half, 0, end)
    speed = np.abs(yaw[hi] - yaw[lo]) / ((hi - lo) / fps_hz)
    return np.maximum.reduceat(speed, offsets)


def turn_steps(
    positions: np.ndarray,
    layout: Layout,
    fps_hz: float,
    start_frame: np.ndarray,
    end_frame: np.ndarray,
    params: StepParams | None = None,
) -> pd.DataFrame:
    """Peak speed, steps and turn type of each turn ``[start_frame, end_frame)`` of a stream.

    ``positions`` ``(frames, joints, 3)``, z up, any length unit, NaN where unseen; the
    layout must name the hips and the ankles (``left_foot``, ``right_foot``). Returns
    :data:`STEP_COLUMNS`, one row per turn; NaN and empty where the stream does not show the
    feet.
    """
    prm = params or StepParams()
    p = np.asarray(positions, dtype=float)
    start = np.asarray(start_frame, dtype=np.int64)
    end = np.asarray(end_frame, dtype=np.int64)
    n = start.shape[0]
    out = {"peak_speed_deg_s": np.full(n, np.nan), "steps": np.full(n, np.nan)}
    kinds = np.full(n, "", dtype=object)
    if n == 0 or p.shape[0] < 2:
        return pd.DataFrame({**out, "turn_type": kinds})
    yaw = _turn_yaw(
        p, layout, start, end, int(round(fps_hz * (_YAW_CONTEXT_S + prm.peak_window_s)))
    )
    swings = (
        foot_swings(p, layout, fps_hz, prm) if all(j in layout.joints for j in _ANKLES) else None
    )
    swung = np.array(swings or [], dtype=np.int64).reshape(-1, 3)
    landings = swung[:, 2]  # in order (foot_swings sorts by landing)
    margin = int(round(prm.landing_margin_s * fps_hz))
    half = max(int(round(prm.peak_window_s * fps_hz / 2)), 1)
    last = p.shape[0] - 1
    a, b = np.clip(start, 0, last), np.clip(end - 1, 0, last)
    unseen = np.concatenate(([0], np.cumsum(~np.isfinite(yaw))))
    measured = np.flatnonzero((b > a) & (unseen[b + 1] == unseen[a]))
    if measured.size == 0:
        return pd.DataFrame({**out, "turn_type": kinds})
    out["peak_speed_deg_s"][measured] = _peak_speeds(yaw, a[measured], b[measured], half, fps_hz)
    if swings is None:
        return pd.DataFrame({**out, "turn_type": kinds})
    steps = np.searchsorted(landings, b + margin, "right") - np.searchsorted(landings, a, "left")
    out["steps"][measured] = steps[measured]
    for i in measured.tolist():
        share = _stance_share(swung, yaw, int(a[i]), int(b[i]))
        kinds[i] = _STEP if steps[i] >= 3 and not share >= prm.pivot_share else _PIVOT
    return pd.DataFrame({**out, "turn_type": kinds})
