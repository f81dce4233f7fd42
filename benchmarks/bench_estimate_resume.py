"""``turn-eval estimate --resume`` over finished outputs against the first run's time.

What is timed: :func:`turn_eval.estimate.batch.estimate_videos` with ``resume=True`` over the
six videos whose outputs the 2-worker run of ``bench_estimate_dask`` wrote (shared through
``estimate_corpus``: made once per process): every video is hashed, its manifest read and its
npz hashed, and all are skipped. The baseline is that first run's wall time.

Target (issue 25): <= 0.05 (5% of the first run). Needs the ``video`` extra.

Run: ``.venv-video/bin/python benchmarks/bench_estimate_resume.py``.
"""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path

REQUIRES = ("mediapipe",)


def _corpus():
    path = Path(__file__).with_name("estimate_corpus.py")
    spec = importlib.util.spec_from_file_location("turnbench_bench_estimate_corpus_loader", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.shared()


def run() -> dict:
    from turn_eval.estimate.batch import estimate_videos

    corpus = _corpus()
    r = corpus.first_runs()
    t0 = time.perf_counter()
    again = estimate_videos(r["jobs"], params=r["params"], resume=True)
    resume_s = time.perf_counter() - t0
    if {v["status"] for v in again.videos} != {"resumed"}:
        raise AssertionError("--resume redid finished videos")
    return {
        "what": "estimate --resume over 6 finished videos (all skipped)",
        "size": f"{corpus.N_COPIES} videos, {r['frames']} frames",
        "baseline": f"the first run on {corpus.N_WORKERS} workers ({r['dask_s']:.1f} s)",
        "seconds": resume_s,
        "ratio": resume_s / r["dask_s"],
        "target": "<= 0.05",
    }


if __name__ == "__main__":
    print(run())
