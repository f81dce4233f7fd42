"""Estimate six copies of the bundled video on 2 local Dask workers against the serial run.

What is timed: :func:`turn_eval.estimate.batch.estimate_videos` (what ``turn-eval estimate
VIDEOS --out-dir DIR [--workers 2]`` runs: decoding, MediaPipe Pose, the time grid, the
identity guard, the levelling and writing each video's npz and manifest) over six copies of
``../shared/data/video/sports2d_demo.mp4`` (1768x994 VP9, 230 frames), first serially in
this process (the baseline), then on a local cluster of two single-threaded worker
processes, its start-up included. Wall time, since MediaPipe and ffmpeg run threads of their
own; the outputs are checked equal byte for byte. On a shared machine, note the load.

Target (issue 25): wall-time ratio <= 0.6 on 2 cores. Frames per second per worker are
reported beside it. Needs the ``video`` extra (``make bench`` runs it in ``.venv-video``).

Run: ``.venv-video/bin/python benchmarks/bench_estimate_dask.py``.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

REQUIRES = ("mediapipe",)


def _corpus():
    path = Path(__file__).with_name("estimate_corpus.py")
    spec = importlib.util.spec_from_file_location("turnbench_bench_estimate_corpus_loader", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.shared()


def run() -> dict:
    corpus = _corpus()
    r = corpus.first_runs()
    per_worker = [v["frames_per_s"] for v in r["dask"].videos]
    load = os.getloadavg()[0]
    return {
        "what": f"estimate {corpus.N_COPIES} videos on {corpus.N_WORKERS} Dask workers: "
        f"{sum(per_worker) / len(per_worker):.1f} frames/s per worker "
        f"(serial {r['frames'] / r['serial_s']:.1f}/s; load {load:.1f})",
        "size": f"{corpus.N_COPIES} x 230 frames at 1768x994 ({r['frames']} frames)",
        "baseline": f"the serial run ({r['serial_s']:.1f} s)",
        "seconds": r["dask_s"],
        "ratio": r["dask_s"] / r["serial_s"],
        "target": "<= 0.6",
    }


if __name__ == "__main__":
    print(run())
