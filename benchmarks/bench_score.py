"""Time ``turn-eval score`` on 100,000 predictions against one scikit-learn pass.

What is timed: reading and validating a 100,000-row reference and submission from CSV, the
metrics overall and in five groupings (scenario, location, cohort, subject, bin_deg: 43
groups), a 1000-resample percentile bootstrap of every metric overall and in every group,
and the JSON, Markdown and CSV renderings: everything ``turn-eval score --format json`` does
but the process start. The baseline is one call of scikit-learn's ``precision_score`` (the
paper's WPrec) on the same 100,000 binned rows, timed in the same process after a warm-up
call. Both are CPU time of this process (``time.process_time``: on a machine shared with
other work, the time the process was not running is not its cost; on an idle machine it
equals the wall time, as everything here runs on one thread) and the best of several runs
(seven calls of the baseline, three scorings). The ratio is scoring time over baseline;
``seconds`` is the scoring's wall time.

Issue 5's target: the whole scoring in under 200 such passes.

Run: ``.venv/bin/python benchmarks/bench_score.py`` (``make bench`` runs every benchmark).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.metrics import precision_score

from turn_datasets.fileio import to_json_text
from turn_datasets.geometry import quantise_deg
from turn_eval.clips.submission import read_predictions, read_reference
from turn_eval.clips.tables import build_scores, scores_frame, scores_markdown

N_CLIPS = 100_000
N_RESAMPLES = 1000
GROUPINGS = ("scenario", "location", "cohort", "subject", "bin_deg")
# Best of several runs, for the baseline and the scoring alike (see the module docstring).
BASELINE_REPEATS = 7
SCORE_REPEATS = 3


def _write_inputs(folder: Path, *, seed: int = 7) -> tuple[Path, Path]:
    """A Turn-REMAP-like reference and a noisy submission of ``N_CLIPS`` clips."""
    rng = np.random.default_rng(seed)
    subjects = np.array([f"P{i:02d}" for i in range(1, 25)])
    subject = subjects[rng.integers(0, 24, N_CLIPS)]
    cohort = np.where(np.isin(subject, subjects[:12]), "PD", "HC")
    scenario = np.array(["scripted", "clinical", "free-living"])[rng.integers(0, 3, N_CLIPS)]
    rooms = np.array(["kitchen", "lounge", "hallway", "bedroom", "dining", "stairs"])
    location = rooms[rng.integers(0, 6, N_CLIPS)]
    angle = rng.uniform(45.0, 360.0, N_CLIPS).round(2)
    duration = rng.uniform(0.8, 6.0, N_CLIPS).round(3)
    reference = pd.DataFrame(
        {
            "clip_id": [f"clip{i:06d}" for i in range(N_CLIPS)],
            "subject": subject,
            "cohort": cohort,
            "duration_s": duration,
            "angle_deg": angle,
            "scenario": scenario,
            "location": location,
        }
    )
    predicted = np.abs(angle + rng.normal(0.0, 30.0, N_CLIPS)).round(2)
    predictions = pd.DataFrame(
        {"clip_id": reference["clip_id"].to_numpy()[::-1], "angle_deg": predicted[::-1]}
    )
    ref_path = folder / "reference.csv"
    pred_path = folder / "predictions.csv"
    reference.to_csv(ref_path, index=False)
    predictions.to_csv(pred_path, index=False)
    return ref_path, pred_path


def _score(ref_path: Path, pred_path: Path) -> dict:
    reference = read_reference(ref_path)
    joined = read_predictions(pred_path, reference)
    scores = build_scores(joined, by=GROUPINGS, n_resamples=N_RESAMPLES, seed=0)
    to_json_text(scores)
    scores_markdown(scores)
    scores_frame(scores).to_csv(index=False)
    return scores


def _baseline_s(ref_path: Path, pred_path: Path) -> float:
    ref = pd.read_csv(ref_path)
    pred = pd.read_csv(pred_path).set_index("clip_id").loc[ref["clip_id"], "angle_deg"]
    ref_bins = quantise_deg(ref["angle_deg"].to_numpy())
    pred_bins = quantise_deg(pred.to_numpy())
    precision_score(ref_bins, pred_bins, average="weighted", zero_division=0)  # warm-up
    times = []
    for _ in range(BASELINE_REPEATS):
        start = time.process_time()
        precision_score(ref_bins, pred_bins, average="weighted", zero_division=0)
        times.append(time.process_time() - start)
    return min(times)


def run() -> dict:
    """Score 100,000 predictions in five groupings with 1000 resamples; ratio to one pass."""
    with tempfile.TemporaryDirectory() as tmp:
        ref_path, pred_path = _write_inputs(Path(tmp))
        baseline = _baseline_s(ref_path, pred_path)
        cpu, wall = [], []
        for _ in range(SCORE_REPEATS):
            start_cpu, start_wall = time.process_time(), time.perf_counter()
            scores = _score(ref_path, pred_path)
            cpu.append(time.process_time() - start_cpu)
            wall.append(time.perf_counter() - start_wall)
    n_groups = sum(len(block["groups"]) for block in scores["by"].values())
    return {
        "what": "turn-eval score: read, validate, metrics, 1000-resample bootstrap CIs, tables",
        "size": f"{N_CLIPS:,} predictions, {len(GROUPINGS)} groupings ({n_groups} groups)",
        "baseline": "one sklearn precision_score pass over the same rows",
        "ratio": min(cpu) / baseline,
        "target": 200,
        "seconds": min(wall),
    }


if __name__ == "__main__":
    result = run()
    for key, value in result.items():
        print(f"{key}: {value}")
