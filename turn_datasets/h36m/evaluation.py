"""How well the miner finds known turns: matching mined clips to planted ones, and scores.

As mobgap keeps an ``evaluation.py`` beside each algorithm, this module scores
:func:`turn_datasets.h36m.miner.mine_sequence` against sequences whose turns are known (the
synthetic sets of :mod:`turn_datasets.synthetic.miner_sets`, or any other truth of the same
columns).

Each known turn of 60° or more is matched one-to-one with a mined clip of the same direction
(scipy's Hungarian algorithm on the frames they share, :func:`match_turns`). The truth of a
clip's ``angle_deg`` is the planted heading change (``heading_deg``); of its
``hip_rotation_deg``, the planted hip rotation (``angle_deg``). A mined clip that matches no
planted turn and overlaps none below 60° is a false clip.
A planted turn longer than :data:`turn_datasets.limits.MAX_TURN_DURATION_S` is turning that
the rule reports as a circling episode, not a turn (one turn lasts at most 10 s): it is
scored as neither, and a clip overlapping it is not false.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from turn_datasets import limits
from turn_datasets.h36m.miner import MinerParams, mine_sequence
from turn_datasets.skeleton import Layout

__all__ = ["MIN_PLANTED_DEG", "FAST_DEG_S", "KnownTurns", "match_turns", "score_sequences"]

#: Planted turns below this are not scored (a clip on them is neither right nor false).
MIN_PLANTED_DEG = 60.0
#: A planted turn faster than this on average (°/s) counts as fast in the table.
FAST_DEG_S = 100.0
#: Turns this many seconds apart are back to back in the table.
_BACK_TO_BACK_S = 0.5


class KnownTurns(NamedTuple):
    """A sequence and its known turns: ``planted`` has ``kind, start_frame, end_frame,
    duration_s, heading_deg`` (the signed heading change) and ``angle_deg`` (the signed hip
    rotation)."""

    seed: int
    positions: np.ndarray
    layout: Layout
    fps: float
    planted: pd.DataFrame


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


def _circling(planted: pd.DataFrame) -> pd.Series:
    """Planted turns longer than one turn lasts: circling episodes, scored as neither."""
    return planted.duration_s > limits.MAX_TURN_DURATION_S


def _rows(case: KnownTurns, mined: pd.DataFrame) -> tuple[list[dict], int]:
    """One row per planted turn (found or not, its errors), and the false clips."""
    planted, fps = case.planted, case.fps
    pairs = dict(match_turns(planted, mined))
    rows = []
    prev_end = -1_000_000
    for i, p in enumerate(planted.itertuples(index=False)):
        row = {
            "seed": case.seed,
            "kind": p.kind,
            "left": p.heading_deg > 0,
            "fast": abs(p.heading_deg) / p.duration_s > FAST_DEG_S,
            "back_to_back": p.start_frame - prev_end == int(_BACK_TO_BACK_S * fps),
            "planted_deg": abs(p.heading_deg),
            "circling": bool(p.duration_s > limits.MAX_TURN_DURATION_S),
            "found": i in pairs,
        }
        prev_end = p.end_frame
        if i in pairs:
            m = mined.iloc[pairs[i]]
            row["angle_error_deg"] = m.angle_deg - abs(p.heading_deg)
            row["hip_error_deg"] = m.hip_rotation_deg - abs(p.heading_deg)
            row["start_error_s"] = (m.start_frame - p.start_frame) / fps
            row["end_error_s"] = (m.end_frame - p.end_frame) / fps
        rows.append(row)
    false_clips = 0
    for j in set(range(len(mined))) - set(pairs.values()):
        m = mined.iloc[j]
        small = planted[
            ((planted.heading_deg.abs() < MIN_PLANTED_DEG) | _circling(planted))
            & (planted.end_frame > m.start_frame)
            & (planted.start_frame < m.end_frame)
        ]
        false_clips += small.empty
    return rows, false_clips


def score_sequences(cases: Iterable[KnownTurns], params: MinerParams | None = None) -> dict:
    """Recall, precision, angle and boundary errors of the miner on sequences of known turns.

    Returns
    -------
    dict
        ``n_planted`` (scored turns), ``recall``, ``precision``, ``false_clips``, the median
        and 90th percentile of the absolute angle error (degrees), the mean signed one, the
        median absolute error of ``hip_rotation_deg`` against the same heading truth (what
        the old angle would score), the median absolute boundary error (seconds, starts and
        ends pooled) and the mean signed start and end errors; plus ``table``, one row per
        scored planted turn (with its ``kind``, ``left``, ``fast`` and ``back_to_back``).
    """
    rows: list[dict] = []
    false_clips = 0
    for case in cases:
        mined = mine_sequence(case.positions, layout=case.layout, fps_hz=case.fps, params=params)
        found, false = _rows(case, mined)
        rows += found
        false_clips += false
    table = pd.DataFrame(rows)
    scored = table[(table.planted_deg >= MIN_PLANTED_DEG) & ~table.circling]
    hits = scored[scored.found]
    err = np.abs(hits.angle_error_deg.to_numpy())
    boundary = np.abs(np.concatenate([hits.start_error_s, hits.end_error_s]))
    return {
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
