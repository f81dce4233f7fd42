"""Time reading a REMAP Open release (``turn-datasets remap open``) against ``np.loadtxt``.

What is timed: :func:`turn_datasets.remap.open_release.read_release` on a synthetic tree in
the release's layout (:func:`turn_datasets.synthetic.remap_open.write_remap_open`: 300
turns, a CSV rater spreadsheet, one 2D and one 3D keypoint CSV per turn): finding the two
data folders, reading and checking the spreadsheet, reading and checking every keypoint
file (field counts, numbers, finite values, at least two frames), the sha256 of every input
and the vertical axis of every clip (``--up-axis auto``). The baseline is NumPy's own
``np.loadtxt`` of the same 600 keypoint files with no check at all, in the same process.
Both are CPU time (``time.process_time``: the machine is shared) and the best of three.
The ratio is reading over loading: what the checks, the hashes and the axis cost on top of
parsing the numbers.

Target: at most 2 (measured 1.46 to 1.55 here on 2026-11-26; 1.04 when the benchmark came:
the keypoint reader parses with NumPy's own C parser and falls back to a row-by-row check only
to name the bad row of a damaged file).

Run: ``.venv/bin/python benchmarks/bench_remap_open.py`` (``make bench`` runs every benchmark).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from turn_datasets.remap.open_release import read_release
from turn_datasets.synthetic.remap_open import write_remap_open

N_PARTICIPANTS = 10  # 5 PD + 5 controls
TURNS_EACH = 30
REPEATS = 3


def _best(fn) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


def run() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        write_remap_open(
            root,
            n_pd=N_PARTICIPANTS // 2,
            n_hc=N_PARTICIPANTS // 2,
            turns_per_participant=TURNS_EACH,
        )
        files = sorted(root.rglob("keypoints.csv"))
        n_turns = N_PARTICIPANTS * TURNS_EACH
        assert len(files) == 2 * n_turns

        def baseline() -> None:
            for f in files:
                np.loadtxt(f, delimiter=",", dtype=np.float64)

        release = read_release(root)  # warm-up, and the size
        frames = sum(a.shape[0] for a in release.skeletons.values())
        base = _best(baseline)
        t0 = time.perf_counter()
        measured = _best(lambda: read_release(root))
        wall = (time.perf_counter() - t0) / REPEATS
    return {
        "what": "remap open: read and check a REMAP Open tree",
        "size": f"{n_turns} turns, {2 * n_turns} keypoint files, {frames:,} frames",
        "baseline": "np.loadtxt of the same keypoint files",
        "seconds": round(wall, 3),
        "ratio": measured / base,
        "target": "<= 2",
    }


if __name__ == "__main__":
    print(run())
