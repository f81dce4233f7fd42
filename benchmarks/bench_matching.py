"""Time the matching of two raters' turns (``remap labels`` / ``agreement``) on 10,000 each.

What is timed: :func:`turn_datasets.remap.matching.match_annotations` linking two raters'
10,000 turn annotations of one participant (the rule of ELAN's reliability check: overlap /
longer duration >= 0.6, greedy by ratio). It sweeps start-sorted intervals, so only
overlapping pairs are candidates: before, every annotation was paired with every other of
its participant, 10^8 candidate rows here (11 GB, 19-33 s). The baseline is reading the same
session's ELAN file with pympi-ling (``pympi.Elan.Eaf``), timed in the same process. Both are
CPU time (``time.process_time``) and the best of three runs. The ratio is matching over
reading: linear matching costs less than reading the file it came from.

``size`` also gives the time per annotation at 10,000 over that at 2,000 per rater: about 1
for linear work, 5 for the old quadratic pairing.

Run: ``.venv/bin/python benchmarks/bench_matching.py`` (``make bench`` runs every benchmark).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import pympi.Elan

from turn_datasets.remap.eaf import read_annotations
from turn_datasets.remap.matching import match_annotations

N_PER_RATER = 10_000
N_SMALL = 2_000
REPEATS = 3


def _write_session(path: Path, n: int, *, seed: int = 3) -> Path:
    """One participant, two raters, ``n`` turns each; rater B's boundaries jittered."""
    rng = np.random.default_rng(seed)
    eaf = pympi.Elan.Eaf()
    eaf.remove_tier("default")
    eaf.add_linguistic_type("turn")
    for rater in ("alice", "bob"):
        eaf.add_tier(f"Turn {rater}", ling="turn", part="PD01", ann=rater)
    starts = np.arange(n) * 5000
    jitter = rng.integers(-300, 300, n)
    for i in range(n):
        eaf.add_annotation("Turn alice", int(starts[i]), int(starts[i] + 2000), "90")
        s = int(starts[i] + jitter[i])
        eaf.add_annotation("Turn bob", s, s + 2000, "90")
    pympi.Elan.to_eaf(str(path), eaf)
    return path


def _best(fn) -> float:
    times = []
    for _ in range(REPEATS):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return min(times)


def _match_time(path: Path) -> tuple[float, int]:
    rows = read_annotations(path)
    a = rows[rows["annotator"] == "alice"]
    b = rows[rows["annotator"] == "bob"]
    links = match_annotations(a, b, min_overlap=0.6)
    return _best(lambda: match_annotations(a, b, min_overlap=0.6)), len(links)


def run() -> dict:
    """Match 10,000 turns per rater; ratio to reading the ELAN file with pympi-ling."""
    with tempfile.TemporaryDirectory() as tmp:
        big = _write_session(Path(tmp) / "big.eaf", N_PER_RATER)
        small = _write_session(Path(tmp) / "small.eaf", N_SMALL)
        baseline = _best(lambda: pympi.Elan.Eaf(str(big)))
        seconds, n_links = _match_time(big)
        small_seconds, _ = _match_time(small)
    growth = (seconds / N_PER_RATER) / (small_seconds / N_SMALL)
    return {
        "what": "match two raters' turns (sweep over sorted intervals)",
        "size": f"{N_PER_RATER:,} per rater, {n_links:,} links; per-annotation time "
        f"at {N_PER_RATER:,} / at {N_SMALL:,}: {growth:.2f}",
        "baseline": "pympi.Elan.Eaf reading the same session file",
        "ratio": seconds / baseline,
        "target": 1.0,
        "seconds": seconds,
    }


if __name__ == "__main__":
    result = run()
    for key, value in result.items():
        print(f"{key}: {value}")
