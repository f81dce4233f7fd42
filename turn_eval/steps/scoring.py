"""Steps and turn type scored per clip: what ``turn-eval score`` adds where both sides have them.

REMAP Open's labels carry each turn's ``steps`` (the raters' ``number_of_turning_steps``) and
``turn_type`` (pivot or step); ``turn-eval predict --fps`` writes both. Where the reference and
the predictions both carry a column, on the clips where both give a value:

- ``steps_mae``: the mean absolute difference of the step counts; ``steps_exact``: the share
  of clips with the count exactly right (``n_steps`` clips);
- ``type_accuracy``: the share of clips of the right type; ``type_kappa``: Cohen's kappa
  between the two (chance-corrected agreement; ``sklearn.metrics.cohen_kappa_score``), null
  when only one type occurs on both sides (``n_type`` clips).

Overall and per group of each grouping the scores report (no intervals: the counts are small
and these are descriptive).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from sklearn.metrics import cohen_kappa_score

from turn_datasets.errors import TurnbenchError
from turn_datasets.render.markdown import metric_table
from turn_datasets.render.numbers import MISSING, fixed
from turn_datasets.render.order import natural_key
from turn_datasets.usertable import numbers, read_table
from turn_eval.events.contract import MAX_STEPS, TURN_TYPES

__all__ = ["STEP_METRICS", "step_scores", "steps_markdown"]

STEP_METRICS = ("n_steps", "steps_mae", "steps_exact", "n_type", "type_accuracy", "type_kappa")


def _columns(
    path: str | os.PathLike[str], what: str
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, str]:
    """A table's clip ids, steps (NaN where empty) and lower-cased turn types, if it has them."""
    table = read_table(path, what=what)
    ids = np.asarray(table.columns["clip_id"], dtype=object)
    steps = types = None
    if "steps" in table.header:
        steps = numbers(table, "steps", allow_empty=True, allow_negative=False, negative_hint=None)
        bad = np.isfinite(steps) & ((steps != np.round(steps)) | (steps > MAX_STEPS))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise TurnbenchError(
                f"steps {steps[i]:g} is not a whole number of at most {MAX_STEPS:g}",
                file=table.path,
                row=int(table.lines[i]),
            )
    if "turn_type" in table.header:
        types = np.array([str(t).strip().lower() for t in table.columns["turn_type"]], dtype=object)
        bad = ~np.isin(types, ["", *TURN_TYPES])
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise TurnbenchError(
                f"turn_type {types[i]!r} is not one of {', '.join(TURN_TYPES)} (or empty)",
                file=table.path,
                row=int(table.lines[i]),
            )
    return ids, steps, types, table.path


def _aligned(ids: np.ndarray, values: np.ndarray | None, clips: np.ndarray) -> np.ndarray | None:
    if values is None:
        return None
    position = pd.Index(ids).get_indexer(clips)
    return np.asarray(values, dtype=object)[position]


def _metrics(
    ref_steps: np.ndarray | None,
    pred_steps: np.ndarray | None,
    ref_type: np.ndarray | None,
    pred_type: np.ndarray | None,
) -> dict[str, Any]:
    out: dict[str, Any] = dict.fromkeys(STEP_METRICS)
    if ref_steps is not None and pred_steps is not None:
        r, p = ref_steps.astype(np.float64), pred_steps.astype(np.float64)
        both = np.isfinite(r) & np.isfinite(p)
        out["n_steps"] = int(both.sum())
        if both.any():
            out["steps_mae"] = float(np.mean(np.abs(r[both] - p[both])))
            out["steps_exact"] = float(np.mean(r[both] == p[both]))
    if ref_type is not None and pred_type is not None:
        both = (ref_type != "") & (pred_type != "")
        out["n_type"] = int(both.sum())
        if both.any():
            a, b = ref_type[both].astype(str), pred_type[both].astype(str)
            out["type_accuracy"] = float(np.mean(a == b))
            if len(set(a) | set(b)) > 1:
                out["type_kappa"] = float(cohen_kappa_score(a, b, labels=list(TURN_TYPES)))
    return out


def step_scores(
    reference: str | os.PathLike[str],
    predictions: str | os.PathLike[str],
    table: pd.DataFrame,
    groupings: Sequence[str],
) -> dict[str, Any] | None:
    """Steps and turn-type agreement overall and per group (module docstring).

    ``table`` is the scored clips (``clip_id`` and the grouping columns: the joined table of
    :func:`turn_eval.clips.submission.read_predictions`). None when the two files do not both
    carry ``steps`` or both carry ``turn_type``.
    """
    ref_ids, ref_steps, ref_types, _ = _columns(reference, "reference")
    pred_ids, pred_steps, pred_types, _ = _columns(predictions, "predictions")
    steps_both = ref_steps is not None and pred_steps is not None
    types_both = ref_types is not None and pred_types is not None
    if not (steps_both or types_both):
        return None
    clips = table["clip_id"].to_numpy(dtype=object)
    cols = [
        _aligned(ref_ids, ref_steps, clips) if steps_both else None,
        _aligned(pred_ids, pred_steps, clips) if steps_both else None,
        _aligned(ref_ids, ref_types, clips) if types_both else None,
        _aligned(pred_ids, pred_types, clips) if types_both else None,
    ]
    doc: dict[str, Any] = {"overall": _metrics(*cols), "by": {}}
    for grouping in groupings:
        values = table[grouping].astype(str).to_numpy()
        doc["by"][grouping] = {
            str(g): _metrics(*(c[values == g] if c is not None else None for c in cols))
            for g in sorted(pd.unique(values), key=natural_key)
        }
    return doc


def _cell(value: Any, digits: int, percent: bool = False) -> str:
    if value is None:
        return MISSING
    return fixed(100 * value, 1) if percent else fixed(value, digits)


def steps_markdown(doc: Mapping[str, Any]) -> str:
    """The steps section of ``scores.md``: one row overall and one per group."""
    header = ["group", "n steps", "steps MAE", "exact %", "n type", "type acc. %", "kappa"]

    def row(label: str, m: Mapping[str, Any]) -> list[Any]:
        return [
            label,
            MISSING if m["n_steps"] is None else m["n_steps"],
            _cell(m["steps_mae"], 2),
            _cell(m["steps_exact"], 1, True),
            MISSING if m["n_type"] is None else m["n_type"],
            _cell(m["type_accuracy"], 1, True),
            _cell(m["type_kappa"], 2),
        ]

    rows = [row("overall", doc["overall"])]
    for grouping, groups in doc["by"].items():
        rows += [row(f"{grouping}: {g}", m) for g, m in groups.items()]
    return "\n".join(["## Steps and turn type", "", *metric_table(header, rows)]) + "\n"
