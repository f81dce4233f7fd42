"""The miner's synthetic test sets: sequences with planted turns, scored by
:mod:`turn_datasets.h36m.evaluation`.

The turns are planted by :mod:`turn_datasets.synthetic.mocap`, in two sets:

easy
    turns of 45 to 160 °/s mean speed, 3 to 5° peak-to-peak pelvic sway, 10 mm joint noise;
hard
    slow turns of 25 to 60 °/s, 6 to 8° sway, 20 mm noise, NaN dropouts (short ones anywhere,
    a long one in a straight stretch);

each minable in the three Human3.6M layouts (the 32 joints in millimetres, the 17-joint
subset in millimetres, and the 17 joints in metres as VideoPose3D stores them).

The matching and the scores are :mod:`turn_datasets.h36m.evaluation`'s.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from types import MappingProxyType
from typing import TypedDict

import numpy as np

from turn_datasets.h36m.evaluation import KnownTurns, score_sequences
from turn_datasets.h36m.miner import MinerParams
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, H36M32, Layout
from turn_datasets.synthetic import mocap as sm

__all__ = ["SETS", "LAYOUTS", "synthetic", "in_layout", "score"]


class SyntheticSet(TypedDict):
    """A synthetic set: turn speed range (°/s), sway range (peak to peak, °), joint noise
    (mm), and whether capture dropouts are planted."""

    speed: tuple[float, float]
    sway: tuple[float, float]
    noise_mm: float
    dropouts: bool


#: The synthetic sets: turn speed range (°/s), sway range (peak to peak, °), noise.
SETS: Mapping[str, SyntheticSet] = MappingProxyType(
    {
        "easy": {"speed": (45.0, 160.0), "sway": (3.0, 5.0), "noise_mm": 10.0, "dropouts": False},
        "hard": {"speed": (25.0, 60.0), "sway": (6.0, 8.0), "noise_mm": 20.0, "dropouts": True},
    }
)
#: The three ways Human3.6M's poses are stored.
LAYOUTS = ("h36m32-mm", "h36m17-mm", "h36m17-m")


def synthetic(set_name: str, seed: int) -> sm.SyntheticSequence:
    """One sequence of a set (eight planted turns), drawn from ``seed``."""
    cfg = SETS[set_name]
    rng = np.random.default_rng(seed)
    segs = sm.random_segments(rng, turn_speed_range_deg_s=cfg["speed"])
    drops = sm.random_dropouts(rng, segs) if cfg["dropouts"] else []
    return sm.generate_sequence(
        seed=seed,
        segments=segs,
        sway_deg=float(rng.uniform(*cfg["sway"])),
        noise_mm=cfg["noise_mm"],
        dropouts=drops,
    )


def in_layout(seq: sm.SyntheticSequence, layout: str) -> tuple[np.ndarray, Layout]:
    """The sequence's positions in one of :data:`LAYOUTS`."""
    if layout == "h36m32-mm":
        return seq.positions, H36M32
    j17 = seq.positions[:, list(H36M17_FROM_32)]
    return (j17, H36M17) if layout == "h36m17-mm" else (j17 / 1000.0, H36M17)


def score(
    set_name: str, layout: str, seeds: Iterable[int], params: MinerParams | None = None
) -> dict:
    """The miner on one set and layout (:func:`turn_datasets.h36m.evaluation.score_sequences`
    on :func:`synthetic` sequences of ``seeds`` in ``layout``), with ``set`` and ``layout``."""

    def cases() -> Iterator[KnownTurns]:
        for seed in seeds:
            seq = synthetic(set_name, seed)
            positions, lay = in_layout(seq, layout)
            yield KnownTurns(seed, positions, lay, seq.fps, seq.planted)

    return {"set": set_name, "layout": layout, **score_sequences(cases(), params)}
