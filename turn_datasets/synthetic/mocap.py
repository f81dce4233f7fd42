"""Synthetic Human3.6M-like motion capture with planted turns, for testing miners and harnesses.

A sequence is a list of :class:`Segment` s (stand, walk, pivot turn, walking turn) laid end to
end. From them a body is built frame by frame, all frames at once (NumPy, no per-frame loop):

- a *heading* (the direction the person walks and faces), changed only by turns, with a
  sinusoidal yaw-rate profile (zero at the turn's first and last frames, peak at the middle);
- a ground path integrated from the walking speed along the heading, so a walking turn is a
  curved path and a pivot turn happens on the spot;
- a *pelvis frame* whose yaw is the heading plus the per-stride pelvis rotation of walking
  (transverse-plane pelvic rotation: the pelvis swings back and forth once per stride, so
  the hip vector sways although the path is straight), plus a slow postural wander;
- a thorax that counter-rotates against the pelvis (as in gait), vertical bob twice per
  stride, lateral pelvic shift once per stride, legs and arms swinging in the sagittal plane
  in opposite phase, with bone lengths close to Human3.6M's subject S1 (hip half-width
  132 mm, thigh 442 mm, shank 454 mm, shoulder half-width 180 mm, upper arm 278 mm);
- independent Gaussian noise on every coordinate of every joint, and dropouts (whole frames
  set to NaN).

The output is the Human3.6M 32-joint layout (:data:`turn_datasets.skeleton.H36M32`), z up,
millimetres, 50 Hz by default, in the world frame of DESIGN.md: positive yaw is
counter-clockwise seen from above, so a positive (left) turn increases the yaw of the
left-minus-right hip vector.

The planted truth is computed by this module from its own noise-free pelvis yaw, never by
the miner: each turn's ``heading_deg`` is the heading change asked for, what the clip
index's ``angle_deg`` measures (DESIGN.md); its ``angle_deg`` is the signed rotation
of the noise-free hip vector from the turn's first frame to its last (``end_frame - 1``),
what the index's ``hip_rotation_deg`` measures. The two differ by the pelvic sway at the
two ends and the postural wander, a few degrees at most.

Everything is drawn from one :class:`numpy.random.Generator` seeded by ``seed``: the same
seed and segments give the same array, bit for bit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.ndimage import uniform_filter1d

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.skeleton import H36M32, MocapSequence
from turn_datasets.synthetic import footsteps

__all__ = [
    "SEGMENT_KINDS",
    "TURN_KINDS",
    "Segment",
    "Dropout",
    "SyntheticSequence",
    "generate_sequence",
    "random_segments",
    "random_dropouts",
    "stride_frequency_hz",
]

#: Kinds of :class:`Segment`.
SEGMENT_KINDS = ("stand", "walk", "pivot_turn", "walking_turn")
#: The kinds that plant a turn.
TURN_KINDS = ("pivot_turn", "walking_turn")

PLANTED_DTYPES = {
    "start_frame": "int64",
    "end_frame": "int64",
    "angle_deg": "float64",
    "kind": "str",
    "heading_deg": "float64",
    "duration_s": "float64",
}
#: The planted table's columns with ``footsteps=True``, after :data:`PLANTED_DTYPES`.
FOOTSTEP_DTYPES = {"steps": "int64", "turn_type": "str"}
SEGMENT_DTYPES = {
    "start_frame": "int64",
    "end_frame": "int64",
    "kind": "str",
    "heading_deg": "float64",
    "speed_m_s": "float64",
}
DROPOUT_DTYPES = {"start_frame": "int64", "end_frame": "int64"}

# Bone lengths and offsets in millimetres, close to Human3.6M subject S1.
PELVIS_HEIGHT_MM = 965.0
HIP_HALF_WIDTH_MM = 132.0
THIGH_MM = 442.0
SHANK_MM = 454.0
FOOT_MM = 140.0
TOE_MM = 60.0
PELVIS_TO_SPINE_MM = 233.0
SPINE_TO_THORAX_MM = 257.0
THORAX_TO_NECK_MM = 121.0
NECK_TO_HEAD_MM = 115.0
SHOULDER_HALF_WIDTH_MM = 180.0
UPPER_ARM_MM = 278.0
FOREARM_MM = 252.0
HAND_MM = 80.0

# Gait kinematics (degrees, millimetres), typical adult values at comfortable speed.
HIP_FLEXION_DEG = 22.0
KNEE_FLEXION_DEG = 55.0
SHOULDER_SWING_DEG = 18.0
ELBOW_FLEXION_DEG = 20.0
VERTICAL_BOB_MM = 18.0
LATERAL_SHIFT_MM = 20.0
#: The thorax counter-rotates against the pelvis by this fraction of the pelvic sway.
THORAX_COUNTER_ROTATION = 0.6
#: Stepping on the spot during a pivot turn: this fraction of the walking leg swing.
PIVOT_STEP_AMPLITUDE = 0.45
PIVOT_STEP_FREQUENCY_HZ = 0.8
#: Speed, gait amplitude and sway change over this time at a segment boundary.
TRANSITION_S = 0.4
POSTURAL_WANDER_DEG = 0.5
#: Default peak-to-peak transverse pelvic rotation per stride, degrees (±4°). Measured on the
#: real CMU walks in ``../shared/data/cmu-mocap`` (root joint's yaw about its stride mean,
#: half the peak to peak per stride): ±3.4° and ±4.1° (69_01), ±6.3° (16_21); Saunders,
#: Inman & Eberhart (1953) and Perry & Burnfield (2010) give ±4° to ±8°.
SWAY_DEG = 8.0


@dataclass(frozen=True)
class Segment:
    """One stretch of a synthetic sequence.

    Parameters
    ----------
    kind
        ``stand``, ``walk`` (straight), ``pivot_turn`` (turning on the spot) or
        ``walking_turn`` (turning while walking on, along a curved path).
    duration_s
        Length in seconds (rounded to whole frames, at least two).
    heading_deg
        Signed heading change of a turn (positive = left = counter-clockwise from above);
        zero for ``stand`` and ``walk``.
    speed_m_s
        Walking speed for ``walk`` and ``walking_turn``; zero for the others.
    steps
        The steps of a turn when the sequence plants footsteps
        (:mod:`turn_datasets.synthetic.footsteps`): 0 takes
        :func:`~turn_datasets.synthetic.footsteps.default_steps`.
    ramp_s
        A turn's yaw rate by default rises and falls as one sine over the whole segment;
        given, it rises over ``ramp_s`` seconds, stays level, and falls over the last
        ``ramp_s`` (walking round a loop at one speed).
    """

    kind: str
    duration_s: float
    heading_deg: float = 0.0
    speed_m_s: float = 0.0
    steps: int = 0
    ramp_s: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in SEGMENT_KINDS:
            raise TurnbenchError(
                f"unknown segment kind {self.kind!r}; choose one of {SEGMENT_KINDS}"
            )
        if not self.duration_s > 0:
            raise TurnbenchError(f"segment duration must be positive, got {self.duration_s}")
        if self.kind in TURN_KINDS and self.heading_deg == 0:
            raise TurnbenchError("a turn segment needs a non-zero heading_deg")
        if self.kind not in TURN_KINDS and self.heading_deg != 0:
            raise TurnbenchError(f"a {self.kind} segment cannot change the heading")
        if self.kind in ("walk", "walking_turn") and not self.speed_m_s > 0:
            raise TurnbenchError(f"a {self.kind} segment needs a positive speed_m_s")
        if self.kind in ("stand", "pivot_turn") and self.speed_m_s != 0:
            raise TurnbenchError(f"a {self.kind} segment does not move: speed_m_s must be 0")
        if self.steps < 0 or (self.steps and self.kind not in TURN_KINDS):
            raise TurnbenchError(
                f"only a turn takes steps (>= 0), got {self.steps} for a {self.kind}"
            )

    @classmethod
    def stand(cls, duration_s: float) -> Segment:
        return cls("stand", duration_s)

    @classmethod
    def walk(cls, duration_s: float, speed_m_s: float = 1.25) -> Segment:
        return cls("walk", duration_s, speed_m_s=speed_m_s)

    @classmethod
    def pivot_turn(cls, heading_deg: float, duration_s: float, steps: int = 0) -> Segment:
        return cls("pivot_turn", duration_s, heading_deg=heading_deg, steps=steps)

    @classmethod
    def walking_turn(
        cls, heading_deg: float, duration_s: float, speed_m_s: float = 1.1, steps: int = 0
    ) -> Segment:
        return cls(
            "walking_turn", duration_s, heading_deg=heading_deg, speed_m_s=speed_m_s, steps=steps
        )

    @property
    def ramp_fraction(self) -> float:
        """The ramp as a fraction of the segment (0.5: the whole-segment sine)."""
        if self.ramp_s is None:
            return 0.5
        return float(min(max(self.ramp_s / self.duration_s, 1e-3), 0.5))

    @property
    def is_turn(self) -> bool:
        return self.kind in TURN_KINDS


@dataclass(frozen=True)
class Dropout:
    """Frames lost by the capture (set to NaN): ``duration_s`` from ``start_s``."""

    start_s: float
    duration_s: float


@dataclass
class SyntheticSequence:
    """A generated sequence and its truth.

    Attributes
    ----------
    positions
        ``(n_frames, 32, 3)`` float64, millimetres, z up, Human3.6M 32-joint layout; dropout
        frames are NaN.
    fps
        Frames per second.
    planted
        One row per planted turn: ``start_frame``, ``end_frame`` (exclusive), ``angle_deg``
        (signed noise-free hip rotation from ``start_frame`` to ``end_frame - 1``; positive
        = left: the truth of ``hip_rotation_deg``), ``kind`` (``pivot_turn`` or
        ``walking_turn``), ``heading_deg`` (the heading change asked for: the truth of the
        clip index's ``angle_deg``), ``duration_s``.
    segments
        Every segment with its frames: ``start_frame``, ``end_frame``, ``kind``,
        ``heading_deg``, ``speed_m_s``.
    dropouts
        The NaN frame runs: ``start_frame``, ``end_frame``.
    true_yaw_deg
        The noise-free yaw of the left-minus-right hip vector per frame (heading + 90° +
        pelvic sway + wander), unwrapped.
    """

    positions: np.ndarray
    fps: float
    planted: pd.DataFrame
    segments: pd.DataFrame
    dropouts: pd.DataFrame
    true_yaw_deg: np.ndarray = field(repr=False)

    @property
    def n_frames(self) -> int:
        return int(self.positions.shape[0])

    def to_mocap(
        self, *, subject: str, action: str, subaction: str = "", source: str = ""
    ) -> MocapSequence:
        """This sequence as a reader would return it."""
        return MocapSequence(
            subject=subject,
            action=action,
            subaction=subaction,
            positions=self.positions,
            layout=H36M32,
            fps=self.fps,
            units="mm",
            source=source,
        )


def stride_frequency_hz(speed_m_s: np.ndarray | float) -> np.ndarray | float:
    """Strides per second at a walking speed: step length grows with speed (0.65 m at 1 m/s,
    0.75 m at 1.5 m/s), a stride is two steps; 0.77 Hz at 1 m/s, 1.0 Hz at 1.5 m/s."""
    v = np.asarray(speed_m_s, dtype=float)
    step_m = 0.45 + 0.2 * v
    out = v / (2.0 * step_m)
    return float(out) if out.ndim == 0 else out


def _turn_profile(u: np.ndarray, ramp: np.ndarray | float = 0.5) -> np.ndarray:
    """Fraction of a turn done at normalised time ``u`` in [0, 1].

    ``ramp`` 0.5 (the default): a sinusoidal yaw rate, zero at both ends, peak in the
    middle. Less (a fraction of the segment, per frame): the rate rises over ``ramp`` as a
    raised cosine, stays level, and falls over the last ``ramp``, as walking round a loop
    keeps one speed for most of it.
    """
    u = np.asarray(u, dtype=float)
    sine = 0.5 * (1.0 - np.cos(np.pi * u))
    r = np.broadcast_to(np.asarray(ramp, dtype=float), u.shape)
    if (r >= 0.5).all():
        return sine
    r = np.clip(r, 1e-9, 0.5)

    def rising(t: np.ndarray) -> np.ndarray:  # the integral of the raised-cosine ramp
        return 0.5 * t - r / (2 * np.pi) * np.sin(np.pi * t / r)

    done = np.where(
        u < r,
        rising(np.minimum(u, r)),
        np.where(u <= 1 - r, 0.5 * r + (u - r), (1 - r) - rising(np.minimum(1 - u, r))),
    )
    return np.where(r >= 0.5, sine, done / (1 - r))


def _heading_changes(
    segments: Sequence[Segment], change: np.ndarray, seg_of: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """The heading per frame less the start's: the turns' heading changes, each completed
    exactly on its segment's last frame (``u``: each frame's place in its segment, 0 to 1)."""
    before = np.concatenate([[0.0], np.cumsum(change)[:-1]])
    ramp = np.array([s.ramp_fraction for s in segments])[seg_of]
    return before[seg_of] + change[seg_of] * _turn_profile(u, ramp)


def _smooth(x: np.ndarray, n: int) -> np.ndarray:
    return uniform_filter1d(x, size=max(int(n), 1), mode="nearest") if n > 1 else x


def _segment_frames(segments: Sequence[Segment], fps_hz: float) -> np.ndarray:
    n = np.array([max(2, int(round(s.duration_s * fps_hz))) for s in segments], dtype=np.int64)
    return n


def generate_sequence(
    *,
    seed: int,
    segments: Sequence[Segment],
    fps_hz: float = 50.0,
    noise_mm: float = 10.0,
    sway_deg: float = SWAY_DEG,
    dropouts: Sequence[Dropout] = (),
    wander_deg: float = POSTURAL_WANDER_DEG,
    start_heading_deg: float | None = None,
    footsteps: bool = False,
) -> SyntheticSequence:
    """Build a Human3.6M-like 32-joint sequence from segments, with its planted turns.

    Parameters
    ----------
    seed
        Seeds the :class:`numpy.random.Generator` that draws the start position and heading,
        the gait phase, the postural wander and the joint noise.
    segments
        The sequence, in order (see :class:`Segment`).
    fps_hz
        Frame rate (Human3.6M: 50).
    noise_mm
        Standard deviation of the independent Gaussian noise on every coordinate of every
        joint, in millimetres (0 for a clean skeleton).
    sway_deg
        Peak-to-peak transverse pelvic rotation per stride while walking, in degrees: the
        pelvis (and with it the hip vector) swings from ``-sway_deg/2`` to ``+sway_deg/2``
        about the heading once per stride, phase-locked to the legs (and, scaled by
        ``PIVOT_STEP_AMPLITUDE``, to the steps of a turn in place); the thorax and shoulders
        counter-rotate. Healthy adults show about ±4° to ±8° (8° to 16° here); the default
        8° is the middle of what CMU's real walks show (:data:`SWAY_DEG`).
    dropouts
        Frame runs to set to NaN (all joints), as capture dropouts.
    wander_deg
        Standard deviation of the slow postural yaw wander of the whole body (low-passed
        over one second), in degrees; 0 for none.
    start_heading_deg
        The walking direction at the first frame (degrees from +x); drawn when None.
    footsteps
        Plant the feet (:mod:`turn_datasets.synthetic.footsteps`), each turn its ``steps``;
        the planted table then has ``steps`` and ``turn_type`` (pivot below three, else step). Off, the legs swing from the pelvis as before and the same seed gives the
        same array as before.

    Returns
    -------
    SyntheticSequence
    """
    _check_generator_args(
        segments, fps_hz, noise_mm=noise_mm, sway_deg=sway_deg, wander_deg=wander_deg
    )
    rng = np.random.default_rng(seed)
    seg_frames = _segment_frames(segments, fps_hz)
    bounds = np.concatenate([[0], np.cumsum(seg_frames)])
    n_frames = int(bounds[-1])
    seg_of = np.repeat(np.arange(len(segments)), seg_frames)
    local = np.arange(n_frames) - bounds[:-1][seg_of]

    kinds = np.array([s.kind for s in segments])
    heading_change = np.radians([s.heading_deg for s in segments])
    speed = np.array([s.speed_m_s for s in segments])
    is_turn = np.isin(kinds, TURN_KINDS)

    heading0 = np.radians(
        rng.uniform(-180, 180) if start_heading_deg is None else start_heading_deg
    )
    heading = heading0 + _heading_changes(
        segments, heading_change, seg_of, local / (seg_frames[seg_of] - 1)
    )

    speed_f, gait_amp, phase = _gait(rng, kinds, speed, seg_of, fps_hz)
    # the pelvis rotates with every step, walking or stepping round in a turn in place
    sway_amp = gait_amp

    # Postural wander: slow, small yaw drift of the whole body (low-passed Gaussian noise).
    wander_n = max(int(round(1.0 * fps_hz)), 1)
    wander = _smooth(rng.normal(size=n_frames), wander_n)
    wander *= np.radians(wander_deg) / max(float(np.std(wander)), 1e-12)

    sway = 0.5 * np.radians(sway_deg) * sway_amp * np.sin(phase)
    pelvis_yaw = heading + sway + wander  # facing direction of the pelvis
    thorax_yaw = heading - THORAX_COUNTER_ROTATION * sway + wander

    # Ground path: integrate the speed along the heading (metres per second -> mm per frame).
    start_xy = rng.uniform(-1000.0, 1000.0, size=2)
    step = speed_f * 1000.0 / fps_hz
    x = start_xy[0] + np.concatenate([[0.0], np.cumsum(step * np.cos(heading))[:-1]])
    y = start_xy[1] + np.concatenate([[0.0], np.cumsum(step * np.sin(heading))[:-1]])

    positions = _build_body(
        x=x,
        y=y,
        pelvis_yaw=pelvis_yaw,
        thorax_yaw=thorax_yaw,
        phase=phase,
        gait_amp=gait_amp,
    )
    swings = (
        _footsteps(segments, bounds, positions, heading, pelvis_yaw, fps_hz) if footsteps else None
    )
    if noise_mm > 0:
        positions += rng.normal(scale=noise_mm, size=positions.shape)

    dropout_rows = _drop_frames(positions, dropouts, fps_hz)
    true_yaw_deg = np.degrees(pelvis_yaw) + 90.0  # left-minus-right is 90° left of the facing
    planted, seg_rows, drops = _sequence_tables(
        segments, bounds, is_turn, true_yaw_deg, dropout_rows, fps_hz
    )
    if swings is not None:
        planted = _with_steps(planted, segments, swings)
    return SyntheticSequence(
        positions=positions,
        fps=float(fps_hz),
        planted=planted,
        segments=seg_rows,
        dropouts=drops,
        true_yaw_deg=true_yaw_deg,
    )


def _footsteps(
    segments: Sequence[Segment],
    bounds: np.ndarray,
    positions: np.ndarray,
    heading: np.ndarray,
    pelvis_yaw: np.ndarray,
    fps_hz: float,
) -> list[footsteps.Swing]:
    """Rebuild the legs from planted feet (:mod:`turn_datasets.synthetic.footsteps`)."""
    steps = [
        (s.steps or footsteps.default_steps(s.kind, s.heading_deg)) if s.is_turn else 0
        for s in segments
    ]
    stride = [float(stride_frequency_hz(max(s.speed_m_s, 1e-9))) for s in segments]
    swings = footsteps.schedule_swings(
        [s.kind for s in segments],
        bounds,
        steps,
        [s.speed_m_s for s in segments],
        stride,
        positions[:, [1, 6], :2],
        heading,
        fps_hz,
    )
    footsteps.plant_feet(
        positions,
        swings,
        pelvis_yaw,
        thigh_mm=THIGH_MM,
        shank_mm=SHANK_MM,
        foot_mm=FOOT_MM,
        toe_mm=TOE_MM,
    )
    return swings


def _with_steps(
    planted: pd.DataFrame, segments: Sequence[Segment], swings: Sequence[footsteps.Swing]
) -> pd.DataFrame:
    """The planted turns with their landings (``steps``) and REMAP's ``turn_type`` (by the
    steps asked for: :func:`~turn_datasets.synthetic.footsteps.turn_type_of`)."""
    out = planted.copy()
    start = out["start_frame"].to_numpy()
    end = out["end_frame"].to_numpy()
    out["steps"] = footsteps.turn_steps(swings, start, end).astype(np.int64)
    kinds = [
        s.steps or footsteps.default_steps(s.kind, s.heading_deg) for s in segments if s.is_turn
    ]
    out["turn_type"] = [footsteps.turn_type_of(k) for k in kinds]
    return typed_frame(out, {**PLANTED_DTYPES, **FOOTSTEP_DTYPES})


def _gait(
    rng: np.random.Generator,
    kinds: np.ndarray,
    speed: np.ndarray,
    seg_of: np.ndarray,
    fps_hz: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per frame: the walking speed, the step amplitude and the stride phase (radians)."""
    walking = np.isin(kinds, ("walk", "walking_turn"))
    # Speed, gait amplitude and sway ease in and out at segment boundaries.
    ramp = int(round(TRANSITION_S * fps_hz))
    speed_f = _smooth(speed[seg_of], ramp)
    gait_amp = _smooth(
        np.where(walking, 1.0, np.where(kinds == "pivot_turn", PIVOT_STEP_AMPLITUDE, 0.0))[seg_of],
        ramp,
    )
    stride_hz = np.where(
        walking,
        stride_frequency_hz(np.maximum(speed, 1e-9)),
        np.where(kinds == "pivot_turn", PIVOT_STEP_FREQUENCY_HZ, 0.0),
    )[seg_of]
    stride_hz = _smooth(stride_hz, ramp)
    phase = rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.cumsum(stride_hz) / fps_hz
    return speed_f, gait_amp, phase


def _check_generator_args(
    segments: Sequence[Segment], fps_hz: float, **non_negative: float
) -> None:
    if not segments:
        raise TurnbenchError("a synthetic sequence needs at least one segment")
    if not (np.isfinite(fps_hz) and fps_hz > 0):
        raise TurnbenchError(f"fps must be positive, got {fps_hz}")
    for name, value in non_negative.items():
        if not (np.isfinite(value) and value >= 0):
            raise TurnbenchError(f"{name} must be a finite non-negative number, got {value}")


def _drop_frames(
    positions: np.ndarray, dropouts: Sequence[Dropout], fps_hz: float
) -> list[tuple[int, int]]:
    """Set the dropouts' frames to NaN (all joints); their (start, end) frames."""
    rows = []
    for d in dropouts:
        a = max(int(round(d.start_s * fps_hz)), 0)
        b = min(a + max(int(round(d.duration_s * fps_hz)), 1), positions.shape[0])
        if a < b:
            positions[a:b] = np.nan
            rows.append((a, b))
    return rows


def _sequence_tables(
    segments: Sequence[Segment],
    bounds: np.ndarray,
    is_turn: np.ndarray,
    true_yaw_deg: np.ndarray,
    dropout_rows: list[tuple[int, int]],
    fps_hz: float,
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The planted turns, the segments and the dropouts as typed tables."""
    seg_rows = pd.DataFrame(
        {
            "start_frame": bounds[:-1],
            "end_frame": bounds[1:],
            "kind": np.array([sg.kind for sg in segments]),
            "heading_deg": np.array([sg.heading_deg for sg in segments], dtype=float),
            "speed_m_s": np.array([sg.speed_m_s for sg in segments]),
        }
    )
    turns = seg_rows[is_turn]
    a = turns["start_frame"].to_numpy()
    b = turns["end_frame"].to_numpy()
    planted = pd.DataFrame(
        {
            "start_frame": a,
            "end_frame": b,
            "angle_deg": true_yaw_deg[b - 1] - true_yaw_deg[a],
            "kind": turns["kind"].to_numpy(),
            "heading_deg": turns["heading_deg"].to_numpy(),
            "duration_s": (b - a) / fps_hz,
        }
    )
    drops = pd.DataFrame(
        dropout_rows or np.zeros((0, 2), dtype=np.int64), columns=["start_frame", "end_frame"]
    )
    return (
        typed_frame(planted, PLANTED_DTYPES),
        typed_frame(seg_rows, SEGMENT_DTYPES),
        typed_frame(drops, DROPOUT_DTYPES),
    )


def _build_body(
    *,
    x: np.ndarray,
    y: np.ndarray,
    pelvis_yaw: np.ndarray,
    thorax_yaw: np.ndarray,
    phase: np.ndarray,
    gait_amp: np.ndarray,
) -> np.ndarray:
    """All 32 joints from the pelvis frame, the thorax frame and the gait phase, vectorised."""
    n = x.shape[0]
    zeros = np.zeros(n)
    up = np.array([0.0, 0.0, 1.0])
    fwd = np.stack([np.cos(pelvis_yaw), np.sin(pelvis_yaw), zeros], axis=1)
    left = np.stack([-np.sin(pelvis_yaw), np.cos(pelvis_yaw), zeros], axis=1)
    fwd_t = np.stack([np.cos(thorax_yaw), np.sin(thorax_yaw), zeros], axis=1)
    left_t = np.stack([-np.sin(thorax_yaw), np.cos(thorax_yaw), zeros], axis=1)

    def col(v: np.ndarray | float) -> np.ndarray:
        return np.broadcast_to(np.asarray(v, dtype=float), (n,))[:, None]

    pelvis_z = PELVIS_HEIGHT_MM + VERTICAL_BOB_MM * gait_amp * np.cos(2 * phase)
    pelvis = (
        np.stack([x, y, pelvis_z], axis=1) + col(LATERAL_SHIFT_MM * gait_amp * np.cos(phase)) * left
    )

    p = np.empty((n, 32, 3))

    def leg(hip: np.ndarray, side_phase: np.ndarray) -> tuple[np.ndarray, ...]:
        hip_flex = np.radians(HIP_FLEXION_DEG) * gait_amp * np.sin(side_phase)
        # The knee flexes most in swing, while the hip flexes (cos of the phase positive).
        knee_flex = np.radians(
            5.0 + KNEE_FLEXION_DEG * gait_amp * np.maximum(np.cos(side_phase), 0.0) ** 2
        )
        shank = hip_flex - knee_flex
        knee = hip + col(THIGH_MM * np.sin(hip_flex)) * fwd - col(THIGH_MM * np.cos(hip_flex)) * up
        ankle = knee + col(SHANK_MM * np.sin(shank)) * fwd - col(SHANK_MM * np.cos(shank)) * up
        toe = ankle + FOOT_MM * fwd - 50.0 * up
        toe_end = toe + TOE_MM * fwd
        return knee, ankle, toe, toe_end

    def arm(shoulder: np.ndarray, side_phase: np.ndarray) -> tuple[np.ndarray, ...]:
        # Arms swing against the leg of the same side.
        swing = -np.radians(SHOULDER_SWING_DEG) * gait_amp * np.sin(side_phase)
        fore = swing + np.radians(ELBOW_FLEXION_DEG) * (
            1.0 + gait_amp * np.maximum(-np.sin(side_phase), 0.0)
        )
        elbow = (
            shoulder
            + col(UPPER_ARM_MM * np.sin(swing)) * fwd_t
            - col(UPPER_ARM_MM * np.cos(swing)) * up
        )
        fore_dir = col(np.sin(fore)) * fwd_t - col(np.cos(fore)) * up
        wrist = elbow + FOREARM_MM * fore_dir
        hand = wrist + HAND_MM * fore_dir
        thumb = wrist + 0.5 * HAND_MM * fore_dir + 30.0 * fwd_t
        return elbow, wrist, hand, thumb

    right_hip = pelvis - HIP_HALF_WIDTH_MM * left
    left_hip = pelvis + HIP_HALF_WIDTH_MM * left
    p[:, 0] = pelvis
    p[:, 1] = right_hip
    p[:, 2:6] = np.stack(leg(right_hip, phase + np.pi), axis=1)
    p[:, 6] = left_hip
    p[:, 7:11] = np.stack(leg(left_hip, phase), axis=1)
    p[:, 11] = pelvis  # Human3.6M repeats the pelvis here
    spine = pelvis + PELVIS_TO_SPINE_MM * up + 15.0 * fwd
    thorax = spine + SPINE_TO_THORAX_MM * up + 15.0 * fwd_t
    p[:, 12] = spine
    p[:, 13] = thorax
    p[:, 14] = thorax + THORAX_TO_NECK_MM * up + 25.0 * fwd_t
    p[:, 15] = p[:, 14] + NECK_TO_HEAD_MM * up + 10.0 * fwd_t
    p[:, 16] = thorax  # Human3.6M repeats the thorax at the root of each arm
    p[:, 24] = thorax
    left_shoulder = thorax + SHOULDER_HALF_WIDTH_MM * left_t - 20.0 * up
    right_shoulder = thorax - SHOULDER_HALF_WIDTH_MM * left_t - 20.0 * up
    l_elbow, l_wrist, l_hand, l_thumb = arm(left_shoulder, phase + np.pi)
    r_elbow, r_wrist, r_hand, r_thumb = arm(right_shoulder, phase)
    p[:, 17] = left_shoulder
    p[:, 18] = l_elbow
    p[:, 19] = l_wrist
    p[:, 20] = l_wrist
    p[:, 21] = l_thumb
    p[:, 22] = l_wrist
    p[:, 23] = l_hand
    p[:, 25] = right_shoulder
    p[:, 26] = r_elbow
    p[:, 27] = r_wrist
    p[:, 28] = r_wrist
    p[:, 29] = r_thumb
    p[:, 30] = r_wrist
    p[:, 31] = r_hand
    return p


def random_segments(
    rng: np.random.Generator,
    *,
    n_turns: int = 8,
    min_turn_deg: float = 50.0,
    max_turn_deg: float = 360.0,
    speed_range_m_s: tuple[float, float] = (1.0, 1.5),
    back_to_back_fraction: float = 0.25,
    stand_fraction: float = 0.2,
    turn_speed_range_deg_s: tuple[float, float] | None = None,
) -> list[Segment]:
    """Draw a realistic mix of walking, standing and planted turns.

    The sequence opens by standing, then alternates straight walking (1.5 to 4 s) with
    turns. Each turn is a pivot turn or a walking turn (even odds), left or right (even
    odds), slow (40 to 90 °/s mean) or fast (120 to 240 °/s mean, even odds), of a heading
    change drawn uniformly from ``min_turn_deg`` to ``max_turn_deg``, lasting at least
    0.6 s. With probability ``back_to_back_fraction`` a turn is followed 0.5 s later by a
    turn the other way (a pause standing for pivots, walking for walking turns); with
    probability ``stand_fraction`` the walking after a turn is replaced by standing.

    Parameters
    ----------
    rng
        The generator that draws everything.
    n_turns
        How many turns to plant.
    min_turn_deg, max_turn_deg
        Range of the planted heading changes (magnitude).
    speed_range_m_s
        Range of walking speeds.
    back_to_back_fraction, stand_fraction
        Probabilities, see above.
    turn_speed_range_deg_s
        If given, every turn's mean speed (heading change over duration, °/s) is drawn
        uniformly from this range instead of the slow/fast mix.
    """
    lo, hi = speed_range_m_s
    segs: list[Segment] = [Segment.stand(float(rng.uniform(0.8, 1.5)))]

    def draw_turn(sign: float | None = None) -> Segment:
        mag = float(rng.uniform(min_turn_deg, max_turn_deg))
        s = sign if sign is not None else (1.0 if rng.random() < 0.5 else -1.0)
        fast = rng.random() < 0.5
        mean_speed = float(rng.uniform(120.0, 240.0) if fast else rng.uniform(40.0, 90.0))
        if turn_speed_range_deg_s is not None:
            mean_speed = float(rng.uniform(*turn_speed_range_deg_s))
        duration = max(mag / mean_speed, 0.6)
        if rng.random() < 0.5:
            return Segment.pivot_turn(s * mag, duration)
        return Segment.walking_turn(s * mag, duration, speed_m_s=float(rng.uniform(lo, hi)))

    turns_left = n_turns
    while turns_left > 0:
        segs.append(Segment.walk(float(rng.uniform(1.5, 4.0)), float(rng.uniform(lo, hi))))
        turn = draw_turn()
        segs.append(turn)
        turns_left -= 1
        if turns_left > 0 and rng.random() < back_to_back_fraction:
            gap: Segment = (
                Segment.stand(0.5)
                if turn.kind == "pivot_turn"
                else Segment.walk(0.5, turn.speed_m_s)
            )
            segs.append(gap)
            second = draw_turn(-1.0 if turn.heading_deg > 0 else 1.0)
            if turn.kind == "walking_turn" and second.kind == "pivot_turn":
                second = Segment.walking_turn(second.heading_deg, second.duration_s, turn.speed_m_s)
            elif turn.kind == "pivot_turn" and second.kind == "walking_turn":
                second = Segment.pivot_turn(second.heading_deg, second.duration_s)
            segs.append(second)
            turns_left -= 1
        if rng.random() < stand_fraction:
            segs.append(Segment.stand(float(rng.uniform(1.0, 3.0))))
    segs.append(Segment.walk(float(rng.uniform(1.5, 3.0)), float(rng.uniform(lo, hi))))
    segs.append(Segment.stand(float(rng.uniform(0.8, 1.5))))
    return segs


def random_dropouts(
    rng: np.random.Generator,
    segments: Sequence[Segment],
    *,
    fps_hz: float = 50.0,
    n_short: int = 3,
    short_range_s: tuple[float, float] = (0.02, 0.2),
    n_long: int = 1,
    long_range_s: tuple[float, float] = (0.5, 1.5),
    margin_s: float = 0.5,
) -> list[Dropout]:
    """Draw capture dropouts: short ones anywhere, long ones only inside straight segments.

    A long dropout (longer than any sensible bridging) cuts the sequence in two; placing it
    inside a ``walk`` or ``stand`` segment, ``margin_s`` from its ends, keeps every planted
    turn whole so it stays findable. Short dropouts fall anywhere, turns included.
    """
    seg_frames = _segment_frames(segments, fps_hz)
    bounds = np.concatenate([[0], np.cumsum(seg_frames)]) / fps_hz
    total_s = float(bounds[-1])
    out: list[Dropout] = []
    for _ in range(n_short):
        d = float(rng.uniform(*short_range_s))
        out.append(Dropout(float(rng.uniform(0.0, max(total_s - d, 0.0))), d))
    straight = [
        i
        for i, s in enumerate(segments)
        if not s.is_turn and bounds[i + 1] - bounds[i] >= long_range_s[0] + 2 * margin_s
    ]
    for _ in range(n_long):
        if not straight:
            break
        i = straight[int(rng.integers(len(straight)))]
        room = bounds[i + 1] - bounds[i] - 2 * margin_s
        d = float(rng.uniform(long_range_s[0], min(long_range_s[1], room)))
        out.append(Dropout(float(bounds[i] + margin_s + rng.uniform(0.0, room - d)), d))
    return out
