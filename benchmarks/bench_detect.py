"""Detect turns in 20 hours of skeleton streams; time it as a ratio to ``np.load`` of the files.

The corpus is what home monitoring produces: 20 hours of 30 fps, 17-joint streams (float32,
camera axes, metres) in 120 files of 10 minutes, one person each, written as the project
writes streams (:func:`turn_datasets.fileio.write_npz`: a zip of
``.npy`` members, deflate level 1). It is made cheaply, once, and cached in the temporary
folder: eight 10-minute streams of :mod:`turn_datasets.synthetic.untrimmed` (turns, decoys,
swaps, dropouts, bystanders), each file one of them rotated about the vertical by its own
angle and shifted by its own whole number of seconds (so no two files hold the same
numbers, while every file is realistic motion).

Timed in the same process, as CPU time (other jobs on a shared machine count less; the
wall time is printed beside it), best of three:

baseline
    ``np.load`` of every file and every array in it: only getting the numbers.
serial
    :func:`turn_eval.detect.mapping.detect_files` with no cluster: read, detect, collect.
2 workers
    The same on a local Dask cluster of two single-threaded processes, started before the
    timing (its start-up, a few seconds once per run, is reported beside it) and given by
    address, as ``--scheduler`` would. Its time is the CPU seconds spent by the workers and
    this process together, divided by the two workers: the wall time on two idle cores (on
    a shared machine the workers get what the other jobs leave; that wall time is printed
    beside it).

Target (issue 13): at most 2x ``np.load`` with 2 workers. This file reports the serial run;
``bench_detect_dask.py`` the two workers (one row each in ``make bench``).

Run: ``python benchmarks/bench_detect.py`` (or ``make bench``).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from turn_datasets.fileio import write_npz
from turn_datasets.skeleton import H36M17
from turn_datasets.synthetic.untrimmed import write_untrimmed_corpus
from turn_eval.detect.mapping import detect_files
from turn_eval.detect.rule import MinerRule
from turn_eval.detect.streams import stream_files

HOURS = 20
FILE_MIN = 10
FPS_HZ = 30.0
CACHE_VERSION = "v1"


def corpus_dir() -> Path:
    """Generate (once) and return the cached folder of 120 stream files."""
    root = Path(tempfile.gettempdir()) / f"turnbench-bench-detect-{CACHE_VERSION}"
    n_files = HOURS * 60 // FILE_MIN
    files = root / "streams"
    if files.is_dir() and len(list(files.glob("*.npz"))) == n_files:
        return files
    write_untrimmed_corpus(root / "source", seed=7, n_pairs=4, duration_s=FILE_MIN * 60.0)
    sources = []
    for path in sorted((root / "source" / "streams").glob("*.npz")):
        with np.load(path) as archive:
            sources += [archive[k] for k in sorted(archive.files)]
    rng = np.random.default_rng(0)
    files.mkdir(parents=True, exist_ok=True)
    for i in range(n_files):
        src = sources[i % len(sources)]
        a = rng.uniform(-np.pi, np.pi)
        # camera axes: y is vertical, so a rotation about it mixes x and z
        rot = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
        shift = int(rng.integers(0, 60)) * int(FPS_HZ)
        arr = np.roll(src @ rot.T.astype(np.float32), shift, axis=0).astype(np.float32)
        write_npz(files / f"home{i:03d}.npz", {f"P{i:03d}": arr})
    return files


def load_all(files: list[Path]) -> int:
    """The baseline: every array of every file, as np.load gives it; returns the frames."""
    n = 0
    for path in files:
        with np.load(path) as archive:
            for key in archive.files:
                n += archive[key].shape[0]
    return n


def detect_all(files: list[Path], **kw) -> int:
    run = detect_files(
        files, detector=MinerRule(), layout=H36M17, up_axis="-y", fps_hz=FPS_HZ, **kw
    )
    return len(run.detections)


def best_of(fn, repeats: int = 3, clock=time.process_time) -> float:
    """Best of ``repeats`` runs of ``fn`` by ``clock`` (CPU time of this process by default:
    other work on a shared machine counts less, as in ``bench_miner.py``)."""
    times = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return min(times)


def run() -> dict:
    files = stream_files([corpus_dir()])
    n_frames = load_all(files)
    load_s = best_of(lambda: load_all(files))
    detect_s = best_of(lambda: detect_all(files), repeats=2)
    wall_s = best_of(lambda: detect_all(files), repeats=1, clock=time.perf_counter)
    n_turns = detect_all(files)
    return {
        "what": "detect turns in 10-min streams, serial (read + detect + collect)",
        "size": f"{len(files)} files, {n_frames / FPS_HZ / 3600:.0f} h, {n_frames:,} frames, "
        f"{n_turns} turns; {n_frames / detect_s:,.0f} frames per CPU second "
        f"({n_frames / wall_s:,.0f} per wall second)",
        "baseline": f"np.load of the same files ({n_frames / load_s:,.0f} frames/s)",
        "ratio": detect_s / load_s,
        "target": "<= 4",
        "seconds": detect_s,
    }


if __name__ == "__main__":
    print(run())
