"""How well the miner finds planted turns: matching mined clips to a synthetic truth.

As mobgap keeps an ``evaluation.py`` beside each algorithm, this module scores
:func:`turn_datasets.h36m.miner.mine_sequence` against the turns planted by
:mod:`turn_datasets.synthetic.mocap`, on two synthetic sets:

easy
    turns of 45 to 160 °/s mean speed, 3 to 5° peak-to-peak pelvic sway, 10 mm joint noise;
hard
    slow turns of 25 to 60 °/s, 6 to 8° sway, 20 mm noise, NaN dropouts (short ones anywhere,
    a long one in a straight stretch);

each minable in the three Human3.6M layouts (the 32 joints in millimetres, the 17-joint
subset in millimetres, and the 17 joints in metres as VideoPose3D stores them).

Each planted turn of 60° or more is matched one-to-one with a mined clip of the same
direction (scipy's Hungarian algorithm on the frames they share, :func:`match_turns`). The
truth of a clip's ``angle_deg`` is the planted heading change (the generator's
``heading_deg``); of its ``hip_rotation_deg``, the planted hip rotation (``angle_deg``). A
mined clip that matches no planted turn and overlaps none below 60° is a false clip.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from types import MappingProxyType
from typing import TypedDict

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from turn_datasets.h36m.miner import MinerParams, mine_sequence
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, H36M32, Layout
from turn_datasets.synthetic import mocap as sm

__all__ = ["SETS", "LAYOUTS", "MIN_PLANTED_DEG", "synthetic", "in_layout", "match_turns", "score"]


class SyntheticSet(TypedDict):
    """A synthetic set: turn speed range (°/s), sway range (peak to peak, °), joint noise
    (mm), and whether capture dropouts are planted."""

    speed: tuple[float, float]
    sway: tuple[float, float]
    noise_mm: float
    dropouts: bool


#: The synthetic sets: turn speed range (°/s), sway range (peak to peak, °), noise.
SETS: Mapping[str, SyntheticSet] = MappingProxyType(
    {
        "easy": {"speed": (45.0, 160.0), "sway": (3.0, 5.0), "noise_mm": 10.0, "dropouts": False},
        "hard": {"speed": (25.0, 60.0), "sway": (6.0, 8.0), "noise_mm": 20.0, "dropouts": True},
    }
)
#: The three ways Human3.6M's poses are stored.
LAYOUTS = ("h36m32-mm", "h36m17-mm", "h36m17-m")
#: Planted turns below this are not scored (a clip on them is neither right nor false).
MIN_PLANTED_DEG = 60.0


def synthetic(set_name: str, seed: int) -> sm.SyntheticSequence:
    """One sequence of a set (eight planted turns), drawn from ``seed``."""
    cfg = SETS[set_name]
    rng = np.random.default_rng(seed)
    segs = sm.random_segments(rng, turn_speed_range_deg_s=cfg["speed"])
    drops = sm.random_dropouts(rng, segs) if cfg["dropouts"] else []
    return sm.generate_sequence(
        seed=seed,
        segments=segs,
        sway_deg=float(rng.uniform(*cfg["sway"])),
        noise_mm=cfg["noise_mm"],
        dropouts=drops,
    )


def in_layout(seq: sm.SyntheticSequence, layout: str) -> tuple[np.ndarray, Layout]:
    """The sequence's positions in one of :data:`LAYOUTS`."""
    if layout == "h36m32-mm":
        return seq.positions, H36M32
    j17 = seq.positions[:, list(H36M17_FROM_32)]
    return (j17, H36M17) if layout == "h36m17-mm" else (j17 / 1000.0, H36M17)


def match_turns(planted: pd.DataFrame, mined: pd.DataFrame) -> list[tuple[int, int]]:
    """One-to-one planted/mined pairs of the same direction maximising the shared frames.

    Solved with scipy's Hungarian algorithm on the overlap matrix; only overlapping pairs
    are kept. ``planted`` needs ``heading_deg``, ``mined`` ``net_deg``.
    """
    if planted.empty or mined.empty:
        return []
    ps, pe = planted["start_frame"].to_numpy()[:, None], planted["end_frame"].to_numpy()[:, None]
    ms, me = mined["start_frame"].to_numpy()[None, :], mined["end_frame"].to_numpy()[None, :]
    overlap = np.clip(np.minimum(pe, me) - np.maximum(ps, ms), 0, None)
    same_way = (
        np.sign(planted["heading_deg"].to_numpy())[:, None]
        == np.sign(mined["net_deg"].to_numpy())[None, :]
    )
    overlap = np.where(same_way, overlap, 0)
    rows, cols = linear_sum_assignment(-overlap)
    return [(int(r), int(c)) for r, c in zip(rows, cols, strict=True) if overlap[r, c] > 0]


def score(
    set_name: str, layout: str, seeds: Iterable[int], params: MinerParams | None = None
) -> dict:
    """Recall, precision, angle and boundary errors of the miner on one set and layout.

    Returns
    -------
    dict
        ``n_planted`` (scored turns), ``recall``, ``precision``, ``false_clips``, the median
        and 90th percentile of the absolute angle error (degrees), the mean signed one, the
        median absolute error of ``hip_rotation_deg`` against the same heading truth (what
        the old angle would score), the median absolute boundary error (seconds, starts and
        ends pooled) and the mean signed start and end errors; plus ``table``, one row per
        scored planted turn.
    """
    rows, false_clips = [], 0
    for seed in seeds:
        seq = synthetic(set_name, seed)
        positions, lay = in_layout(seq, layout)
        mined = mine_sequence(positions, layout=lay, fps_hz=seq.fps, params=params)
        pairs = dict(match_turns(seq.planted, mined))
        for i, p in enumerate(seq.planted.itertuples(index=False)):
            row = {"seed": seed, "kind": p.kind, "planted_deg": abs(p.heading_deg)}
            row["found"] = i in pairs
            if i in pairs:
                m = mined.iloc[pairs[i]]
                row["angle_error_deg"] = m.angle_deg - abs(p.heading_deg)
                row["hip_error_deg"] = m.hip_rotation_deg - abs(p.heading_deg)
                row["start_error_s"] = (m.start_frame - p.start_frame) / seq.fps
                row["end_error_s"] = (m.end_frame - p.end_frame) / seq.fps
            rows.append(row)
        for j in set(range(len(mined))) - set(pairs.values()):
            m = mined.iloc[j]
            small = seq.planted[
                (seq.planted.heading_deg.abs() < MIN_PLANTED_DEG)
                & (seq.planted.end_frame > m.start_frame)
                & (seq.planted.start_frame < m.end_frame)
            ]
            false_clips += small.empty
    table = pd.DataFrame(rows)
    scored = table[table.planted_deg >= MIN_PLANTED_DEG]
    hits = scored[scored.found]
    err = np.abs(hits.angle_error_deg.to_numpy())
    boundary = np.abs(np.concatenate([hits.start_error_s, hits.end_error_s]))
    return {
        "set": set_name,
        "layout": layout,
        "n_planted": int(len(scored)),
        "recall": round(len(hits) / len(scored), 4),
        "precision": round(len(hits) / max(len(hits) + false_clips, 1), 4),
        "false_clips": int(false_clips),
        "median_angle_error_deg": round(float(np.median(err)), 2),
        "p90_angle_error_deg": round(float(np.percentile(err, 90)), 2),
        "mean_signed_angle_error_deg": round(float(np.mean(hits.angle_error_deg)), 2),
        "median_hip_rotation_error_deg": round(float(np.median(np.abs(hits.hip_error_deg))), 2),
        "median_boundary_error_s": round(float(np.median(boundary)), 3),
        "mean_start_error_s": round(float(np.mean(hits.start_error_s)), 3),
        "mean_end_error_s": round(float(np.mean(hits.end_error_s)), 3),
        "table": scored,
    }
