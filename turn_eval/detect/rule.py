"""The built-in detector: the miner's rule on an estimator's stream, after its preprocessing.

The rule that mines Turn-H3.6M's clips from motion capture
(:mod:`turn_datasets.h36m.miner`: hip yaw, bridging short dropouts, a zero-phase low-pass,
a heading rate taken over one stride so that the pelvis's step-by-step sway cancels,
double-threshold runs of it, boundaries where the heading starts and stops changing, and
the angle as the change of the mean heading over a stride on each side) is the
detector. It is not a second algorithm; what an estimator's stream needs on top
(:mod:`turn_eval.detect.preprocess`) comes first, per stream:

1. **Identity.** The stream is split where the skeleton jumps to someone else (position or
   size), and pieces of another body size are dropped.
2. **Swaps.** Left/right swaps are undone.
3. **Frontal vector.** The frontal vectors of the chosen joint pairs (``joints``; default
   hips and shoulders, the paper's equations 1 and 2) are made unit length and averaged,
   each weighted by its pair's squared median width. The depth error of a monocular
   estimator is independent from joint to joint and turns a pair by about error / width,
   so the inverse-variance weight is the squared width (the shoulders, 36 cm apart, count
   about twice the hips, 26 cm); on the synthetic sessions two pairs cut the per-frame yaw
   error from about 10° (hips) to 7°, and took F1 from 0.87 to 0.95. The shoulders'
   counter-rotation in gait also cancels part of the pelvis's sway. The knees swing with
   every step and are left out by default (with them F1 fell to 0.92); they still give the
   miner its stride period.
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

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import (
    angular_speed_deg_s,
    direction_of,
    frontal_vectors,
    parse_joints,
    usable_frames,
)
from turn_datasets.h36m.miner import HeadingRuns, MinerParams, heading_runs, knee_gait
from turn_datasets.params import check_params, describe_params, param
from turn_datasets.skeleton import JOINT_PAIRS, Layout
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
#: (the miner's 0.6 s holds less of the wobble's slow error). On the synthetic untrimmed
#: sessions (three seeds) these took F1 from 0.95 to 0.97-0.98 and matched accuracy from
#: 93-94% to 95-97% (``benchmarks/eval_detect.py``).
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


def _paired_joints(positions: np.ndarray, layout: Layout) -> tuple[np.ndarray, Layout]:
    """The joints of :data:`~turn_datasets.skeleton.JOINT_PAIRS` that ``layout`` has, as a
    contiguous ``(frames, joints, 3)`` copy, and the layout that names them."""
    names = [n for pair in JOINT_PAIRS.values() for n in pair if n in layout.joints]
    sub = Layout(f"{layout.name}-pairs", len(names), {n: i for i, n in enumerate(names)})
    return positions[:, [layout.index(n) for n in names]], sub


def _joints_read(positions: np.ndarray, layout: Layout) -> tuple[np.ndarray, Layout]:
    """The joints the rule reads (the pairs, the body-size bones and the step counter's
    ankles), gathered into one float64 ``(frames, joints, 3)`` array, and the layout that
    names them: the stream itself (often float32, all joints) is never widened whole."""
    wanted = [*(n for pair in JOINT_PAIRS.values() for n in pair), *SIZE_JOINTS, *STEP_JOINTS]
    names = [n for n in dict.fromkeys(wanted) if n in layout.joints]
    sub = Layout(f"{layout.name}-read", len(names), {n: i for i, n in enumerate(names)})
    p = np.asarray(positions)
    out = np.empty((p.shape[0], len(names), 3), dtype=np.float64)
    for k, name in enumerate(names):  # joint by joint: no stored-precision copy in between
        out[:, k] = p[:, layout.index(name)]
    return out, sub


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
        p, layout = _joints_read(positions, layout)
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
        # The rule from here on reads only the paired joints (hips, knees, shoulders): one
        # gather into a compact array makes every later pass (swap repair's copy, frontal
        # vectors) walk 6 joints' memory instead of the whole skeleton's; same numbers.
        pairs, pair_layout = _paired_joints(p, layout)
        # the pieces' clips gathered as columns (one table for the stream, not one per piece)
        cols: dict[str, list[np.ndarray]] = {"start": [], "end": [], "net": [], "seen": []}
        for a, b in pieces:
            found = self._mine_piece(pairs[a:b], fps_hz, pair_layout)
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
        # would move both ankles by the stance width and back: two false steps).
        unswapped, _ = repair_swaps(p, layout, fps_hz=fps_hz, max_gap_s=prm.miner.max_gap_s)
        steps = turn_steps(unswapped, layout, fps_hz, start, end, prm.steps)
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
        fixed, _ = repair_swaps(piece, layout, fps_hz=fps_hz, max_gap_s=prm.miner.max_gap_s)
        total = np.zeros((fixed.shape[0], 2))
        widths = {}
        for joint in prm.joints:
            v = frontal_vectors(fixed, layout, joint)
            length = np.hypot(v[:, 0], v[:, 1])
            widths[joint] = float(np.nanmedian(length)) if np.isfinite(length).any() else 0.0
            # weight = squared width: independent joint errors turn a pair by error / width
            with np.errstate(invalid="ignore", divide="ignore"):
                total += widths[joint] ** 2 * v / length[:, None]
        seen = usable_frames(fixed, layout, prm.joints) & np.isfinite(total).all(axis=1)
        if int(seen.sum()) < 2:
            return None
        # The combined unit vector at the hips' own width, and the knees as they are: the
        # miner reads the stride from the knees' fore-aft swing in hip widths.
        if "hip" in widths:
            width = widths["hip"]
        else:
            hip = frontal_vectors(fixed, layout, "hip")
            width = float(np.nanmedian(np.hypot(hip[:, 0], hip[:, 1])))
        frontal = np.full((fixed.shape[0], 2), np.nan)
        frontal[seen] = (width * total / np.hypot(total[:, 0], total[:, 1])[:, None])[seen]
        knees = fixed[:, [layout.index("left_knee"), layout.index("right_knee")], :2]
        gait = knee_gait(frontal, knees[:, 0].astype(float), knees[:, 1].astype(float))
        runs = heading_runs(frontal, fps_hz=fps_hz, gait=gait, params=prm.miner)
        seen_sum = np.concatenate(([0], np.cumsum(seen)))
        s, e = runs.start, runs.end
        return runs, (seen_sum[e] - seen_sum[s]) / np.maximum(e - s, 1)
