"""Mine an H3.6M-sized synthetic corpus; time it as a ratio to ``np.load`` of the same arrays.

The corpus is what Human3.6M's 3-D poses are in VideoPose3D's ``data_3d_h36m.npz``: 7
subjects x 15 actions x 2 trials = 210 sequences of 4,000 frames (80 s at 50 Hz), 840,000
frames in all, 32 joints, float32 metres in a pickled, deflate-compressed dict. It is
generated once by :mod:`turn_datasets.synthetic.mocap` (walking, standing, pivot and walking
turns, noise, dropouts; fixed seeds) and cached in the temporary folder.

Timed in the same process, alternating, best of five each, as CPU time of this process (so
that other work on the machine counts less):

baseline
    ``np.load(path, allow_pickle=True)["positions_3d"].item()``: only getting the arrays.
measured
    The whole mining: :func:`turn_datasets.mocap.readers.read_source` (the same load, plus the
    reader's checks and float64 conversion, one sequence at a time),
    :func:`turn_datasets.h36m.miner.mine_clips` (the rule of
    :func:`turn_datasets.h36m.miner.mine_sequence`) and the clip index
    (:func:`turn_datasets.h36m.clip_index.build_index`).

The target is a ratio of at most 1.5 (issue 3).

Run: ``python benchmarks/bench_miner.py`` (or ``make bench``).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from turn_datasets.h36m.clip_index import build_index
from turn_datasets.h36m.miner import MinerParams, iter_clips
from turn_datasets.mocap.h36m import H36M_ACTIONS
from turn_datasets.mocap.readers import SourceFile, read_source
from turn_datasets.synthetic import mocap as sm
from turn_datasets.synthetic.h36m_files import write_videopose_npz

SUBJECTS = ("S1", "S5", "S6", "S7", "S8", "S9", "S11")
ACTIONS = H36M_ACTIONS
FRAMES_PER_SEQUENCE = 4000
FPS_HZ = 50.0
CACHE_VERSION = "v2"  # v2: issue 11 (pelvic rotation in turns in place, default sway)


def _segments(rng: np.random.Generator) -> list[sm.Segment]:
    """A random mix padded with standing to exactly FRAMES_PER_SEQUENCE frames."""
    total_s = FRAMES_PER_SEQUENCE / FPS_HZ
    segs = sm.random_segments(rng, n_turns=10)
    frames = sum(max(2, int(round(s.duration_s * FPS_HZ))) for s in segs)
    while frames > FRAMES_PER_SEQUENCE - 2:
        segs = segs[:-2] + [segs[-1]]
        frames = sum(max(2, int(round(s.duration_s * FPS_HZ))) for s in segs)
    pad_s = total_s - frames / FPS_HZ
    if pad_s > 0:
        segs.append(sm.Segment.stand(pad_s))
    return segs


def corpus_path() -> Path:
    """Generate (once) and return the cached corpus."""
    path = (
        Path(tempfile.gettempdir()) / f"turnbench-bench-miner-{CACHE_VERSION}" / "data_3d_h36m.npz"
    )
    if path.is_file():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    data: dict[str, dict[str, np.ndarray]] = {}
    seed = 0
    for subject in SUBJECTS:
        data[subject] = {}
        for action in ACTIONS:
            for trial in ("", " 1"):
                rng = np.random.default_rng(seed)
                segs = _segments(rng)
                seq = sm.generate_sequence(
                    seed=seed,
                    segments=segs,
                    fps_hz=FPS_HZ,
                    sway_deg=float(rng.uniform(3.0, 6.0)),
                    dropouts=sm.random_dropouts(rng, segs, fps_hz=FPS_HZ),
                )
                data[subject][action + trial] = seq.positions[:FRAMES_PER_SEQUENCE] / 1000.0
                seed += 1
    write_videopose_npz(path, data)
    return path


def _load(path: Path) -> dict:
    with np.load(path, allow_pickle=True) as archive:
        return archive["positions_3d"].item()


def _mine(path: Path):
    params = MinerParams()
    sequences = read_source(SourceFile(path, "videopose-npz"))
    return build_index(clips for _, clips in iter_clips(sequences, params))


def run(repeats: int = 5) -> dict:
    path = corpus_path()
    load_s, mine_s = [], []
    n_frames = sum(a.shape[0] for actions in _load(path).values() for a in actions.values())
    index = None
    for _ in range(repeats):
        t0 = time.process_time()
        _load(path)
        load_s.append(time.process_time() - t0)
        t0 = time.process_time()
        index = _mine(path)
        mine_s.append(time.process_time() - t0)
    n_sequences = len(SUBJECTS) * len(ACTIONS) * 2
    return {
        "what": "mine a synthetic H3.6M corpus (read + mine + index)",
        "size": f"{n_sequences} sequences, {n_frames:,} frames, {len(index)} clips",
        "baseline": "np.load of the same npz",
        "ratio": min(mine_s) / min(load_s),
        "target": 1.5,
        "seconds": min(mine_s),
    }


if __name__ == "__main__":
    print(run())
