"""The manifest of a clip index: how it was made.

The manifest, ``<index stem>.manifest.json`` beside the index, records how the index was
made: the tool version, every parameter, each input file with its sha256, size and the
number of sequences read from it, the units of each source, its ``frame_offset`` (1 for a BVH
whose rest-pose frame 0 was dropped, so that the index's frame k is the file's frame k + 1;
else 0), counts per bin, split, subject
and action, the overrides applied and unmatched, and the files and single sequences
skipped (``--skip-bad``; ``item`` names the sequence, null for a whole file).
Its ``created_utc`` timestamp is the only field that changes between two runs on the same
inputs."""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from turn_datasets import __version__
from turn_datasets.h36m.miner import MinerParams
from turn_datasets.h36m.overrides import Overrides
from turn_datasets.render.order import natural_key

__all__ = ["build_manifest"]


def _counts(series: pd.Series, key=None) -> dict[str, int]:
    counts = series.astype(str).value_counts()
    names = sorted(counts.index, key=key) if key else sorted(counts.index)
    return {str(n): int(counts[n]) for n in names}


def build_manifest(
    *,
    index: pd.DataFrame,
    params: MinerParams,
    reader_options: Mapping[str, Any],
    inputs: Sequence[Mapping[str, Any]],
    overrides: Overrides | None,
    applied: Sequence[Mapping[str, Any]],
    unmatched: Sequence[Mapping[str, Any]],
    skipped: Sequence[Mapping[str, Any]],
    n_sequences: int,
    n_frames: int,
    created_utc: str | None = None,
) -> dict[str, Any]:
    """The manifest as a JSON-ready dict (see the module docstring).

    ``created_utc`` defaults to now; every other field depends only on the inputs.
    """
    created = created_utc or _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    by_bin = index["bin_deg"].astype(int).value_counts()
    return {
        "tool": "turn-datasets h36m mine",
        "version": __version__,
        "created_utc": created,
        "parameters": {"miner": params.as_dict(), "reader": dict(reader_options)},
        "inputs": [dict(i) for i in inputs],
        "skipped": [dict(s) for s in skipped],
        "counts": {
            "sequences": int(n_sequences),
            "frames": int(n_frames),
            "clips": int(len(index)),
            "per_bin_deg": {str(b): int(by_bin[b]) for b in sorted(by_bin.index)},
            "per_split": _counts(index["split"].fillna("")),
            "per_subject": _counts(index["subject"], key=natural_key),
            "per_action": _counts(index["action"]),
            "per_direction": _counts(index["direction"]),
        },
        "overrides": {
            "file": None if overrides is None else overrides.path,
            "sha256": None if overrides is None else overrides.sha256,
            "applied": [dict(a) for a in applied],
            "unmatched": [dict(u) for u in unmatched],
        },
    }
