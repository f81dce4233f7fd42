"""Time ``turn-eval profile`` on a week of 1,000 participants: about 1.5 million turns.

What is timed: reading and validating the detections (every column ``turn-eval detect``
writes, steps and turn type included), the sessions (7,000, with their start times) and the
participants; cross-checking them; the per-participant measures, turns per local hour, and
the PD-versus-control contrasts of every measure with a 1,000-resample bootstrap of the
participants within each group: everything ``turn-eval profile`` computes but writing and the
process start. The baseline is reading the same detections CSV with ``pandas.read_csv`` (no
checks), in the same process. Both are CPU time (``time.process_time``), the best of a few
runs, as ``bench_events``.

Memory: the peak of what Python and numpy allocate (``tracemalloc``) while profiling a
quarter of the participants and all of them; "linear" means the peak per turn stays the same
(the size printed gives both, in bytes per turn).

Issue 22's target: the whole profile in at most 3 such reads.

Run: ``.venv/bin/python benchmarks/bench_profile.py`` (``make bench`` runs every benchmark).
"""

from __future__ import annotations

import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd

from turn_eval.profile import turning_profile

N_PARTICIPANTS = 1000
DAYS = 7
HOURS_PER_DAY = 14.0
TURNS_PER_HOUR = 15.3  # 1,000 x 7 x 14 h x 15.3 = 1.5 M turns
N_RESAMPLES = 1000
BASELINE_REPEATS = 3
PROFILE_REPEATS = 2


def _write_inputs(folder: Path, n_participants: int, *, seed: int = 3) -> dict[str, Path]:
    """A week of one 14-hour session a day per participant, turns at random times."""
    rng = np.random.default_rng(seed)
    subjects = np.array([f"P{i:04d}" for i in range(n_participants)])
    n_sessions = n_participants * DAYS
    ses_subject = np.repeat(subjects, DAYS)
    ses_day = np.tile(np.arange(DAYS), n_participants)
    session = np.char.add(np.char.add(ses_subject, "-d"), ses_day.astype(str))
    duration = np.full(n_sessions, HOURS_PER_DAY * 3600.0)
    start_hour = rng.integers(6, 9, n_sessions)
    start_time = [
        f"2024-03-{4 + d:02d}T{h:02d}:00:00+01:00" for d, h in zip(ses_day, start_hour, strict=True)
    ]
    pd.DataFrame(
        {
            "session": session,
            "subject": ses_subject,
            "duration_s": duration,
            "start_time": start_time,
        }
    ).to_csv(folder / "sessions.csv", index=False)
    cohort = np.where(np.arange(n_participants) % 2 == 0, "PD", "HC")
    pd.DataFrame({"subject": subjects, "cohort": cohort}).to_csv(
        folder / "participants.csv", index=False
    )
    per = rng.poisson(TURNS_PER_HOUR * HOURS_PER_DAY, n_sessions)
    unit = np.repeat(np.arange(n_sessions), per)
    n = unit.shape[0]
    # turns evenly spread over the day, jittered within their slot, 1-4 s long
    slot = duration[unit] / per[unit]
    k = np.arange(n) - np.repeat(np.cumsum(per) - per, per)
    length = rng.uniform(1.0, 4.0, n)
    start = k * slot + rng.uniform(0, 1, n) * np.maximum(slot - length, 0)
    is_pd = cohort[unit // DAYS] == "PD"
    angle = np.where(is_pd, rng.uniform(60, 180, n), rng.uniform(70, 220, n))
    steps = np.where(is_pd, rng.integers(2, 8, n), rng.integers(1, 6, n))
    pd.DataFrame(
        {
            "session": session[unit],
            "subject": ses_subject[unit],
            "start_s": start.round(3),
            "end_s": (start + length).round(3),
            "angle_deg": angle.round(1),
            "direction": np.where(rng.random(n) < 0.5, "left", "right"),
            "speed_deg_s": (angle / length).round(1),
            "peak_speed_deg_s": (1.5 * angle / length).round(1),
            "steps": steps,
            "turn_type": np.where(steps < 3, "pivot", "step"),
            "score": rng.random(n).round(4),
        }
    ).to_csv(folder / "detections.csv", index=False)
    return {
        "detections": folder / "detections.csv",
        "sessions": folder / "sessions.csv",
        "participants": folder / "participants.csv",
    }


def _profile(paths: dict[str, Path]):
    return turning_profile(
        paths["detections"], paths["sessions"], paths["participants"], n_resamples=N_RESAMPLES
    )


def _best(fn, repeats: int) -> tuple[float, float]:
    cpu, wall = np.inf, np.inf
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - w0)
    return cpu, wall


def _peak_bytes(paths: dict[str, Path]) -> int:
    tracemalloc.start()
    try:
        _profile(paths)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def run() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        quarter = Path(tmp) / "quarter"
        quarter.mkdir()
        small = _write_inputs(quarter, N_PARTICIPANTS // 4)
        paths = _write_inputs(Path(tmp), N_PARTICIPANTS)
        n_small = sum(1 for _ in open(small["detections"])) - 1
        n_turns = sum(1 for _ in open(paths["detections"])) - 1
        peak = (_peak_bytes(small) / n_small, _peak_bytes(paths) / n_turns)
        pd.read_csv(paths["detections"])  # warm-up: imports, page cache
        result = _profile(paths)
        base_cpu, _ = _best(lambda: pd.read_csv(paths["detections"]), BASELINE_REPEATS)
        cpu, wall = _best(lambda: _profile(paths), PROFILE_REPEATS)
    auc = result.contrasts.set_index("measure").loc["mean_angle_deg", "auc"]
    return {
        "what": "profile: read, check, measures, by-hour, contrasts of "
        f"{len(result.contrasts)} measures, 1000-resample bootstrap (angle AUC {auc:.2f})",
        "size": f"{n_turns:,} turns, {N_PARTICIPANTS:,} participants x {DAYS} days; peak "
        f"memory {peak[0]:.0f} B/turn at a quarter, {peak[1]:.0f} B/turn at all",
        "baseline": "pandas.read_csv of the detections",
        "seconds": wall,
        "ratio": cpu / base_cpu,
        "target": "<= 3",
    }


if __name__ == "__main__":
    print(run())
