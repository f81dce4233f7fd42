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

Beside it, on the same data: the clips' sparse bootstrap (:func:`turn_eval.clips.metrics.
grouped_bootstrap`) against the generic engine every scorer could use
(:func:`turn_eval.scoring.bootstrap.unit_bootstrap`, each clip a unit whose components are
1, its errors and one-hot reference, predicted and right bins, combined into the metrics),
both computing every metric of every group on the same draws, their results checked equal
first. The generic engine's per-unit sums are dense (clips x groups x components: 1.4 GB
for the 100,000 clips), so the two are timed on the first :data:`COMPARE_CLIPS` clips, all
five groupings, with the 1000 resamples; the row's text gives the generic engine's time
over the sparse path's (the sparse path is kept only while it is at least 1.2x faster).

Run: ``.venv/bin/python benchmarks/bench_score.py`` (``make bench`` runs every benchmark).
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.metrics import precision_score

from turn_datasets.fileio import to_json_text
from turn_datasets.geometry import quantise_deg
from turn_eval.clips.metrics import ClipOutcomes, Partition, grouped_bootstrap, wprec_from_counts
from turn_eval.clips.submission import read_predictions, read_reference
from turn_eval.clips.tables import (
    build_scores,
    outcomes_of,
    partitions_of,
    scores_frame,
    scores_markdown,
)
from turn_eval.scoring.bootstrap import resample_indices, unit_bootstrap, unit_sums

N_CLIPS = 100_000
N_RESAMPLES = 1000
GROUPINGS = ("scenario", "location", "cohort", "subject", "bin_deg")
# Best of several runs, for the baseline and the scoring alike (see the module docstring).
BASELINE_REPEATS = 7
SCORE_REPEATS = 3
#: Clips of the sparse-versus-generic comparison (the generic engine's sums are dense).
COMPARE_CLIPS = 10_000
COMPARE_REPEATS = 3


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


def clip_components(outcomes: ClipOutcomes) -> tuple[np.ndarray, Callable]:
    """The clip metrics in the generic engine's model: per clip, the components ``1``,
    ``|angle error|``, (``|speed error|``, has a speed error), then one-hot reference bin,
    predicted bin and right bin; and the function combining their sums into ``n`` and the
    metrics (:func:`turn_eval.clips.metrics.wprec_from_counts` for WPrec)."""
    k, n = int(outcomes.bins_deg.shape[0]), outcomes.n
    columns = [np.ones(n), outcomes.abs_error_deg]
    speed = outcomes.abs_error_speed_deg_s
    if speed is not None:
        ok = np.isfinite(speed)
        columns += [np.where(ok, speed, 0.0), ok.astype(np.float64)]
    at = len(columns)
    one_hot = np.eye(k)
    right = (outcomes.ref_bin == outcomes.pred_bin).astype(np.float64)[:, None]
    ref_bins = one_hot[outcomes.ref_bin]
    values = np.column_stack([*columns, ref_bins, one_hot[outcomes.pred_bin], ref_bins * right])

    def combine(sums: np.ndarray) -> dict[str, np.ndarray]:
        n_drawn = sums[..., 0]
        true, predicted = sums[..., at : at + k], sums[..., at + k : at + 2 * k]
        true_right = sums[..., at + 2 * k : at + 3 * k]
        with np.errstate(divide="ignore", invalid="ignore"):
            out = {
                "n": n_drawn,
                "accuracy": true_right.sum(axis=-1) / n_drawn,
                "mae_deg": sums[..., 1] / n_drawn,
                "wprec": wprec_from_counts(true, predicted, true_right),
            }
            if speed is not None:
                out["mae_speed_deg_s"] = sums[..., 2] / sums[..., 3]
        return out

    return values, combine


def generic_bootstrap(
    outcomes: ClipOutcomes, partitions: Sequence[Partition], chunks: Sequence[np.ndarray]
) -> list[dict[str, np.ndarray]]:
    """:func:`turn_eval.clips.metrics.grouped_bootstrap` through the generic engine."""
    values, combine = clip_components(outcomes)
    unit = np.arange(outcomes.n)
    sums = {p.name: unit_sums(unit, p.codes, values, outcomes.n, len(p.labels)) for p in partitions}
    result = unit_bootstrap(sums, combine, indices=chunks)
    return [result[p.name] for p in partitions]


def sparse_over_generic(
    outcomes: ClipOutcomes,
    partitions: Sequence[Partition],
    *,
    n_resamples: int,
    repeats: int = COMPARE_REPEATS,
) -> float:
    """The generic engine's CPU time over the sparse path's on the same draws (best of
    ``repeats`` each), after checking that they give the same numbers."""
    chunks = list(resample_indices(outcomes.n, n_resamples=n_resamples, seed=0))
    sparse = grouped_bootstrap(outcomes, partitions, indices=chunks)
    generic = generic_bootstrap(outcomes, partitions, chunks)
    for p, a, b in zip(partitions, sparse, generic, strict=True):
        for name in a:
            if not np.allclose(a[name], b[name], rtol=1e-9, atol=0.0, equal_nan=True):
                raise AssertionError(f"the engines differ on {p.name} {name}")
    times = {}
    for name, fn in (
        ("sparse", lambda: grouped_bootstrap(outcomes, partitions, indices=chunks)),
        ("generic", lambda: generic_bootstrap(outcomes, partitions, chunks)),
    ):
        best = np.inf
        for _ in range(repeats):
            start = time.process_time()
            fn()
            best = min(best, time.process_time() - start)
        times[name] = best
    return times["generic"] / times["sparse"]


def _first_clips(
    outcomes: ClipOutcomes, partitions: Sequence[Partition], n: int
) -> tuple[ClipOutcomes, list[Partition]]:
    speed = outcomes.abs_error_speed_deg_s
    head = replace(
        outcomes,
        ref_bin=outcomes.ref_bin[:n],
        pred_bin=outcomes.pred_bin[:n],
        abs_error_deg=outcomes.abs_error_deg[:n],
        abs_error_speed_deg_s=None if speed is None else speed[:n],
    )
    return head, [Partition(p.name, p.labels, p.codes[:n]) for p in partitions]


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
        joined = read_predictions(pred_path, read_reference(ref_path))
    outcomes = outcomes_of(joined)
    head = _first_clips(outcomes, partitions_of(joined, GROUPINGS), COMPARE_CLIPS)
    engines = sparse_over_generic(*head, n_resamples=N_RESAMPLES)
    n_groups = sum(len(block["groups"]) for block in scores["by"].values())
    return {
        "what": "turn-eval score: read, validate, metrics, 1000-resample bootstrap CIs, tables"
        f" (the sparse clip bootstrap {engines:.1f}x faster than the generic engine on the "
        f"same draws, {COMPARE_CLIPS:,} clips)",
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
