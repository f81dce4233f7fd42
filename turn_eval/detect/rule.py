"""The built-in detector: the miner's rule on an estimator's stream, after its preprocessing.

The rule that mines Turn-H3.6M's clips from motion capture
(:mod:`turn_datasets.h36m.miner`: hip yaw, bridging short dropouts, a zero-phase low-pass,
a heading rate taken over one stride so that the pelvis's step-by-step sway cancels,
double-threshold runs of it, boundaries where the heading starts and stops changing, and
the angle as the change of the mean heading over a stride on each side) is the
detector. It is not a second algorithm; what an estimator's stream needs on top
(:mod:`turn_eval.detect.preprocess`) comes first, per stream:

1. **Identity.** The stream is split where the skeleton jumps to someone else (position or
   size), pieces of another body size are dropped, and kept pieces split by a change of
   size alone are joined again.
2. **Swaps.** Left/right swaps are undone.
3. **Frontal vector.** The frontal vectors of the chosen joint pairs (``joints``; default
   hips and shoulders, the paper's equations 1 and 2) give one heading per frame. Their
   plain direction is their unit vectors averaged, each weighted by its pair's squared
   median width: the depth error of a monocular estimator is independent from joint to
   joint and turns a pair by about error / width, so the inverse-variance weight is the
   squared width (the shoulders, 36 cm apart, count about twice the hips, 26 cm). On the
   synthetic sessions (``benchmarks/eval_detect.py``, three seeds) the hips alone give F1
   0.93-0.95, the hips and shoulders 0.975-0.982. The shoulders' counter-rotation in gait
   also cancels part of the pelvis's sway. The knees swing with every step and are left
   out by default (with them F1 is 0.93-0.94); they still give the miner its stride
   period. The heading is then corrected, within ``ray_search_deg`` of that direction, by
   what an estimator gets right: the pairs' lengths and their positions across the
   camera's ray, against their depth (:mod:`turn_eval.detect.heading`: ``ray_noise_ratio``,
   ``lateral_noise_widths``; a root-relative stream's ray is read from its jitter).
4. **The miner's rule** on that vector (:func:`turn_datasets.h36m.miner.mine_heading`),
   with its gap bridging (``max_gap_s``: longer gaps cut the stream, so a turn is never
   followed through an absence) and its ``min_turn_deg`` (the paper's 45°; 67.5° for
   Turn-REMAP, whose smallest label is the 90° bin): small direction changes, sway,
   reaching and sitting down turn the body by less and are not turns.

Each turn's ``score`` is ``observed * angle / (angle + min_turn_deg)``, with ``observed``
the share of its frames that were seen (not bridged): larger and fully seen turns are surer.
Its ``steps``, ``turn_type`` and ``peak_speed_deg_s`` are :func:`turn_eval.steps.turn_steps`'
on the stream with its left/right swaps undone.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from textwrap import indent
from typing import NamedTuple

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import (
    FrontalLengths,
    angular_speed_deg_s,
    direction_of,
    frontal_lengths,
    frontal_vectors,
    parse_joints,
    usable_frames,
)
from turn_datasets.h36m.miner import HeadingRuns, MinerParams, heading_runs, knee_gait
from turn_datasets.params import check_params, describe_params, param
from turn_datasets.skeleton import JOINT_PAIRS, Layout
from turn_eval.detect.heading import PAIR_LENGTH_CV, camera_rays, ray_weighted_direction
from turn_eval.detect.preprocess import SIZE_JOINTS, identity_pieces, repair_swaps
from turn_eval.detect.protocol import TURN_DTYPES, empty_turns
from turn_eval.steps import STEP_COLUMNS, STEP_JOINTS, StepParams, turn_steps

__all__ = ["DetectParams", "MinerRule", "DETECT_MINER_DEFAULTS", "split_overlaps"]

#: The miner's parameters as the detector uses them (the rest are the miner's defaults).
#: Estimator dropouts are longer than motion capture's, so gaps up to half a second are
#: bridged (a 180° turn at 70 °/s covers 35° in that time, which interpolation follows).
#: A monocular estimator's depth error wobbles the heading by several degrees over fractions
#: of a second, so a turn's start and end are fitted from a 12° departure (the miner's 6° is
#: reached by the wobble alone and stretched short turns by up to a second), a turn ends
#: below 15 °/s, and the heading before and after a turn in place is averaged over a second
#: (the miner's 0.6 s holds less of the wobble's slow error). With the miner's own values
#: instead (6°, 10 °/s, 0.6 s), the synthetic untrimmed sessions (``benchmarks/eval_detect.py``,
#: three seeds) give twice the false turns and F1 0.968-0.972 against 0.975-0.982.
DETECT_MINER_DEFAULTS = MinerParams(
    max_gap_s=0.5, onset_deg=12.0, stop_speed_deg_s=15.0, no_sway_window_s=1.0
)


@dataclass(frozen=True)
class DetectParams:
    """Every parameter of the built-in detector, with units (module docstring).

    The preprocessing's own fields are declared here once, with their help and bounds
    (:func:`turn_datasets.params.param`; ``turn-eval detect`` makes its options from them);
    ``joints`` names the joint pairs whose frontal vectors are combined (any of ``hip``,
    ``knee``, ``shoulder``); ``miner`` holds the miner's rule
    (:class:`turn_datasets.h36m.miner.MinerParams`), by default
    :data:`DETECT_MINER_DEFAULTS`; ``steps`` the step counter's
    (:class:`turn_eval.steps.StepParams`).
    """

    identity_jump_sizes: float = param(
        0.5,
        "A move of the mid-hip point between consecutive frames by more than this many body "
        "sizes (trunk + upper arms, about 1.1 m in an adult) is a jump to another person.",
        min=0,
        min_open=True,
        max=100.0,
    )
    identity_size_change: float = param(
        0.15,
        "A change of the body's size by more than this fraction (median over the second "
        "after a frame against the second before) is a jump to another person.",
        min=0,
        min_open=True,
        max=10.0,
    )
    identity_size_tolerance: float = param(
        0.1,
        "Stretches whose size differs from most of the stream's by more than this fraction "
        "are another person's and ignored.",
        min=0,
        min_open=True,
        max=10.0,
    )
    ray_noise_ratio: float = param(
        4.0,
        "The pose estimator's joint error along the camera's ray over its error across it "
        "(30 mm against 10 mm facing the camera, 60 mm with the back to it): the heading "
        "trusts the pairs' lengths and lateral positions over their depth; 1 takes both alike.",
        min=1.0,
        max=100.0,
    )
    lateral_noise_widths: float = param(
        0.04,
        "The pose estimator's joint error across the camera's ray, in hip widths (10 mm of "
        "a 260 mm hip width).",
        min=0.0,
        min_open=True,
        max=1.0,
    )
    ray_search_deg: float = param(
        20.0,
        "How far the depth-aware heading may move from the plain direction of the joint "
        "pairs, in degrees (never to its mirror image about the ray); 0 keeps the plain one.",
        min=0.0,
        max=90.0,
    )
    joints: tuple[str, ...] = ("hip", "shoulder")
    miner: MinerParams = field(default_factory=lambda: DETECT_MINER_DEFAULTS)
    steps: StepParams = field(default_factory=StepParams)

    def __post_init__(self) -> None:
        object.__setattr__(self, "joints", parse_joints(self.joints))
        check_params(self)

    def as_dict(self) -> dict[str, object]:
        """Flat, JSON-ready: the detector's own fields and the miner's, by name."""
        out: dict[str, object] = {
            k: v for k, v in asdict(self).items() if k not in ("miner", "steps")
        }
        out["joints"] = ",".join(self.joints)
        out.update(self.miner.as_dict())
        out.update({f"steps_{k}": v for k, v in asdict(self.steps).items()})
        return out


DetectParams.__doc__ = (
    (DetectParams.__doc__ or "") + "\n" + indent(describe_params(DetectParams), "    ")
)


def split_overlaps(start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frames ``[start, end)`` of time-ordered turns, with each overlap of two neighbours
    split at its middle.

    The miner fits a turn's start and end from where the heading departs (its step 6); two
    turns a moment apart can then share a few frames (seen: 2 frames at 30 fps between
    opposite turns on noisy streams). The detections contract wants one person's turns
    apart, so each keeps its half of what they share.
    """
    start = np.array(start, dtype=np.int64)
    end = np.array(end, dtype=np.int64)
    for i in np.flatnonzero(start[1:] < end[:-1]):
        mid = (int(start[i + 1]) + int(end[i])) // 2
        end[i], start[i + 1] = max(mid, start[i] + 1), min(mid, end[i + 1] - 1)
    return start, end


class _JointsRead(NamedTuple):
    """The joints the rule reads (:func:`_joints_read`) and the layouts of its parts."""

    #: float64 ``(frames, joints, 3)``, z up.
    positions: np.ndarray
    layout: Layout
    #: The pairs of :data:`~turn_datasets.skeleton.JOINT_PAIRS` the layout has: a view.
    pairs: np.ndarray
    pair_layout: Layout
    #: The hips, shoulders and ankles that the step counter reads: a view.
    steps: np.ndarray
    step_layout: Layout


def _joints_read(positions: np.ndarray, layout: Layout) -> _JointsRead:
    """The joints the rule reads (the pairs, the step counter's ankles and the body-size
    bones), gathered into one float64 ``(frames, joints, 3)`` array, with two views of it:
    the pairs, which the miner's rule reads, and what the step counter reads. The stream
    itself (often float32, all joints) is never widened whole.

    The array is stored joint by joint (each joint's coordinate one contiguous series of
    frames; the array is a transposed view of that store): every later pass takes a joint's
    coordinates or the difference of two joints, which then run along contiguous memory
    instead of stepping over the other joints three values at a time (an eighth of the time,
    same numbers). The joints are stored knees, hips, shoulders, ankles, then the rest, so
    that both views are slices.
    """
    have = layout.joints
    side = {kind: [n for n in JOINT_PAIRS[kind] if n in have] for kind in JOINT_PAIRS}
    ankles = [n for n in STEP_JOINTS if n in have]
    pairs = [*side["knee"], *side["hip"], *side["shoulder"]]
    steps = [*side["hip"], *side["shoulder"], *ankles]
    names = list(dict.fromkeys([*pairs, *ankles, *(n for n in SIZE_JOINTS if n in have)]))

    def sub(name: str, joints: list[str]) -> Layout:
        return Layout(f"{layout.name}-{name}", len(joints), {n: i for i, n in enumerate(joints)})

    p = np.asarray(positions)
    store = np.empty((len(names), 3, p.shape[0]), dtype=np.float64)
    by_joint = p.transpose(1, 2, 0)  # a view: (joints, 3, frames)
    for k, name in enumerate(names):  # joint by joint: no stored-precision copy in between
        store[k] = by_joint[layout.index(name)]
    read = store.transpose(2, 0, 1)
    first = len(side["knee"])
    return _JointsRead(
        read,
        sub("read", names),
        read[:, : len(pairs)],
        sub("pairs", pairs),
        read[:, first : first + len(steps)],
        sub("steps", steps),
    )


def _width(lengths: FrontalLengths) -> float:
    """A pair's width: the median of its lengths, NaN frames aside (0 when none is finite);
    an infinite length (only a caller past the readers' magnitude check has one) counts."""
    if np.isnan(lengths.median):
        return 0.0
    if np.isinf(lengths.length).any():
        return float(np.nanmedian(lengths.length))
    return lengths.median


class MinerRule:
    """The built-in :class:`~turn_eval.detect.protocol.TurnDetector` (module docstring)."""

    name = "miner-rule"

    def __init__(self, params: DetectParams | None = None) -> None:
        self.params = params or DetectParams()
        #: Why each run of turning of the last stream was not reported (``circling``,
        #: ``too_fast``: :func:`turn_datasets.h36m.miner.rejection_reasons`).
        self.rejected_: list[str] = []

    def detect(self, positions: np.ndarray, fps_hz: float, layout: Layout) -> pd.DataFrame:
        """The turns of one stream: :data:`~turn_eval.detect.protocol.TURN_DTYPES` columns."""
        read = _joints_read(positions, layout)
        p, layout = read.positions, read.layout
        prm = self.params
        self.rejected_ = []
        usable = usable_frames(p, layout, ("hip",))
        pieces = identity_pieces(
            p,
            layout,
            usable,
            fps_hz=fps_hz,
            jump_sizes=prm.identity_jump_sizes,
            size_change=prm.identity_size_change,
            size_tolerance=prm.identity_size_tolerance,
        )
        # the pieces' clips gathered as columns (one table for the stream, not one per piece)
        cols: dict[str, list[np.ndarray]] = {"start": [], "end": [], "net": [], "seen": []}
        for a, b in pieces:
            # the rule reads only the paired joints (hips, knees, shoulders)
            found = self._mine_piece(read.pairs[a:b], fps_hz, read.pair_layout)
            if found is None:
                continue
            runs, observed = found
            ok = runs.reason == ""
            self.rejected_.extend(runs.reason[~ok].tolist())
            cols["start"].append(runs.start[ok] + a)
            cols["end"].append(runs.end[ok] + a)
            cols["net"].append(runs.net_deg[ok])
            cols["seen"].append(observed[ok])
        if not sum(len(c) for c in cols["start"]):
            return empty_turns()
        start, end = split_overlaps(np.concatenate(cols["start"]), np.concatenate(cols["end"]))
        net = np.concatenate(cols["net"])
        angle = np.abs(net)
        duration = (end - start) / fps_hz
        min_deg = prm.miner.min_turn_deg
        # Steps, turn type and peak speed from the whole stream, its swaps undone (a swap
        # would move both ankles by the stance width and back: two false steps); the swaps
        # are found from the hips, as usable here.
        unswapped, _ = repair_swaps(
            read.steps,
            read.step_layout,
            fps_hz=fps_hz,
            max_gap_s=prm.miner.max_gap_s,
            usable=usable,
        )
        steps = turn_steps(unswapped, read.step_layout, fps_hz, start, end, prm.steps)
        table = pd.DataFrame(
            {
                "start_s": start / fps_hz,
                "end_s": end / fps_hz,
                "angle_deg": angle,
                "direction": [direction_of(v) for v in net],
                "speed_deg_s": angular_speed_deg_s(angle, duration),
                **{c: steps[c].to_numpy() for c in STEP_COLUMNS},
                "score": np.concatenate(cols["seen"]) * angle / (angle + min_deg),
            }
        )
        return typed_frame(table, TURN_DTYPES)

    def _mine_piece(
        self, piece: np.ndarray, fps_hz: float, layout: Layout
    ) -> tuple[HeadingRuns, np.ndarray] | None:
        """Swaps undone, frontal vectors combined, the miner's rule: its runs, with the share
        of each run's frames that were seen; None where too little of the piece was seen."""
        prm = self.params
        # A pair's lengths (and so its width and which frames are usable) are the same
        # before and after the swaps are undone (an exchange of sides negates the vector
        # exactly): taken once, here, and the hips' usable frames given to the repair.
        lengths = {j: frontal_lengths(frontal_vectors(piece, layout, j)) for j in prm.joints}
        if "hip" not in lengths:
            lengths["hip"] = frontal_lengths(frontal_vectors(piece, layout, "hip"))
        fixed, _ = repair_swaps(
            piece,
            layout,
            fps_hz=fps_hz,
            max_gap_s=prm.miner.max_gap_s,
            usable=lengths["hip"].usable,
        )
        vectors, widths = [], []
        seen = np.ones(fixed.shape[0], dtype=bool)
        for joint in prm.joints:
            vectors.append(frontal_vectors(fixed, layout, joint))
            widths.append(_width(lengths[joint]))
            seen &= lengths[joint].usable
        # The combined unit vector at the hips' own width, and the knees as they are: the
        # miner reads the stride from the knees' fore-aft swing in hip widths.
        if "hip" in prm.joints:
            width = widths[prm.joints.index("hip")]
        else:
            width = float(np.nanmedian(lengths["hip"].length))
        hips = [layout.index("left_hip"), layout.index("right_hip")]
        # the joints whose jitter shows a root-relative stream's ray (their own movement is
        # the trunk's, slow against the estimator's error)
        trunk = [*hips, layout.index("left_shoulder"), layout.index("right_shoulder")]
        heading = ray_weighted_direction(
            vectors,
            widths,
            [PAIR_LENGTH_CV[j] for j in prm.joints],
            camera_rays(fixed[:, hips, :2].mean(axis=1), width, fixed[:, trunk, :2], fps_hz),
            lateral_sd=prm.lateral_noise_widths * width,
            ratio=prm.ray_noise_ratio,
            search_deg=prm.ray_search_deg,
        )
        seen &= np.isfinite(heading).all(axis=1)
        if int(seen.sum()) < 2:
            return None
        frontal = np.full((fixed.shape[0], 2), np.nan)
        frontal[seen] = width * heading[seen]
        knees = fixed[:, [layout.index("left_knee"), layout.index("right_knee")], :2]
        gait = knee_gait(frontal, knees[:, 0].astype(float), knees[:, 1].astype(float))
        runs = heading_runs(frontal, fps_hz=fps_hz, gait=gait, params=prm.miner)
        seen_sum = np.concatenate(([0], np.cumsum(seen)))
        s, e = runs.start, runs.end
        return runs, (seen_sum[e] - seen_sum[s]) / np.maximum(e - s, 1)
