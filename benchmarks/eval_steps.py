"""Steps and turn type of ``turn-eval detect`` on synthetic untrimmed sessions with footsteps.

Each seed writes a corpus of :func:`turn_datasets.synthetic.untrimmed.write_untrimmed_corpus`
with planted footsteps (pivot turns of 1-2 steps, step turns of 3-7, PD more), as a monocular
estimator would hand it over (depth error, jitter, dropouts, swaps: the corpus's own
artefacts), runs the built-in detector (``min_turn_deg`` 67.5, as ``eval_detect.py``) and
matches each labelled turn to the detection of the same person with the largest temporal IoU
(at least 0.5). On the matched turns: the share within one step of the planted count, the
share exactly right, the share of the right turn type, and per cohort the mean planted and
measured steps. The sessions are ``eval_detect.py``'s, with its two options: ``--plain``
leaves out the movements of real life, ``--white-depth-mm`` sets the estimator's white
depth error per joint (0 turns it off; the ankles' speed is then no longer noise).

Run: ``python benchmarks/eval_steps.py [--seeds 1 2 3] [--pairs 8] [--duration 600] [--plain]
[--white-depth-mm 30]``; prints a Markdown table.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from turn_datasets.render.markdown import markdown_table
from turn_datasets.skeleton import H36M17
from turn_datasets.synthetic.untrimmed import (
    REAL_MOVEMENT,
    ArtefactParams,
    MovementMix,
    write_untrimmed_corpus,
)
from turn_eval.detect import DetectParams, MinerRule, detect_files, stream_files
from turn_eval.detect.rule import DETECT_MINER_DEFAULTS

FPS_HZ = 30.0
MIN_TURN_DEG = 67.5


def matched(labels: pd.DataFrame, detections: pd.DataFrame, iou: float = 0.5) -> pd.DataFrame:
    """Each label with the detection of its person that overlaps it most (IoU >= ``iou``)."""
    rows = []
    for (session, subject), mine in labels.groupby(["session", "subject"]):
        det = detections[(detections["session"] == session) & (detections["subject"] == subject)]
        ds, de = det["start_s"].to_numpy(), det["end_s"].to_numpy()
        for row in mine.itertuples(index=False):
            inter = np.clip(np.minimum(de, row.end_s) - np.maximum(ds, row.start_s), 0, None)
            union = np.maximum(de, row.end_s) - np.minimum(ds, row.start_s)
            score = inter / union if len(det) else np.array([])
            if score.size and score.max() >= iou:
                best = det.iloc[int(np.argmax(score))]
                rows.append(
                    {
                        "cohort": row.cohort,
                        "planted_steps": row.steps,
                        "steps": best["steps"],
                        "planted_type": row.turn_type,
                        "turn_type": best["turn_type"],
                    }
                )
    return pd.DataFrame(rows)


def figures(pairs: pd.DataFrame, seed: int, group: str) -> dict:
    diff = pairs["steps"].to_numpy(float) - pairs["planted_steps"].to_numpy(float)
    return {
        "seed": seed,
        "group": group,
        "matched": len(pairs),
        "within 1 step": float(np.mean(np.abs(diff) <= 1)),
        "exact": float(np.mean(diff == 0)),
        "steps MAE": float(np.mean(np.abs(diff))),
        "type accuracy": float(np.mean(pairs["turn_type"] == pairs["planted_type"])),
        "planted mean steps": float(pairs["planted_steps"].mean()),
        "measured mean steps": float(pairs["steps"].mean()),
    }


def evaluate(
    seed: int,
    root: Path,
    *,
    n_pairs: int = 8,
    duration_s: float = 600.0,
    movement: MovementMix = REAL_MOVEMENT,
    artefacts: ArtefactParams | None = None,
) -> list[dict]:
    corpus = root / f"seed{seed}"
    write_untrimmed_corpus(
        corpus,
        seed=seed,
        n_pairs=n_pairs,
        duration_s=duration_s,
        footsteps=True,
        movement=movement,
        artefacts=artefacts or ArtefactParams(),
    )
    files = stream_files([corpus / "streams"])
    rule = MinerRule(DetectParams(miner=replace(DETECT_MINER_DEFAULTS, min_turn_deg=MIN_TURN_DEG)))
    detected = detect_files(files, detector=rule, layout=H36M17, up_axis="-y", fps_hz=FPS_HZ)
    pairs = matched(pd.read_csv(corpus / "labels.csv"), detected.detections)
    out = [figures(pairs, seed, "overall")]
    out += [figures(g, seed, str(c)) for c, g in pairs.groupby("cohort", sort=False)]
    return out


def _eval_detect():
    """``eval_detect.py`` beside this file (benchmarks/ is not a package): its sessions'
    options are declared there once."""
    spec = importlib.util.spec_from_file_location(
        "turnbench_eval_detect", Path(__file__).with_name("eval_detect.py")
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--pairs", type=int, default=8)
    parser.add_argument("--duration", type=float, default=600.0)
    eval_detect = _eval_detect()
    eval_detect.add_session_options(parser)
    args = parser.parse_args()
    movement, artefacts = eval_detect.session_settings(args)
    with tempfile.TemporaryDirectory() as tmp:
        rows = [
            r
            for seed in args.seeds
            for r in evaluate(
                seed,
                Path(tmp),
                n_pairs=args.pairs,
                duration_s=args.duration,
                movement=movement,
                artefacts=artefacts,
            )
        ]
    header = list(rows[0])
    cells = [[f"{v:.3f}" if isinstance(v, float) else v for v in r.values()] for r in rows]
    print("\n".join(markdown_table(header, cells)))


if __name__ == "__main__":
    main()
