"""Shared by ``bench_estimate_dask`` and ``bench_estimate_resume``: six copies of the bundled
video estimated serially and on two local Dask workers, once per process.

Not a benchmark itself (no ``bench_`` prefix): the two benchmarks load it under one name, so
that run by hand in one process, the first run (a minute or two on 2 cores) is made once and
timed by both. ``benchmarks/run.py`` gives each benchmark a process of its own, so there each
makes and times its own.
"""

from __future__ import annotations

import atexit
import importlib.util
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

N_COPIES = 6
N_WORKERS = 2
CLIP = (
    Path(__file__).resolve().parents[1].parent / "shared" / "data" / "video" / "sports2d_demo.mp4"
)
_CACHE: dict = {}


def shared():
    """This module as loaded once per process (``sys.modules``), whoever loads it first."""
    name = "turnbench_bench_estimate_corpus"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, Path(__file__))
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


def _clip() -> Path:
    env = os.environ.get("TURNBENCH_SHARED_DATA")
    return Path(env) / "video" / "sports2d_demo.mp4" if env else CLIP


def _jobs(videos: list[Path], out: Path):
    from turn_eval.estimate.batch import VideoJob

    return [VideoJob(v, out / f"{v.stem}.npz") for v in videos]


def first_runs() -> dict:
    """The corpus, the serial run and the 2-worker run (outputs checked equal), timed."""
    if _CACHE:
        return _CACHE
    from turn_eval.estimate.batch import estimate_videos
    from turn_eval.estimate.pipeline import EstimateParams

    tmp = Path(tempfile.mkdtemp(prefix="turnbench-bench-estimate-"))
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    videos = []
    for i in range(N_COPIES):
        videos.append(tmp / "videos" / f"home{i}.mp4")
        videos[-1].parent.mkdir(exist_ok=True)
        shutil.copy(_clip(), videos[-1])
    params = EstimateParams()
    serial_jobs, dask_jobs = _jobs(videos, tmp / "serial"), _jobs(videos, tmp / "dask")
    for jobs in (serial_jobs, dask_jobs):
        jobs[0].npz.parent.mkdir()
    t0 = time.perf_counter()
    serial = estimate_videos(serial_jobs, params=params)
    serial_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    on_workers = estimate_videos(dask_jobs, params=params, workers=N_WORKERS)
    dask_s = time.perf_counter() - t0  # the cluster's start-up included, as the command pays it
    for a, b in zip(serial_jobs, dask_jobs, strict=True):
        if a.npz.read_bytes() != b.npz.read_bytes():
            raise AssertionError(f"2 workers gave other skeletons than the serial run: {b.npz}")
    _CACHE.update(
        tmp=tmp,
        params=params,
        jobs=dask_jobs,
        serial_s=serial_s,
        dask_s=dask_s,
        serial=serial,
        dask=on_workers,
        frames=sum(v["frames"] for v in serial.videos),
    )
    return _CACHE
