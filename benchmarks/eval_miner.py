"""Accuracy of the miner on synthetic sets with planted turns (issue 11's targets).

Two sets, each mined in the three Human3.6M layouts (the 32 joints in millimetres, the
17-joint subset in millimetres, and the 17 joints in metres as VideoPose3D stores them):

easy
    turns of 45 to 160 °/s mean speed, 3 to 5° peak-to-peak pelvic sway, 10 mm joint noise;
hard
    slow turns of 25 to 60 °/s, 6 to 8° sway, 20 mm noise, NaN dropouts (short ones anywhere,
    a long one in a straight stretch).

Each planted turn of 60° or more is matched one-to-one with a mined clip of the same
direction (scipy's Hungarian algorithm on the frames they share). The truth of a clip's
angle is the planted heading change (the generator's ``heading_deg``), not the hip's
rotation: the miner's ``angle_deg`` is a heading change. A mined clip that matches no planted
turn and overlaps none below 60° is a false clip.

Run: ``python benchmarks/eval_miner.py [--seeds N]``; prints one JSON line per set and layout.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from turn_datasets.h36m.miner import mine_sequence
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, H36M32
from turn_datasets.synthetic import mocap as sm

SETS = {
    "easy": {"speed": (45.0, 160.0), "sway": (3.0, 5.0), "noise_mm": 10.0, "dropouts": False},
    "hard": {"speed": (25.0, 60.0), "sway": (6.0, 8.0), "noise_mm": 20.0, "dropouts": True},
}
LAYOUTS = ("h36m32-mm", "h36m17-mm", "h36m17-m")
MIN_PLANTED_DEG = 60.0


def synthetic(set_name: str, seed: int) -> sm.SyntheticSequence:
    """One sequence of a set, drawn from ``seed``."""
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


def in_layout(seq: sm.SyntheticSequence, layout: str):
    if layout == "h36m32-mm":
        return seq.positions, H36M32
    j17 = seq.positions[:, list(H36M17_FROM_32)]
    return (j17, H36M17) if layout == "h36m17-mm" else (j17 / 1000.0, H36M17)


def match_turns(planted: pd.DataFrame, mined: pd.DataFrame) -> list[tuple[int, int]]:
    """One-to-one planted/mined pairs of the same direction maximising the shared frames."""
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


def score(set_name: str, layout: str, seeds) -> dict:
    """Recall, precision, angle and boundary errors of the miner on one set and layout."""
    rows, false_clips = [], 0
    for seed in seeds:
        seq = synthetic(set_name, seed)
        positions, lay = in_layout(seq, layout)
        mined = mine_sequence(positions, layout=lay, fps_hz=seq.fps)
        pairs = dict(match_turns(seq.planted, mined))
        for i, p in enumerate(seq.planted.itertuples(index=False)):
            row = {"seed": seed, "planted_deg": abs(p.heading_deg), "found": i in pairs}
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
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=40, help="sequences per set (8 turns each)")
    ap.add_argument("--layouts", default=",".join(LAYOUTS), help="comma-separated")
    ap.add_argument("--sets", default="easy,hard", help="comma-separated")
    args = ap.parse_args(argv)
    for set_name in args.sets.split(","):
        for layout in args.layouts.split(","):
            print(json.dumps(score(set_name, layout, range(args.seeds))), flush=True)


if __name__ == "__main__":
    main()
