"""Untrimmed sessions: long estimator-like skeleton streams from planted timelines, with labels.

A home recording of a person with Parkinson's disease is hours of video; a pose estimator
turns it into one skeleton stream per person. This module writes look-alikes of such
streams, with every turn, every decoy and every estimator artefact planted at a known time,
so that ``turn-eval detect`` and ``turn-eval score-events`` can be tested and demonstrated.

The timeline
------------
A participant's timeline is a list of labelled turns (``start_s``, ``end_s``, the labelled
45° bin) with everything between them filled by walking, standing and *decoys*
(:func:`timeline_segments`). The labelled turns are either drawn (:func:`draw_turn_labels`)
or taken from a ``remap labels`` table (the demo plants the turns of its ELAN sessions).

Turns (what the labels hold)
    Labelled 90°, 135°, 180° or 225° (Turn-REMAP's smallest bins, shares
    :data:`LABEL_BIN_MIX`, the shape of the paper's Table 2); the planted heading change is
    the label plus a normal error of :data:`LABEL_ROUNDING_SD_DEG` (clipped to ±20°): what a
    clinician's 45° vocabulary rounds away, so even a perfect detector has an MAE near 7°.
    Mean turning speeds (:data:`TURN_SPEED_DEG_S`): people with PD turn en bloc, on the
    spot, in many small steps, at 30-70 °/s (the issue's figure; 90° then takes 1.3-3 s);
    controls at 50-110 °/s, mostly while walking on. The paper's Table 3 gives 1.1 s to
    3.2 s for its 45° to 225° bins (40-70 °/s) for healthy actors, inside the controls'
    range. The yaw rate is sinusoidal (:mod:`turn_datasets.synthetic.mocap`), peaking at
    pi/2 times the mean. The label's interval is the turn's first to last frame.
Movements (``planted.csv``'s ``movement``)
    Real movement at home is not a corner between straight walks (Human3.6M's walks, CMU's
    trials): ``pivot`` and ``walking`` turns as above; ``curved`` (:data:`CURVED_SHARE`): a
    turn made gradually along a curved path of constant curvature, 25-45 °/s (CMU 69_32:
    about 96° over 2.3 s); ``quick`` (:data:`QUICK_SUCCESSION_SHARE`): a turn 0.3-0.9 s
    after the one before, either way (CMU 69_19's four turns with pauses of 0.1-0.3 s);
    ``to_sit`` (:data:`TURN_TO_SIT_SHARE`): a pivot that ends by sitting down.
Decoys (never labelled)
    ``small_turn`` (a direction change of 15-40° while walking), ``circling`` (walking
    round a loop at 30-45 °/s for 12-25 s, as Human3.6M's walking actions do: continuous
    turning that is no one turn), ``sway`` (standing and
    rocking the body 8-18° each way, 3 to 6 times), ``reach`` (turning 25-40° to reach for
    something, a pause, turning back), ``sit_stand`` (sitting down for 5-25 s, then standing
    up: the pelvis drops 45 cm, the thighs go horizontal) and plain ``stand`` (2-8 s).
Artefacts of the estimator
    ``absence`` (the person leaves the view for 5-20 s and comes back facing another way:
    a turn no one saw, so NaN frames and no label), ``bystander`` (an identity break: for
    2-6 s the tracker follows another person, 12-25% larger or smaller, 1.5-3 m away, who
    sometimes turns; no confidence drop, no NaN), then on the whole stream: the depth error
    along the camera ray that grows with the back to the camera, joint jitter and short
    occlusion dropouts of :func:`turn_datasets.synthetic.degrade.degrade_skeleton` (per
    scenario, free-living worse, as in the demo corpus), a white depth error along each
    joint's ray (30 mm facing the camera, 60 mm with the back to it: a lifter's MPJPE is
    40-60 mm on Human3.6M, much of it along the ray and independent per joint and frame),
    and ``swap`` s: for 2-8 frames the
    left and right joints are exchanged, starting :data:`ArtefactParams.swaps_per_min` times
    a minute, most often with the back to the camera (probability proportional to the angle
    to the camera).

Output: per session one ``.npz`` (stem = session, one array per subject), 17 joints
(Human3.6M order), in the axes of a level camera at the room's edge (x right, y down, z
forward, ``--up-axis -y``; :func:`camera_frame_m`), metres,
float32, optionally root-relative (pelvis at the origin, as lifting networks write); the
labels in the ``remap labels`` format (:data:`turn_datasets.remap.labels.LABEL_COLUMNS`),
``context.csv`` (scenario and location intervals), ``sessions.csv`` (annotated duration per
participant) and ``planted.csv`` (every event and artefact with its frames, for tests).
Everything is drawn from ``numpy.random.default_rng`` seeded from ``seed`` and the names: the
same seed gives the same bytes.
"""

from __future__ import annotations

import math
import os
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame, write_csv, write_npz
from turn_datasets.remap.context import CONTEXT_COLUMNS, SESSIONS_COLUMNS, SESSIONS_OPTIONAL
from turn_datasets.remap.labels import LABEL_COLUMNS, clip_id_for
from turn_datasets.skeleton import H36M17, H36M17_FROM_32
from turn_datasets.synthetic.degrade import degrade_skeleton
from turn_datasets.synthetic.mocap import THIGH_MM, Segment, generate_sequence

__all__ = [
    "LABEL_BIN_MIX",
    "TURN_SPEED_DEG_S",
    "LABEL_ROUNDING_SD_DEG",
    "DECOY_KINDS",
    "EVENT_DTYPES",
    "ArtefactParams",
    "MovementMix",
    "REAL_MOVEMENT",
    "PLAIN_MOVEMENT",
    "UntrimmedStream",
    "draw_turn_labels",
    "draw_steps",
    "session_start_time",
    "STEP_LABEL_COLUMNS",
    "timeline_segments",
    "synthesize_stream",
    "write_untrimmed_corpus",
    "write_streams_for_labels",
    "SCENARIO_DEGRADE",
    "camera_frame_m",
    "plant_sitting",
    "plant_bystander",
    "draw_swaps",
    "swap_sides",
]

#: Share of labelled turns per bin (Table 2's shape restricted to 90-225°).
LABEL_BIN_MIX: Mapping[int, float] = MappingProxyType({90: 0.45, 135: 0.15, 180: 0.32, 225: 0.08})
#: Range of mean turning speeds per cohort, degrees per second (module docstring).
TURN_SPEED_DEG_S: Mapping[str, tuple[float, float]] = MappingProxyType(
    {"PD": (30.0, 70.0), "HC": (50.0, 110.0)}
)
#: Walking speed per cohort, metres per second (PD walk slower, with shorter steps).
WALK_SPEED_M_S: Mapping[str, tuple[float, float]] = MappingProxyType(
    {"PD": (0.5, 0.9), "HC": (0.8, 1.3)}
)
#: Share of turns made on the spot (en bloc) per cohort; the rest are walking turns.
PIVOT_SHARE: Mapping[str, float] = MappingProxyType({"PD": 0.8, "HC": 0.35})
#: SD of the planted heading change about its labelled bin, degrees.
LABEL_ROUNDING_SD_DEG = 9.0
#: Share of labelled turns that follow the previous one within a second (same or opposite
#: way): people at home turn twice in quick succession, e.g. into a room and to a cupboard.
QUICK_SUCCESSION_SHARE = 0.15
#: Gap between turns in quick succession, seconds (CMU's 69_19: pauses of 0.1-0.3 s).
QUICK_GAP_S = (0.3, 0.9)
#: Share of labelled turns made gradually while walking on, along a curved path of
#: constant curvature, and their mean speed, degrees per second (CMU's 69_32: about 96°
#: over 2.3 s, 42 °/s, a curve, not a corner).
CURVED_SHARE = 0.15
CURVED_SPEED_DEG_S = (25.0, 45.0)
#: Share of pivot turns that end by sitting down (turning to a chair), 5-15 s seated.
TURN_TO_SIT_SHARE = 0.12


@dataclass(frozen=True)
class MovementMix:
    """How often each movement of real life appears (module docstring's *Movements*).

    :data:`REAL_MOVEMENT` (the default) has them all; :data:`PLAIN_MOVEMENT` none: turns
    only at corners of straight walks or on the spot, no circling, as in sessions written
    before these were planted (for comparing a detector across the two).
    """

    quick_share: float = QUICK_SUCCESSION_SHARE
    curved_share: float = CURVED_SHARE
    to_sit_share: float = TURN_TO_SIT_SHARE
    circling_share: float = 0.05  # of the decoys (:data:`DECOY_KINDS`' circling share)


#: Every movement kind at its share (the default of every writer here).
REAL_MOVEMENT = MovementMix()
#: None of them: corners and turns in place only.
PLAIN_MOVEMENT = MovementMix(0.0, 0.0, 0.0, 0.0)

#: Circling decoys (walking round a loop, never one turn): mean speed and length, as
#: Human3.6M's walks round their loop (about 40 °/s for half a minute).
CIRCLING_SPEED_DEG_S = (30.0, 45.0)
CIRCLING_S = (12.0, 25.0)
#: Filler events between turns, with their shares (absence and bystander are artefacts).
DECOY_KINDS: Mapping[str, float] = MappingProxyType(
    {
        "small_turn": 0.19,
        "circling": MovementMix.circling_share,
        "sway": 0.12,
        "reach": 0.16,
        "sit_stand": 0.12,
        "stand": 0.12,
        "absence": 0.12,
        "bystander": 0.12,
    }
)
#: Degradation per scenario (home videos get more depth error and occlusion), calibrated
#: so that the miner's rule run raw on these streams scores about what it scored on the
#: project's hidden sessions (precision 0.41, recall 0.90, F1 0.57, matched accuracy 81%, MAE
#: 29°): here 0.41-0.43, 0.79-0.82, 0.54-0.56, 78-82% and 24-27° on three seeds
#: (``benchmarks/eval_detect.py``). The demo corpus's depth errors (20-110 mm) were
#: harsher than the hidden sessions (raw accuracy 67%).
SCENARIO_DEGRADE: Mapping[str, Mapping[str, float]] = MappingProxyType(
    {
        "scripted": {
            "depth_sd_facing_mm": 13.0,
            "depth_sd_away_mm": 55.0,
            "dropout_rate_per_s": 0.05,
        },
        "clinical": {
            "depth_sd_facing_mm": 16.0,
            "depth_sd_away_mm": 64.0,
            "dropout_rate_per_s": 0.1,
        },
        "free-living": {
            "depth_sd_facing_mm": 20.0,
            "depth_sd_away_mm": 76.0,
            "dropout_rate_per_s": 0.3,
        },
    }
)
_SCENARIO_SHARE = (("scripted", 0.35), ("clinical", 0.15), ("free-living", 0.50))
_LOCATIONS = ("living room", "kitchen", "hallway", "dining room", "bedroom")
_ROOM_RADIUS_MM = 2500.0

#: ``planted.csv``: every event of every stream (turns, decoys and artefacts), frames 0-based.
EVENT_DTYPES = MappingProxyType(
    {
        "session": "str",
        "subject": "str",
        "kind": "str",
        "start_frame": "int64",
        "end_frame": "int64",
        "start_s": "float64",
        "end_s": "float64",
        "heading_deg": "float64",
        "label_deg": "float64",
        # a labelled turn's movement: pivot, walking, curved, quick (within a second of the
        # previous turn), to_sit (a pivot that ends seated); empty for everything else
        "movement": "str",
    }
)
# Left/right joint pairs of the 17-joint layout, exchanged by a swap.
_LR_PAIRS = tuple(
    (H36M17.index(f"left_{j}"), H36M17.index(f"right_{j}"))
    for j in ("hip", "knee", "foot", "shoulder", "elbow", "wrist")
)


@dataclass(frozen=True)
class ArtefactParams:
    """Estimator artefacts planted on every stream (module docstring), with units.

    ``joint_noise_mm`` is per-frame jitter (a single-frame estimator such as MediaPipe
    jitters by about a centimetre); ``white_depth_sd_mm`` a depth error along each joint's
    camera ray, independent per joint and frame, doubled with the back to the camera
    (:func:`turn_datasets.synthetic.degrade.degrade_skeleton`: a lifter's 40-60 mm MPJPE
    is much of it along the ray); the smooth depth error and dropouts come per scenario
    from :data:`SCENARIO_DEGRADE`.
    """

    swaps_per_min: float = 3.0
    swap_frames: tuple[int, int] = (2, 8)
    joint_noise_mm: float = 8.0
    depth_smooth_s: float = 0.3
    white_depth_sd_mm: float = 30.0
    dropout_mean_s: float = 0.15
    absence_s: tuple[float, float] = (5.0, 20.0)
    bystander_s: tuple[float, float] = (2.0, 6.0)


@dataclass(frozen=True)
class UntrimmedStream:
    """One participant's synthetic stream and its truth.

    ``positions`` are ``(frames, 17, 3)`` camera axes, metres, float32; ``events`` has
    :data:`EVENT_DTYPES` columns (without session and subject); ``labels`` the labelled
    turns (``start_s, end_s, angle_deg`` = the bin).
    """

    positions: np.ndarray
    fps: float
    events: pd.DataFrame
    labels: pd.DataFrame


#: Two headings closer than this miss home equally (a tie in :meth:`_Builder.steer`).
_TIE_DEG = 1e-9


def _seed(seed: int, *names: str) -> np.random.Generator:
    # crc32 of the names, not hash(): Python salts str hashes per process.
    return np.random.default_rng([int(seed), zlib.crc32("/".join(names).encode("utf-8"))])


def draw_turn_labels(
    rng: np.random.Generator,
    *,
    duration_s: float,
    cohort: str,
    mean_gap_s: float = 20.0,
    movement: MovementMix = REAL_MOVEMENT,
) -> pd.DataFrame:
    """Draw labelled turns over a session: ``start_s, end_s, angle_deg`` (the bin) and
    ``movement`` (``quick``: within a second of the previous turn; ``curved``: a slow
    walking turn along a curve; else empty).

    Gaps between turns are 4 s plus an exponential of mean ``mean_gap_s - 4`` (about 25
    turns in 10 minutes at the default), except after a turn followed in quick succession
    (:data:`QUICK_SUCCESSION_SHARE`, :data:`QUICK_GAP_S`); durations are the planted angle
    over a mean speed drawn from :data:`TURN_SPEED_DEG_S` (:data:`CURVED_SPEED_DEG_S` for
    a curved walk).
    """
    lo, hi = TURN_SPEED_DEG_S[cohort]
    bins = np.array(list(LABEL_BIN_MIX), dtype=float)
    p = np.array(list(LABEL_BIN_MIX.values()))
    rows = []
    t = float(rng.uniform(4.0, 8.0))
    kind = ""
    while True:
        label = float(rng.choice(bins, p=p / p.sum()))
        curved = kind != "quick" and rng.random() < movement.curved_share
        speed = rng.uniform(*(CURVED_SPEED_DEG_S if curved else (lo, hi)))
        duration = label / float(speed)
        if t + duration > duration_s - 5.0:
            break
        rows.append((t, t + duration, label, "curved" if curved else kind))
        if rng.random() < movement.quick_share:
            kind = "quick"
            t += duration + float(rng.uniform(*QUICK_GAP_S))
        else:
            kind = ""
            t += duration + 4.0 + float(rng.exponential(max(mean_gap_s - 4.0, 0.1)))
    return pd.DataFrame(rows, columns=["start_s", "end_s", "angle_deg", "movement"])


@dataclass
class _Builder:
    """Segments laid end to end, with a rough position and heading to steer turns home.

    The position is integrated from the segments' speeds and headings (ignoring the gait's
    own ramps): it only decides which way a turn goes, so that the person stays in a room
    of :data:`_ROOM_RADIUS_MM` around the origin, as people at home do.
    """

    rng: np.random.Generator
    fps: float
    walk_m_s: float
    heading_deg: float
    segments: list[Segment]
    events: list[tuple[str, int, int, float, float, str]]
    frame: int = 0
    x_mm: float = 0.0
    y_mm: float = 0.0

    def add(
        self, kind: str, n: int, heading_deg: float = 0.0, speed: float = 0.0, ramp_s=None
    ) -> int:
        """Append a segment of ``n`` (>= 2) frames; returns its first frame."""
        n = int(n)
        duration = n / self.fps
        if ramp_s is not None:
            seg = Segment(
                "walking_turn", duration, heading_deg, speed or self.walk_m_s, ramp_s=ramp_s
            )
        elif kind == "stand":
            seg = Segment.stand(duration)
        elif kind == "walk":
            seg = Segment.walk(duration, speed or self.walk_m_s)
        elif kind == "pivot_turn":
            seg = Segment.pivot_turn(heading_deg, duration)
        else:
            seg = Segment.walking_turn(heading_deg, duration, speed or self.walk_m_s)
        # Scalar trigonometry from math (the C library, the same under every NumPy):
        # NumPy 2 computes some of it to a different last bit than NumPy 1.26, and the
        # position decides which way a turn goes.
        mid = math.radians(self.heading_deg + 0.5 * heading_deg)
        self.x_mm += 1000.0 * seg.speed_m_s * duration * math.cos(mid)
        self.y_mm += 1000.0 * seg.speed_m_s * duration * math.sin(mid)
        self.heading_deg += heading_deg
        self.segments.append(seg)
        first = self.frame
        self.frame += n
        return first

    def steer(self, magnitude_deg: float) -> float:
        """The signed heading change of ``magnitude_deg`` that mostly turns towards home."""
        home = math.degrees(math.atan2(-self.y_mm, -self.x_mm))
        miss = [
            abs((self.heading_deg + s * magnitude_deg - home + 180.0) % 360.0 - 180.0)
            for s in (1, -1)
        ]
        # Home exactly behind (after a straight walk from the origin) is a tie: both ways
        # miss it equally, and the last bit of the arithmetic must not decide (it did, and
        # the demo's streams differed between NumPy 1.26 and 2.x). Ties turn left.
        homeward = 1.0 if miss[0] <= miss[1] + _TIE_DEG else -1.0
        sign = homeward if self.rng.random() < 0.85 else -homeward
        return sign * magnitude_deg

    def event(
        self,
        kind: str,
        a: int,
        b: int,
        heading: float = 0.0,
        label: float = np.nan,
        movement: str = "",
    ) -> None:
        self.events.append((kind, int(a), int(b), float(heading), float(label), movement))

    def frames(self, seconds: float) -> int:
        return max(2, int(round(seconds * self.fps)))


def _decoy(b: _Builder, kind: str, room: int) -> None:
    """Plant one filler event of at most ``room`` frames (module docstring's decoys)."""
    rng = b.rng
    if kind == "small_turn":
        n = min(b.frames(rng.uniform(0.6, 1.5)), room)
        h = b.steer(float(rng.uniform(15.0, 40.0)))
        b.event(kind, b.add("walking_turn", n, h), b.frame, h)
    elif kind == "circling" and room >= b.frames(CIRCLING_S[0]):
        # walking round a loop: a curved walk far longer than any one turn
        n = min(b.frames(rng.uniform(*CIRCLING_S)), room)
        h = (
            float(rng.uniform(*CIRCLING_SPEED_DEG_S))
            * n
            / b.fps
            * (1 if rng.random() < 0.5 else -1)
        )
        b.event(kind, b.add("walking_turn", n, h, ramp_s=1.0), b.frame, h)
    elif kind == "sway":
        first = b.frame
        for _ in range(int(rng.integers(3, 7))):
            amp = float(rng.uniform(8.0, 18.0))
            n = b.frames(rng.uniform(0.5, 0.9))
            if b.frame - first + 2 * n + 4 > room:
                break
            b.add("pivot_turn", n, amp)
            b.add("pivot_turn", n, -amp)
            b.add("stand", 2)
        b.event(kind, first, b.frame)
    elif kind == "reach":
        h = float(rng.uniform(25.0, 40.0)) * (1 if rng.random() < 0.5 else -1)
        n = b.frames(rng.uniform(0.8, 1.2))
        hold = max(2, min(b.frames(rng.uniform(1.0, 2.0)), room - 2 * n))
        first = b.add("pivot_turn", n, h)
        b.add("stand", hold)
        b.add("pivot_turn", n, -h)
        b.event(kind, first, b.frame, 0.0)
    elif kind == "absence":
        n = min(b.frames(rng.uniform(5.0, 20.0)), room)
        h = b.steer(float(rng.uniform(90.0, 180.0)))  # a turn no one saw
        n_turn = b.frames(abs(h) / 60.0)
        first = b.add("stand", max(2, (n - n_turn) // 2))
        b.add("pivot_turn", n_turn, h)
        b.add("stand", max(2, n - n_turn - (n - n_turn) // 2))
        b.event(kind, first, b.frame, h)
    else:  # stand, sit_stand, bystander (and a circling with no room for it): standing
        lo, hi = {"sit_stand": (5.0, 25.0), "bystander": (2.0, 6.0)}.get(kind, (2.0, 8.0))
        kind = "stand" if kind == "circling" else kind
        n = min(b.frames(rng.uniform(lo, hi)), room)
        b.event(kind, b.add("stand", n), b.frame)


def timeline_segments(
    rng: np.random.Generator,
    labels: pd.DataFrame,
    *,
    duration_s: float,
    cohort: str,
    fps_hz: float,
    decoy_rate: float = 0.7,
    movement: MovementMix = REAL_MOVEMENT,
) -> tuple[list[Segment], pd.DataFrame, float]:
    """The segments of one participant's timeline around its labelled turns.

    Parameters
    ----------
    rng
        Draws everything.
    labels
        ``start_s, end_s, angle_deg`` (the labelled bin) per turn, not overlapping.
    duration_s
        The stream's length.
    cohort
        ``PD`` or ``HC`` (speeds, pivot share).
    fps_hz
        Frame rate.
    decoy_rate
        Probability that a gap long enough holds a filler event (:data:`DECOY_KINDS`).

    Returns
    -------
    segments, events, start_heading_deg
        The segments for :func:`turn_datasets.synthetic.mocap.generate_sequence` (exactly
        ``round(duration_s * fps_hz)`` frames), the events (``kind, start_frame, end_frame,
        heading_deg, label_deg``; turns are ``turn``) and the heading at frame 0.
    """
    heading0 = float(rng.uniform(-180.0, 180.0))
    b = _Builder(rng, fps_hz, float(rng.uniform(*WALK_SPEED_M_S[cohort])), heading0, [], [])
    total = int(round(duration_s * fps_hz))
    kinds = list(DECOY_KINDS)
    shares = np.array(
        [movement.circling_share if k == "circling" else DECOY_KINDS[k] for k in kinds]
    )
    lead = b.frames(1.0)
    pivot_prev = True  # the stream opens standing
    last_turn = -1  # no turn yet
    for turn in labels.sort_values("start_s").itertuples(index=False):
        a = int(round(float(turn.start_s) * fps_hz))
        e = int(round(float(turn.end_s) * fps_hz))
        if a - b.frame < 4 or e - a < 2 or e > total:
            continue  # overlapping or out of the stream: such a label cannot be planted
        how = str(getattr(turn, "movement", "") or "")
        pivot = how != "curved" and rng.random() < PIVOT_SHARE[cohort]
        gap = a - b.frame
        sit = last_turn >= 0 and pivot_prev and gap - lead > b.frames(7.0)
        if sit and rng.random() < movement.to_sit_share:
            # the last pivot turned the person to a chair: sit down at once
            n_sit = min(b.frames(rng.uniform(5.0, 15.0)), gap - lead - 4)
            b.event("sit_stand", b.add("stand", n_sit), b.frame)
            last = b.events[last_turn]
            b.events[last_turn] = (*last[:5], "to_sit")
        # after the last turn: walk on (or stand after a pivot) for a while
        n_after = min(b.frames(rng.uniform(1.0, 3.0)), max(a - b.frame - lead, 0))
        if n_after >= 2:
            b.add("stand" if pivot_prev else "walk", n_after)
        room = a - b.frame - lead - 4
        if room > b.frames(3.0) and rng.random() < decoy_rate:
            _decoy(b, str(rng.choice(kinds, p=shares / shares.sum())), room)
        # lead-in (at least 4 frames are left): stand, then stand before a pivot or walk
        # into a walking turn for the last second
        rest = a - b.frame
        pre = "stand" if pivot else "walk"
        if rest >= lead + 2:
            b.add("stand", rest - lead)
            b.add(pre, lead)
        else:
            b.add(pre, rest)
        label = float(turn.angle_deg)
        magnitude = label + float(np.clip(rng.normal(0.0, LABEL_ROUNDING_SD_DEG), -20.0, 20.0))
        h = b.steer(magnitude)
        b.add("pivot_turn" if pivot else "walking_turn", e - a, h)
        how = how or ("pivot" if pivot else "walking")
        last_turn = len(b.events)
        b.event("turn", a, e, h, label, how)
        pivot_prev = pivot
    if total - b.frame >= 2:
        b.add("stand", total - b.frame)
    events = pd.DataFrame(
        b.events,
        columns=["kind", "start_frame", "end_frame", "heading_deg", "label_deg", "movement"],
    )
    return b.segments, events, heading0


#: Share of pivot turns (1-2 steps) per cohort; the rest are step turns (3-7 steps).
REMAP_PIVOT_SHARE: Mapping[str, float] = MappingProxyType({"PD": 0.3, "HC": 0.5})
#: At most this many steps a second in a synthetic turn.
_MAX_CADENCE_STEPS_S = 3.0


def draw_steps(rng: np.random.Generator, segment: Segment, cohort: str) -> int:
    """The steps of one planted turn (PD more: Mancini et al. 2015, El-Gohary et al. 2014).

    A pivot turn (share :data:`REMAP_PIVOT_SHARE`) has 1 or 2 steps (PD mostly 2); a step
    turn, on the spot or walking, one step per 45° plus one in PD (and one more half the
    time: people with PD turn in many small steps), one per 90° plus two in controls, between
    3 and 7 and no faster than :data:`_MAX_CADENCE_STEPS_S` steps a second (at least 3).
    """
    pd_like = cohort == "PD"
    magnitude = abs(segment.heading_deg)
    if rng.random() < REMAP_PIVOT_SHARE[cohort]:
        return 2 if rng.random() < (0.7 if pd_like else 0.4) else 1
    if pd_like:
        k = int(round(magnitude / 45.0)) + 1 + int(rng.random() < 0.5)
    else:
        k = int(round(magnitude / 90.0)) + 2
    most = max(3, int(_MAX_CADENCE_STEPS_S * segment.duration_s))
    return int(np.clip(k, 3, min(7, most)))


def plant_sitting(positions: np.ndarray, a: int, b: int, fps: float) -> None:
    """Sit down at the start of frames ``[a, b)`` and stand up at their end, in place.

    The pelvis and everything above it drops by 450 mm and moves 120 mm back (onto the
    chair); the thighs rotate from vertical to horizontal, keeping their length; the feet
    stay. Over 1.2 s each way, with a smooth (raised cosine) profile. The hip vector is not
    rotated: sitting is not a turn, only a change of posture an estimator may misread.
    """
    n = b - a
    ramp = min(int(round(1.2 * fps)), n // 2)
    d = np.ones(n)
    u = np.arange(ramp) / max(ramp, 1)
    d[:ramp] = 0.5 - 0.5 * np.cos(np.pi * u)
    d[n - ramp :] = d[:ramp][::-1]
    p = positions[a:b]
    hips = p[:, [6, 1], :]  # left, right
    lr = hips[:, 0, :2] - hips[:, 1, :2]
    fwd = np.stack([lr[:, 1], -lr[:, 0], np.zeros(n)], axis=1)  # 90° right of left-minus-right
    fwd /= np.maximum(np.linalg.norm(fwd, axis=1, keepdims=True), 1e-9)
    shift = -120.0 * d[:, None] * fwd
    shift[:, 2] -= 450.0 * d
    upper = [0, 1, 6, 11, *range(12, 32)]
    p[:, upper, :] += shift[:, None, :]
    alpha = 0.5 * np.pi * d
    up = np.array([0.0, 0.0, 1.0])
    for hip, knee in ((1, 2), (6, 7)):
        p[:, knee, :] = (
            p[:, hip, :]
            + THIGH_MM * np.sin(alpha)[:, None] * fwd
            - THIGH_MM * np.cos(alpha)[:, None] * up
        )


def plant_bystander(
    rng: np.random.Generator, n: int, fps: float, near_mm: np.ndarray
) -> np.ndarray:
    """Another person for ``n`` frames, 12-25% larger or smaller, 1.5-3 m from ``near_mm``,
    standing or walking, turning 90-180° half of the time: what the tracker jumps to."""
    if rng.random() < 0.5 and n >= 12:
        n1 = max(2, n // 5)
        nt = max(2, min(int(round(float(rng.uniform(1.0, 2.0)) * fps)), n - n1 - 4))
        segs = [
            Segment.stand(n1 / fps),
            Segment.pivot_turn(float(rng.uniform(90, 180)), nt / fps),
            Segment.stand((n - n1 - nt) / fps),
        ]
    else:
        segs = [Segment.walk(max(n, 2) / fps, float(rng.uniform(0.8, 1.2)))]
    other = generate_sequence(
        seed=int(rng.integers(2**31)), segments=segs, fps_hz=fps, noise_mm=0.0
    ).positions[:n]
    scale = float(rng.uniform(1.12, 1.25)) if rng.random() < 0.5 else float(rng.uniform(0.75, 0.88))
    ground = other[:, :1, :].copy()
    ground[:, :, 2] = 0.0
    other = ground + scale * (other - ground)
    where = float(rng.uniform(-np.pi, np.pi))
    target = near_mm[:2] + float(rng.uniform(1500.0, 3000.0)) * np.array(
        [np.cos(where), np.sin(where)]
    )
    other[:, :, :2] += target - other[0, 0, :2]
    return other


def swap_sides(positions17: np.ndarray, a: int, b: int) -> None:
    """Exchange the left and right joints of frames ``[a, b)`` in place (17-joint layout)."""
    for left, right in _LR_PAIRS:
        positions17[a:b, [left, right]] = positions17[a:b, [right, left]]


def draw_swaps(
    rng: np.random.Generator, facing_deg: np.ndarray, fps: float, params: ArtefactParams
) -> list[tuple[int, int]]:
    """Frame runs whose left and right joints get exchanged, mostly with the back turned."""
    n = facing_deg.shape[0]
    count = int(rng.poisson(params.swaps_per_min * n / fps / 60.0))
    weight = np.nan_to_num(facing_deg, nan=0.0) + 1.0
    starts = np.sort(rng.choice(n, size=min(count, n), replace=False, p=weight / weight.sum()))
    lo, hi = params.swap_frames
    return [(int(s), int(min(s + rng.integers(lo, hi + 1), n))) for s in starts]


def _context(rng: np.random.Generator, session: str, duration_s: float) -> pd.DataFrame:
    """Scenario blocks (scripted, clinical, free-living) and rooms changing every 1-3 min
    (``context.csv``'s columns; ``subject`` empty: the caller writes one copy per person)."""
    rows = []
    t = 0.0
    for i, (scenario, share) in enumerate(_SCENARIO_SHARE):
        end = duration_s if i == len(_SCENARIO_SHARE) - 1 else t + share * duration_s
        while t < end - 1e-9:
            stop = min(end, t + float(rng.uniform(60.0, 180.0)))
            place = str(rng.choice(_LOCATIONS))
            rows.append((session, "", round(t, 3), round(stop, 3), scenario, place))
            t = stop
    return typed_frame(pd.DataFrame(rows, columns=list(CONTEXT_COLUMNS)), CONTEXT_COLUMNS)


def synthesize_stream(
    rng: np.random.Generator,
    labels: pd.DataFrame,
    *,
    duration_s: float,
    cohort: str,
    context: pd.DataFrame,
    camera_mm: tuple[float, float, float],
    fps_hz: float = 30.0,
    artefacts: ArtefactParams = ArtefactParams(),
    root_relative: bool = False,
    movement: MovementMix = REAL_MOVEMENT,
    footsteps: np.random.Generator | None = None,
) -> UntrimmedStream:
    """One participant's estimator-like stream around its labelled turns (module docstring).

    Parameters
    ----------
    rng
        Draws everything.
    labels
        ``start_s, end_s, angle_deg`` of the labelled turns (:func:`draw_turn_labels`, or a
        participant's rows of a ``remap labels`` table).
    duration_s, cohort, fps_hz
        Length, ``PD``/``HC``, frame rate.
    context
        The person's scenario intervals (``context.csv``'s columns): each gets the degradation
        of :data:`SCENARIO_DEGRADE`.
    camera_mm
        The camera's position (world, z up, millimetres; the room's centre is the origin).
    artefacts
        Swaps, jitter, dropout length, absence and identity-break lengths.
    root_relative
        Subtract the pelvis from every joint (as lifting networks output).
    footsteps
        Plant footsteps (:mod:`turn_datasets.synthetic.footsteps`), each turn's steps drawn
        from this generator (:func:`draw_steps`; a generator of its own, so that the rest of
        the stream is drawn as without footsteps); the labels then carry ``steps`` and
        ``turn_type``.
    """
    segs, events, heading0 = timeline_segments(
        rng, labels, duration_s=duration_s, cohort=cohort, fps_hz=fps_hz, movement=movement
    )
    if footsteps is not None:
        segs = [
            replace(s, steps=draw_steps(footsteps, s, cohort)) if s.is_turn else s for s in segs
        ]
    seq = generate_sequence(
        seed=int(rng.integers(2**31)),
        segments=segs,
        fps_hz=fps_hz,
        noise_mm=0.0,  # the estimator's errors come below
        sway_deg=float(rng.uniform(3.0, 7.0)),
        start_heading_deg=heading0,
        footsteps=footsteps is not None,
    )
    body = seq.positions
    for ev in events.itertuples(index=False):
        if ev.kind == "sit_stand":
            plant_sitting(body, ev.start_frame, ev.end_frame, fps_hz)
        elif ev.kind == "bystander":
            near = body[ev.start_frame, 0, :]
            body[ev.start_frame : ev.end_frame] = plant_bystander(
                rng, ev.end_frame - ev.start_frame, fps_hz, near
            )
    body17 = body[:, list(H36M17_FROM_32), :]
    out = np.empty_like(body17)
    facing = np.empty(body17.shape[0])
    n = body17.shape[0]
    for row in context.itertuples(index=False):
        a = int(round(row.start_s * fps_hz))
        b = min(int(round(row.end_s * fps_hz)), n)
        if b <= a:
            continue
        deg = degrade_skeleton(
            body17[a:b],
            H36M17,
            seed=rng,
            fps=fps_hz,
            camera_position_mm=camera_mm,
            joint_noise_mm=artefacts.joint_noise_mm,
            depth_smooth_s=artefacts.depth_smooth_s,
            white_depth_sd_mm=artefacts.white_depth_sd_mm,
            dropout_mean_s=artefacts.dropout_mean_s,
            depth_sd_facing_mm=SCENARIO_DEGRADE[row.scenario]["depth_sd_facing_mm"],
            depth_sd_away_mm=SCENARIO_DEGRADE[row.scenario]["depth_sd_away_mm"],
            dropout_rate_per_s=SCENARIO_DEGRADE[row.scenario]["dropout_rate_per_s"],
        )
        out[a:b] = deg.positions
        facing[a:b] = deg.facing_to_camera_deg
    rows = [events]
    for ev in events.itertuples(index=False):
        if ev.kind == "absence":
            out[ev.start_frame : ev.end_frame] = np.nan
    swaps = draw_swaps(rng, facing, fps_hz, artefacts)
    for a, b in swaps:
        swap_sides(out, a, b)
    rows.append(_spans("swap", swaps))
    rows.append(_spans("dropout", _runs_of(np.isnan(out).any(axis=(1, 2)))))
    ev_all = pd.concat(rows, ignore_index=True).sort_values(["start_frame", "kind"], kind="stable")
    ev_all["start_s"] = ev_all["start_frame"] / fps_hz
    ev_all["end_s"] = ev_all["end_frame"] / fps_hz
    turns = ev_all[ev_all["kind"] == "turn"]
    labelled = pd.DataFrame(
        {
            "start_s": turns["start_s"].to_numpy(),
            "end_s": turns["end_s"].to_numpy(),
            "angle_deg": turns["label_deg"].to_numpy(),
        }
    )
    if footsteps is not None:
        planted = seq.planted.set_index("start_frame")
        first = turns["start_frame"].to_numpy()
        labelled["steps"] = planted.loc[first, "steps"].to_numpy()
        labelled["turn_type"] = planted.loc[first, "turn_type"].to_numpy()
    seen = camera_frame_m(out, camera_mm)
    if root_relative:
        seen = seen - seen[:, :1, :]
    return UntrimmedStream(seen, float(fps_hz), ev_all.reset_index(drop=True), labelled)


def camera_frame_m(positions_mm: np.ndarray, camera_mm: tuple[float, float, float]) -> np.ndarray:
    """World (z up, millimetres) -> the camera's own axes in metres, float32.

    The camera stands at ``camera_mm``, level, looking at the room's centre (the origin):
    x to the image's right, y down, z forward along its optical axis, as an estimator writes
    3D joints (``--up-axis -y``). A proper rotation plus a translation, so left and right
    turns keep their sense; the depth error planted along the camera's rays lies mostly
    along z, as a monocular estimator's does.
    """
    cam = np.asarray(camera_mm, dtype=float)
    f = -cam[:2] / max(float(np.hypot(*cam[:2])), 1e-9)  # forward, on the ground plane
    d = np.asarray(positions_mm, dtype=float) - cam
    x = d[..., 0] * f[1] - d[..., 1] * f[0]  # right = forward turned 90° clockwise
    z = d[..., 0] * f[0] + d[..., 1] * f[1]
    return (np.stack([x, -d[..., 2], z], axis=-1) / 1000.0).astype(np.float32)


def _spans(kind: str, spans: list[tuple[int, int]]) -> pd.DataFrame:
    """Event rows of one artefact kind (no heading, no label)."""
    return pd.DataFrame(
        {
            "kind": kind,
            "start_frame": [a for a, _ in spans],
            "end_frame": [b for _, b in spans],
            "heading_deg": 0.0,
            "label_deg": np.nan,
            "movement": "",
        }
    )


def _runs_of(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(
        zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True)
    )


def _camera(rng: np.random.Generator) -> tuple[float, float, float]:
    """A camera at the room's edge, 3-4.5 m from its centre, 1.0-2.2 m high."""
    bearing = float(rng.uniform(-np.pi, np.pi))
    dist = float(rng.uniform(3000.0, 4500.0))
    return (dist * np.cos(bearing), dist * np.sin(bearing), float(rng.uniform(1000.0, 2200.0)))


def write_untrimmed_corpus(
    out_dir: str | os.PathLike[str],
    *,
    seed: int,
    n_pairs: int = 8,
    duration_s: float = 600.0,
    fps_hz: float = 30.0,
    root_relative_every: int = 4,
    artefacts: ArtefactParams = ArtefactParams(),
    movement: MovementMix = REAL_MOVEMENT,
    footsteps: bool = False,
) -> dict[str, Path]:
    """Write a synthetic untrimmed corpus: sessions of a PD participant and a control.

    ``movement`` sets how often the movements of real life appear (:class:`MovementMix`).

    Each of ``n_pairs`` sessions (``home01``, ...) holds two people, ``P01`` (PD) and
    ``C01`` (control), each with their own timeline (:func:`draw_turn_labels`) in one
    ``streams/<session>.npz``; every ``root_relative_every``-th session is written
    root-relative. Beside ``streams/``: ``labels.csv`` (the ``remap labels`` columns, and
    with ``footsteps`` each turn's planted ``steps`` and ``turn_type``), ``context.csv``,
    ``sessions.csv`` (with each session's ``start_time``: :func:`session_start_time`),
    ``participants.csv`` (``subject, cohort``) and ``planted.csv`` (:data:`EVENT_DTYPES`).

    Returns
    -------
    dict
        ``streams`` (the folder) and each CSV by name.
    """
    out = Path(out_dir)
    (out / "streams").mkdir(parents=True, exist_ok=True)
    labels, contexts, sessions, events, people = [], [], [], [], []
    for i in range(1, n_pairs + 1):
        session = f"home{i:02d}"
        srng = _seed(seed, session)
        context = _context(srng, session, duration_s)
        camera = _camera(srng)
        arrays = {}
        for subject, cohort in ((f"P{i:02d}", "PD"), (f"C{i:02d}", "HC")):
            rng = _seed(seed, session, subject)
            drawn = draw_turn_labels(rng, duration_s=duration_s, cohort=cohort, movement=movement)
            stream = synthesize_stream(
                rng,
                drawn,
                duration_s=duration_s,
                cohort=cohort,
                context=context,
                camera_mm=camera,
                fps_hz=fps_hz,
                artefacts=artefacts,
                root_relative=root_relative_every > 0 and i % root_relative_every == 0,
                movement=movement,
                footsteps=_seed(seed, session, subject, "steps") if footsteps else None,
            )
            arrays[subject] = stream.positions
            labels.append(
                _label_rows(stream.labels, session, subject, cohort, context, f"{session}.npz")
            )
            events.append(stream.events.assign(session=session, subject=subject))
            sessions.append((session, subject, duration_s, session_start_time(seed, session, i)))
            people.append((subject, cohort))
            contexts.append(context.assign(subject=subject))
        write_npz(out / "streams" / f"{session}.npz", arrays)
    paths = {"streams": out / "streams"}
    tables = {
        "labels.csv": typed_frame(
            pd.concat(labels, ignore_index=True),
            {**LABEL_COLUMNS, **(STEP_LABEL_COLUMNS if footsteps else {})},
        ),
        "context.csv": typed_frame(pd.concat(contexts, ignore_index=True), CONTEXT_COLUMNS),
        "sessions.csv": typed_frame(pd.DataFrame(sessions, columns=list(_SESSIONS)), _SESSIONS),
        "participants.csv": pd.DataFrame(people, columns=["subject", "cohort"]),
        "planted.csv": typed_frame(
            pd.concat(events, ignore_index=True)[list(EVENT_DTYPES)], EVENT_DTYPES
        ),
    }
    for name, table in tables.items():
        paths[name] = write_csv(table, out / name)
    return paths


#: ``sessions.csv`` as the untrimmed corpus writes it: with each session's start.
_SESSIONS = {**SESSIONS_COLUMNS, **SESSIONS_OPTIONAL}
#: The labels' columns with planted footsteps, after the ``remap labels`` ones.
STEP_LABEL_COLUMNS = {"steps": "int64", "turn_type": "str"}


def session_start_time(seed: int, session: str, day: int) -> str:
    """When a synthetic session started: ISO 8601 with its UTC offset. Session ``day`` (1, 2,
    ...) is recorded on that day of March 2024, starting between 07:00 and 19:59 local time
    in a +01:00 zone (drawn from ``seed`` and the session's name alone)."""
    rng = _seed(seed, session, "start_time")
    hour, minute = int(rng.integers(7, 20)), int(rng.integers(0, 60))
    return f"2024-03-{day:02d}T{hour:02d}:{minute:02d}:00+01:00"


def _label_rows(
    turns: pd.DataFrame, session: str, subject: str, cohort: str, context: pd.DataFrame, source: str
) -> pd.DataFrame:
    """The ``remap labels`` rows of one participant's planted turns, with their context."""
    mid = 0.5 * (turns["start_s"].to_numpy() + turns["end_s"].to_numpy())
    idx = np.searchsorted(context["start_s"].to_numpy(), mid, side="right") - 1
    ctx = context.iloc[np.clip(idx, 0, len(context) - 1)]
    start = turns["start_s"].round(3).to_numpy()
    end = turns["end_s"].round(3).to_numpy()
    steps = {c: turns[c].to_numpy() for c in STEP_LABEL_COLUMNS if c in turns}
    return pd.DataFrame(
        {
            "clip_id": [
                clip_id_for(session=session, subject=subject, start_s=s, end_s=e)
                for s, e in zip(start, end, strict=True)
            ],
            "session": session,
            "subject": subject,
            "cohort": cohort,
            "annotator": "planted",
            "start_s": start,
            "end_s": end,
            "duration_s": np.round(end - start, 3),
            "angle_deg": turns["angle_deg"].to_numpy(),
            "scenario": ctx["scenario"].to_numpy(),
            "location": ctx["location"].to_numpy(),
            "double_annotated": False,
            "source": source,
            **steps,
        }
    )


def write_streams_for_labels(
    labels: pd.DataFrame,
    out_dir: str | os.PathLike[str],
    *,
    seed: int,
    context: pd.DataFrame | None = None,
    sessions: pd.DataFrame | None = None,
    fps_hz: float = 30.0,
    artefacts: ArtefactParams = ArtefactParams(),
    footsteps: bool = False,
) -> list[Path]:
    """Untrimmed streams around the turns of a ``remap labels`` table (the demo's sessions).

    For each session, one ``<session>.npz`` in ``out_dir`` with one stream per subject whose
    labelled turns are planted at the labels' times with the labels' angles (the bin plus
    the rounding of :data:`LABEL_ROUNDING_SD_DEG`), everything between filled as
    :func:`timeline_segments` does, degraded per the scenario in ``context`` (else all
    ``scripted``), as long as ``sessions`` says (else 10 s after the last turn). Each
    session's camera and each person's timeline are seeded from ``seed`` and their names.

    Parameters
    ----------
    labels
        ``session, subject, cohort, start_s, end_s, angle_deg`` per turn.
    out_dir
        Folder of the ``.npz`` files (created).
    seed, fps_hz, artefacts
        See :func:`synthesize_stream`.
    context, sessions
        ``context.csv`` and ``sessions.csv`` as ``remap labels`` writes them, or None.
    footsteps
        Plant footsteps, each turn's steps drawn by :func:`draw_steps` from a generator
        seeded by ``seed`` and the names (see :func:`synthesize_stream`).

    Returns
    -------
    list of Path
        The files written, by session.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for session, turns in labels.groupby("session", sort=True):
        srng = _seed(seed, str(session))
        camera = _camera(srng)
        arrays = {}
        for subject, mine in turns.groupby("subject", sort=True):
            duration = float(mine["end_s"].max()) + 10.0
            if sessions is not None:
                row = sessions[(sessions["session"] == session) & (sessions["subject"] == subject)]
                duration = max(duration, float(row["duration_s"].max()) if len(row) else 0.0)
            ctx = _context_of(context, str(session), str(subject), duration)
            stream = synthesize_stream(
                _seed(seed, str(session), str(subject)),
                mine[["start_s", "end_s", "angle_deg"]],
                duration_s=duration,
                cohort=str(mine["cohort"].iloc[0]),
                context=ctx,
                camera_mm=camera,
                fps_hz=fps_hz,
                artefacts=artefacts,
                footsteps=_seed(seed, str(session), str(subject), "steps") if footsteps else None,
            )
            arrays[str(subject)] = stream.positions
        written.append(write_npz(out / f"{session}.npz", arrays))
    return written


def _context_of(
    context: pd.DataFrame | None, session: str, subject: str, duration_s: float
) -> pd.DataFrame:
    """One person's scenario intervals covering ``[0, duration_s]``: theirs from
    ``context.csv`` (rows without a subject are shared), gaps and the rest ``scripted``."""
    rows = []
    if context is not None:
        mine = context[context["session"] == session]
        if "subject" in mine.columns:
            mine = mine[mine["subject"].fillna("").astype(str).isin([subject, ""])]
        rows = [
            (session, subject, float(r.start_s), float(r.end_s), str(r.scenario), "")
            for r in mine.sort_values("start_s").itertuples(index=False)
            if str(r.scenario) in SCENARIO_DEGRADE
        ]
    t = 0.0
    filled = []
    for row in rows:
        if row[2] > t:
            filled.append((session, subject, t, row[2], "scripted", ""))
        if row[3] > max(t, row[2]):
            filled.append((session, subject, max(t, row[2]), row[3], row[4], ""))
            t = row[3]
    if t < duration_s:
        filled.append((session, subject, t, duration_s, "scripted", ""))
    return pd.DataFrame(filled, columns=list(CONTEXT_COLUMNS))
