"""Planted footsteps for synthetic motion capture: feet that stand still on the ground.

The gait model of :mod:`turn_datasets.synthetic.mocap` swings the legs from the moving pelvis,
so its feet never rest: good enough for a heading, useless for counting steps. With
``footsteps=True`` the legs are rebuilt here from a schedule of foot placements instead:

- a foot is either planted (its ankle fixed on the ground, :data:`ANKLE_HEIGHT_MM`) or in a
  swing that carries it, along a smooth-step path lifted by up to :data:`SWING_LIFT_MM`, to
  its next placement under its hip (ahead of it by half the swing's travel when walking);
- walking: one swing after the other, the feet alternating, two per stride
  (:func:`~turn_datasets.synthetic.mocap.stride_frequency_hz`); no swing is started that would
  land after its segment ends; standing: both feet planted;
- a turn of ``k`` = 1 or 2 steps is a **pivot turn** (REMAP's: one or both feet swivel in
  place): the body turns over its planted feet (the toes follow the pelvis, the ankles stay)
  and the ``k`` steps, each lasting a fifth of the turn, end at 90% of it to put the feet
  back under the new heading;
- a turn of ``k`` = 3 to 7 steps is a **step turn** (REMAP's: three steps or more without
  pivoting): ``k`` swings spread evenly over 5% to 90% of the turn, so no planted foot carries
  much more than ``1/k`` of the rotation. A turn on the spot (``pivot_turn`` segment) can be
  either: people with PD often turn on the spot in many small steps.

Every landing of a turn falls inside the turn, so the planted truth of a turn's ``steps`` is
the number of its swings. The knees are placed by two-bone inverse kinematics (thigh and
shank lengths of the body model, bending forward); where a planted foot is farther from its
hip than the leg reaches (a stride's end), the knee is placed as at full reach and the shank
stretches by the difference (at most a few centimetres): the ankle, which step counting
reads, stays exactly where it was planted.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from turn_datasets.remap.open_sheet import TURN_TYPES

__all__ = [
    "ANKLE_HEIGHT_MM",
    "SWING_LIFT_MM",
    "Swing",
    "default_steps",
    "schedule_swings",
    "plant_feet",
    "turn_steps",
    "turn_type_of",
]

#: The ankle joint's height above the floor when the foot is planted (the standing leg model's).
ANKLE_HEIGHT_MM = 70.0
#: How high a swing lifts the ankle at its middle.
SWING_LIFT_MM = 80.0
#: Right and left legs in the Human3.6M 32-joint layout: hip, knee, ankle, toe, toe end.
_LEGS = ((1, 2, 3, 4, 5), (6, 7, 8, 9, 10))


@dataclass(frozen=True)
class Swing:
    """One step: ``foot`` (0 right, 1 left) swings over frames ``[start, end)`` and lands at
    ``target`` (x, y, millimetres) on frame ``end - 1``."""

    foot: int
    start: int
    end: int
    target: tuple[float, float]


def default_steps(kind: str, heading_deg: float) -> int:
    """Steps of a turn when none are asked for: a pivot turn 1 (up to 90°) or 2; a step turn
    one per 45° plus one, between 3 and 7."""
    magnitude = abs(heading_deg)
    if kind == "pivot_turn":
        return 1 if magnitude <= 90.0 else 2
    return int(np.clip(round(magnitude / 45.0) + 1, 3, 7))


_PIVOT, _STEP = (v for v in TURN_TYPES.values() if v)


def turn_type_of(steps: int) -> str:
    """REMAP's class of a planted turn: ``pivot`` below three steps, else ``step``."""
    return _PIVOT if steps < 3 else _STEP


def _turn_windows(start: int, end: int, steps: int) -> list[tuple[int, int]]:
    """The swings of one turn (module docstring)."""
    span = end - start
    if turn_type_of(steps) == _PIVOT:
        width = 0.2 * span
        return [
            (
                start + int(round((0.9 - 0.2 * (steps - j)) * span)),
                start + int(round((0.9 - 0.2 * (steps - j)) * span + width)),
            )
            for j in range(steps)
        ]
    length = 0.85 * span / steps
    first = start + 0.05 * span
    return [
        (int(round(first + j * length)), int(round(first + (j + 1) * length))) for j in range(steps)
    ]


def schedule_swings(
    kinds: Sequence[str],
    bounds: np.ndarray,
    steps: Sequence[int],
    speed_m_s: Sequence[float],
    stride_hz: Sequence[float],
    hips_xy: np.ndarray,
    heading: np.ndarray,
    fps_hz: float,
) -> list[Swing]:
    """Every swing of a sequence, in time order (module docstring).

    ``bounds`` are the segments' first frames and the end; ``steps`` each turn's step count;
    ``hips_xy`` ``(frames, 2, 2)`` the right and left hips on the ground plane; ``heading`` the
    walking direction per frame (radians).
    """
    swings: list[Swing] = []
    free = 0  # the first frame a new swing may start on
    foot = 1  # the left foot steps first
    n = hips_xy.shape[0]
    for i, kind in enumerate(kinds):
        s, e = int(bounds[i]), int(bounds[i + 1])
        if kind == "walk":
            period = max(int(round(fps_hz / (2.0 * stride_hz[i]))), 2)
            windows = [(a, a + period) for a in range(max(s, free), e - period + 1, period)]
        elif kind in ("pivot_turn", "walking_turn"):
            windows = _turn_windows(s, e, int(steps[i]))
        else:
            windows = []
        for a, b in windows:
            a = max(a, free)
            b = min(max(b, a + 2), n)
            if b - a < 2:
                continue
            land = b - 1
            lead = 0.5 * speed_m_s[i] * 1000.0 * (b - a) / fps_hz
            direction = np.array([np.cos(heading[land]), np.sin(heading[land])])
            target = hips_xy[land, foot] + lead * direction
            swings.append(Swing(foot, a, b, (float(target[0]), float(target[1]))))
            free = b
            foot = 1 - foot
    return swings


def _ankle_paths(swings: Sequence[Swing], start_xy: np.ndarray, n: int) -> np.ndarray:
    """Each foot's ankle per frame, ``(frames, 2, 3)``: planted, or on its swing's path."""
    out = np.empty((n, 2, 3))
    out[:, :, 2] = ANKLE_HEIGHT_MM
    current = [np.asarray(start_xy[0], float), np.asarray(start_xy[1], float)]
    since = [0, 0]
    for sw in swings:
        f = sw.foot
        out[since[f] : sw.start, f, :2] = current[f]
        u = (np.arange(sw.start, sw.end) - sw.start + 1) / (sw.end - sw.start)
        smooth = u * u * (3.0 - 2.0 * u)
        target = np.asarray(sw.target)
        out[sw.start : sw.end, f, :2] = current[f] + smooth[:, None] * (target - current[f])
        out[sw.start : sw.end, f, 2] += SWING_LIFT_MM * np.sin(np.pi * u)
        current[f], since[f] = target, sw.end
    for f in (0, 1):
        out[since[f] :, f, :2] = current[f]
    return out


def _knee(hip: np.ndarray, ankle: np.ndarray, forward: np.ndarray, thigh: float, shank: float):
    """Two-bone inverse kinematics: the knee bending towards ``forward`` (rows of vectors)."""
    d_vec = ankle - hip
    d = np.linalg.norm(d_vec, axis=1)
    u = d_vec / np.maximum(d, 1e-9)[:, None]
    reach = np.minimum(d, thigh + shank - 1e-6)
    along = (thigh**2 - shank**2 + reach**2) / (2.0 * reach)
    side = np.sqrt(np.maximum(thigh**2 - along**2, 0.0))
    normal = forward - (forward * u).sum(axis=1)[:, None] * u
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-9)[:, None]
    return hip + along[:, None] * u + side[:, None] * normal


def plant_feet(
    positions: np.ndarray,
    swings: Sequence[Swing],
    pelvis_yaw: np.ndarray,
    *,
    thigh_mm: float,
    shank_mm: float,
    foot_mm: float,
    toe_mm: float,
) -> None:
    """Rebuild both legs of a 32-joint body in place from the swings (module docstring)."""
    n = positions.shape[0]
    start_xy = positions[0, [_LEGS[0][2], _LEGS[1][2]], :2]
    ankles = _ankle_paths(swings, start_xy, n)
    forward = np.stack([np.cos(pelvis_yaw), np.sin(pelvis_yaw), np.zeros(n)], axis=1)
    up = np.array([0.0, 0.0, 1.0])
    for f, (hip, knee, ankle, toe, toe_end) in enumerate(_LEGS):
        positions[:, ankle] = ankles[:, f]
        positions[:, knee] = _knee(positions[:, hip], ankles[:, f], forward, thigh_mm, shank_mm)
        positions[:, toe] = ankles[:, f] + foot_mm * forward - 50.0 * up
        positions[:, toe_end] = positions[:, toe] + toe_mm * forward


def turn_steps(swings: Sequence[Swing], start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Landings (a swing's last frame) within each turn's frames ``[start, end)``."""
    land = np.sort(np.array([sw.end - 1 for sw in swings], dtype=np.int64))
    return np.searchsorted(land, end, side="left") - np.searchsorted(land, start, side="left")
