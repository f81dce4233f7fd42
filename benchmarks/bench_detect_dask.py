"""Detect turns in 20 hours of streams on 2 Dask workers; ratio to ``np.load`` of the files.

The corpus, the baseline and the detection are :mod:`bench_detect`'s (same folder, loaded by
path); here :func:`turn_eval.detect.mapping.detect_files` runs on a local cluster of two
single-threaded worker processes, started before the timing and given by address (as
``turn-eval detect --scheduler`` would), so the figure is the mapping's throughput; the
cluster's start-up, paid once per ``--workers`` run, is reported beside it. The time is the
CPU seconds of the two workers and this process divided by two: what two idle cores take
(the wall time on the shared machine is printed beside it). The output is checked equal,
row for row, to the serial run's.

Target (issue 13): at most 2x ``np.load`` of the same files.

Run: ``python benchmarks/bench_detect_dask.py`` (or ``make bench``).
"""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path

from turn_datasets.skeleton import H36M17
from turn_eval.detect.mapping import detect_files, local_cluster
from turn_eval.detect.rule import MinerRule
from turn_eval.detect.streams import stream_files


def _bench_detect():
    path = Path(__file__).with_name("bench_detect.py")
    spec = importlib.util.spec_from_file_location("turnbench_bench_detect_shared", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def run() -> dict:
    from dask.distributed import Client

    shared = _bench_detect()
    files = stream_files([shared.corpus_dir()])
    n_frames = shared.load_all(files)
    load_s = shared.best_of(lambda: shared.load_all(files))
    t0 = time.perf_counter()
    cluster = local_cluster(2)  # as `turn-eval detect --workers 2` starts it
    start_s = time.perf_counter() - t0
    client = Client(cluster)
    kw = {"detector": MinerRule(), "layout": H36M17, "up_axis": "-y", "fps_hz": shared.FPS_HZ}
    try:
        on_cluster = detect_files(files, scheduler=cluster.scheduler_address, **kw)
        cpu, wall = [], []
        for _ in range(2):
            before = sum(client.run(time.process_time).values()) + time.process_time()
            t0 = time.perf_counter()
            detect_files(files, scheduler=cluster.scheduler_address, **kw)
            wall.append(time.perf_counter() - t0)
            after = sum(client.run(time.process_time).values()) + time.process_time()
            cpu.append((after - before) / 2)  # spread over the two workers
    finally:
        client.close()
        cluster.close()
    dask_s, wall_s = min(cpu), min(wall)
    serial = detect_files(files, **kw)
    if not serial.detections.equals(on_cluster.detections):
        raise AssertionError("2 workers gave other detections than the serial run")
    return {
        "what": "detect turns in 10-min streams on 2 local Dask workers",
        "size": f"{len(files)} files, {n_frames / shared.FPS_HZ / 3600:.0f} h, {n_frames:,} frames; "
        f"{n_frames / dask_s:,.0f} frames per second of 2 workers' CPU "
        f"({n_frames / wall_s:,.0f} per wall second here); cluster start-up {start_s:.1f} s",
        "baseline": f"np.load of the same files ({n_frames / load_s:,.0f} frames/s)",
        "ratio": dask_s / load_s,
        "target": 2,
        "seconds": dask_s,
    }


if __name__ == "__main__":
    print(run())
