"""Time ``turn-eval score-events`` on 100,000 reference turns against 100,000 detections.

What is timed: reading and validating the reference (labels with cohort, scenario and
location) and the detections (with direction, speed and score) from CSV, together with a
context file and a sessions file; matching in 1,000 (session, subject) units; precision,
recall and F1 overall and in four groupings; the matched-turn angle metrics; turns per hour;
average precision at five IoU thresholds; a 1,000-resample cluster bootstrap; and the JSON,
Markdown and CSV renderings: everything ``turn-eval score-events --format json`` does but the
process start. The baseline is reading the same two CSVs with ``pandas.read_csv`` (no
checks), in the same process. Both are CPU time (``time.process_time``) and the best of a
few runs, as ``bench_score``.

Issue 12's target: the whole scoring in at most 5 such reads.

Run: ``.venv/bin/python benchmarks/bench_events.py`` (``make bench`` runs every benchmark).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from turn_datasets.fileio import to_json_text
from turn_eval.events import events_frame, events_markdown, score_events

N_UNITS = 1000
TURNS_PER_UNIT = 100
N_RESAMPLES = 1000
BASELINE_REPEATS = 5
SCORE_REPEATS = 3


def _write_inputs(folder: Path, *, seed: int = 11) -> dict[str, Path]:
    """1,000 sessions of one participant each, 100 turns apiece, and a noisy detector."""
    rng = np.random.default_rng(seed)
    n = N_UNITS * TURNS_PER_UNIT
    unit = np.repeat(np.arange(N_UNITS), TURNS_PER_UNIT)
    session = np.array([f"home{u // 2:04d}-{u % 2}" for u in range(N_UNITS)])[unit]
    subject = np.array([f"P{u % 48:02d}" for u in range(N_UNITS)])[unit]
    cohort = np.where(unit % 48 < 24, "PD", "HC")
    # Turns of 1-4 s with gaps of 2-30 s: about an hour per session.
    duration = rng.uniform(1.0, 4.0, n)
    gap = rng.uniform(2.0, 30.0, n)
    end = np.zeros(n)
    start = np.zeros(n)
    for u in range(N_UNITS):
        s = slice(u * TURNS_PER_UNIT, (u + 1) * TURNS_PER_UNIT)
        t = np.cumsum(gap[s] + duration[s])
        end[s] = t
        start[s] = t - duration[s]
    segment = (start // 600).astype(int)  # context changes every 10 minutes
    scenarios = np.array(["scripted", "clinical", "free-living"])
    rooms = np.array(["kitchen", "lounge", "hallway", "bedroom", "dining", "stairs"])
    scenario = scenarios[(segment + unit) % 3]
    location = rooms[(segment * 5 + unit) % 6]
    angle = rng.choice(np.arange(90.0, 361.0, 45.0), n)
    reference = pd.DataFrame(
        {
            "clip_id": [f"c{i:06d}" for i in range(n)],
            "session": session,
            "subject": subject,
            "cohort": cohort,
            "start_s": start.round(3),
            "end_s": end.round(3),
            "angle_deg": angle,
            "scenario": scenario,
            "location": location,
        }
    )
    # The detector: 90% of turns found with jittered boundaries, false turns in the gaps.
    found = rng.random(n) < 0.9
    jitter = rng.normal(0.0, 0.3, (2, n))
    d_start = np.where(found, start + jitter[0], end + 0.3 * gap)
    d_end = np.where(found, end + jitter[1], end + 0.3 * gap + rng.uniform(0.8, 3.0, n))
    d_end = np.maximum(d_end, d_start + 0.2)
    d_angle = np.where(found, np.abs(angle + rng.normal(0, 25, n)), rng.uniform(45, 200, n))
    detections = pd.DataFrame(
        {
            "session": session,
            "subject": subject,
            "start_s": np.maximum(d_start, 0.0).round(3),
            "end_s": d_end.round(3),
            "angle_deg": d_angle.round(1),
            "direction": np.where(rng.random(n) < 0.5, "left", "right"),
            "speed_deg_s": (d_angle / (d_end - d_start)).round(1),
            "score": rng.random(n).round(4),
        }
    )
    # Keep the detections of a unit apart (the contract): clip each end at the next start.
    nxt = np.append(detections["start_s"].to_numpy()[1:], np.inf)
    same = np.append(unit[1:] == unit[:-1], False)
    detections["end_s"] = np.where(same, np.minimum(detections["end_s"], nxt), detections["end_s"])
    keep = detections["end_s"] > detections["start_s"]
    detections = detections[keep]
    ctx_unit = np.repeat(np.arange(N_UNITS), 8)
    ctx_seg = np.tile(np.arange(8), N_UNITS)
    context = pd.DataFrame(
        {
            "session": np.array([f"home{u // 2:04d}-{u % 2}" for u in range(N_UNITS)])[ctx_unit],
            "subject": np.array([f"P{u % 48:02d}" for u in range(N_UNITS)])[ctx_unit],
            "start_s": ctx_seg * 600.0,
            "end_s": (ctx_seg + 1) * 600.0,
            "scenario": scenarios[(ctx_seg + ctx_unit) % 3],
            "location": rooms[(ctx_seg * 5 + ctx_unit) % 6],
        }
    )
    sessions = pd.DataFrame(
        {
            "session": [f"home{u // 2:04d}-{u % 2}" for u in range(N_UNITS)],
            "subject": [f"P{u % 48:02d}" for u in range(N_UNITS)],
            "duration_s": 4800.0,
        }
    )
    paths = {
        "reference": folder / "labels.csv",
        "detections": folder / "detections.csv",
        "context": folder / "context.csv",
        "sessions": folder / "sessions.csv",
    }
    reference.to_csv(paths["reference"], index=False)
    detections.to_csv(paths["detections"], index=False)
    context.to_csv(paths["context"], index=False)
    sessions.to_csv(paths["sessions"], index=False)
    return paths


def _score(paths: dict[str, Path]) -> dict:
    result = score_events(
        paths["detections"],
        paths["reference"],
        context=paths["context"],
        sessions=paths["sessions"],
        n_resamples=N_RESAMPLES,
        seed=0,
    )
    to_json_text(result.doc)
    events_markdown(result.doc)
    events_frame(result.doc).to_csv(index=False)
    return result.doc


def _baseline(paths: dict[str, Path]) -> None:
    pd.read_csv(paths["reference"])
    pd.read_csv(paths["detections"])


def _best(fn, repeats: int) -> tuple[float, float]:
    cpu, wall = np.inf, np.inf
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - w0)
    return cpu, wall


def run() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        paths = _write_inputs(Path(tmp))
        n_det = sum(1 for _ in open(paths["detections"])) - 1
        _baseline(paths)  # warm-up: imports, page cache
        doc = _score(paths)
        base_cpu, _ = _best(lambda: _baseline(paths), BASELINE_REPEATS)
        score_cpu, score_wall = _best(lambda: _score(paths), SCORE_REPEATS)
    return {
        "what": "score-events: read, validate, match, metrics, AP x5, 1000-resample cluster "
        f"bootstrap, render (F1 {doc['overall']['f1']:.3f})",
        "size": f"{N_UNITS * TURNS_PER_UNIT:,} turns in {N_UNITS:,} sessions vs "
        f"{n_det:,} detections",
        "baseline": "pandas.read_csv of the two CSVs",
        "seconds": score_wall,
        "ratio": score_cpu / base_cpu,
        "target": "<= 5",
    }


if __name__ == "__main__":
    print(run())
