"""How ``turn-eval detect`` does per kind of movement, and what each part of it contributes.

Each seed writes a corpus of :func:`turn_datasets.synthetic.untrimmed.write_untrimmed_corpus`
(16 participant-sessions of 10 minutes at 30 fps, estimator noise with white depth error along
the camera ray), whose ``planted.csv`` names each labelled turn's movement: ``pivot`` (on the
spot), ``walking`` (walking on), ``curved`` (a slow turn along a curve), ``quick`` (within a
second of the previous turn, same or opposite way), ``to_sit`` (a pivot that ends seated); and
``circling`` episodes (12-25 s round a loop, never a turn). The built-in detector runs whole
and with one part of it switched off at a time:

- ``identity``: no split where the skeleton jumps to someone else;
- ``swaps``: left/right swaps not undone;
- ``shoulders``: the hips' frontal vector alone;
- ``depth model``: the plain direction of the pairs, every error taken alike
  (:mod:`turn_eval.detect.heading` off: ``ray_noise_ratio`` 1, ``ray_search_deg`` 0);
- ``noise rays``: root-relative streams' camera ray taken as straight ahead, not read from
  their jitter (:func:`turn_eval.detect.heading.noise_rays`);
- ``pauses``: continuous turning not split at its pauses (``pause_speed_deg_s`` 0);
- ``bounds``: no circling or speed bound (``max_turn_s`` and ``max_turn_speed_deg_s`` lifted).

Reported per variant: F1 at IoU 0.3 and 0.5 (one-to-one matching, :mod:`turn_eval.events.
matching`), recall per movement at IoU 0.5, detections overlapping a circling episode, the
longest detection and the detections faster than the human bound
(:data:`turn_datasets.limits.MAX_TURN_MEAN_SPEED_DEG_S`).

Run: ``python benchmarks/eval_movement.py [--seeds 1 2 3]``; prints Markdown tables.
"""

from __future__ import annotations

import argparse
import tempfile
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd

from turn_datasets import limits
from turn_datasets.render.markdown import markdown_table
from turn_datasets.skeleton import H36M17
from turn_datasets.synthetic.untrimmed import write_untrimmed_corpus
from turn_eval.detect import DetectParams, MinerRule, detect_files, stream_files
from turn_eval.detect.heading import camera_rays
from turn_eval.detect.rule import DETECT_MINER_DEFAULTS
from turn_eval.events.matching import categorize_events

FPS_HZ = 30.0
MIN_TURN_DEG = 67.5
MOVEMENTS = ("pivot", "walking", "curved", "quick", "to_sit")


def _variants() -> dict[str, tuple[DetectParams, list]]:
    miner = replace(DETECT_MINER_DEFAULTS, min_turn_deg=MIN_TURN_DEG)
    full = DetectParams(miner=miner)

    def whole(positions, layout, usable, **_):
        idx = np.flatnonzero(usable)
        return [(int(idx[0]), int(idx[-1]) + 1)] if idx.size >= 2 else []

    return {
        "full": (full, []),
        "no identity": (full, [mock.patch("turn_eval.detect.rule.identity_pieces", whole)]),
        "no swaps": (
            full,
            [mock.patch("turn_eval.detect.rule.repair_swaps", lambda p, *a, **k: (p, 0))],
        ),
        "no shoulders": (replace(full, joints=("hip",)), []),
        "no depth model": (replace(full, ray_noise_ratio=1.0, ray_search_deg=0.0), []),
        "no noise rays": (
            full,
            [mock.patch("turn_eval.detect.rule.camera_rays", lambda m, w, *_: camera_rays(m, w))],
        ),
        "no pauses": (DetectParams(miner=replace(miner, pause_speed_deg_s=0.0)), []),
        "no bounds": (
            DetectParams(
                miner=replace(
                    miner,
                    max_turn_s=limits.MAX_DURATION_S,
                    max_turn_speed_deg_s=limits.MAX_SPEED_DEG_S,
                )
            ),
            [],
        ),
    }


def _units(frames: list[pd.DataFrame]) -> list[np.ndarray]:
    keys = pd.concat([f[["session", "subject"]] for f in frames], ignore_index=True)
    codes = pd.MultiIndex.from_frame(keys).factorize()[0]
    out, at = [], 0
    for f in frames:
        out.append(codes[at : at + len(f)])
        at += len(f)
    return out


def _sorted(frame: pd.DataFrame) -> pd.DataFrame:
    return frame.sort_values(["session", "subject", "start_s"], kind="stable").reset_index(
        drop=True
    )


def score(det: pd.DataFrame, planted: pd.DataFrame) -> dict[str, object]:
    ref = _sorted(planted[planted.kind == "turn"])
    det = _sorted(det)
    circ = planted[planted.kind == "circling"]
    du, ru = _units([det, ref])
    row: dict[str, object] = {}
    for iou in (0.3, 0.5):
        ev = categorize_events(det, du, ref, ru, iou=iou)
        tp = int((ev.kind == "TP").sum())
        fp, fn = int((ev.kind == "FP").sum()), int((ev.kind == "FN").sum())
        row[f"F1@{iou}"] = 2 * tp / max(2 * tp + fp + fn, 1)
        if iou == 0.5:
            tp_rows = ev[ev.kind == "TP"]
            hit = set(tp_rows.ref_row.astype(int))
            for m in MOVEMENTS:
                rows = np.flatnonzero(ref.movement.to_numpy() == m)
                row[f"R {m}"] = float(np.mean([r in hit for r in rows])) if rows.size else np.nan
            # matched accuracy: the detection's 45° bin is the label's (Turn-REMAP's metric)
            det_bin = 45.0 * np.floor(det.angle_deg.to_numpy()[tp_rows.det_row] / 45.0 + 0.5)
            right = det_bin == ref.label_deg.to_numpy()[tp_rows.ref_row]
            moves = ref.movement.to_numpy()[tp_rows.ref_row]
            row["acc"] = float(right.mean())
            for m in ("quick", "curved"):
                row[f"acc {m}"] = float(right[moves == m].mean()) if (moves == m).any() else np.nan
    inside = 0
    for c in circ.itertuples(index=False):
        same = (det.session == c.session) & (det.subject == c.subject)
        inside += int((same & (det.start_s < c.end_s) & (det.end_s > c.start_s)).sum())
    row["in circling"] = inside
    row["longest s"] = float((det.end_s - det.start_s).max())
    row["too fast"] = int((det.speed_deg_s > limits.MAX_TURN_MEAN_SPEED_DEG_S).sum())
    return row


def evaluate(seed: int, root: Path, only: list[str] | None = None) -> list[dict[str, object]]:
    corpus = root / f"seed{seed}"
    write_untrimmed_corpus(corpus, seed=seed)
    planted = pd.read_csv(corpus / "planted.csv", keep_default_na=False, na_values=[""])
    planted["movement"] = planted["movement"].fillna("")
    files = stream_files([corpus / "streams"])
    rows = []
    for name, (params, patches) in _variants().items():
        if only and name not in only:
            continue
        with ExitStack() as stack:
            for p in patches:
                stack.enter_context(p)
            run = detect_files(
                files, detector=MinerRule(params), layout=H36M17, up_axis="-y", fps_hz=FPS_HZ
            )
        rows.append({"seed": seed, "variant": name, **score(run.detections, planted)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--variants", nargs="+", default=None, help="only these (e.g. full)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        rows = [r for seed in args.seeds for r in evaluate(seed, Path(tmp), args.variants)]
    header = list(rows[0])
    cells = [[f"{v:.3f}" if isinstance(v, float) else v for v in r.values()] for r in rows]
    print("\n".join(markdown_table(header, cells)))


if __name__ == "__main__":
    main()
