"""Significance-gated ranks: a leaderboard entry moves below the one above it only when the
paired bootstrap says it is worse.

Entries are ordered by accuracy (the paper's headline metric; higher first), then MAE (lower
first), then the earlier submission. The first entry has rank 1; each next entry is compared
with the entry just above it by :func:`turn_eval.clips.significance.compare_predictions` (the
paired bootstrap of ``turn-eval compare``, on the same clips, with the challenge's resamples
and seed) and takes its own position as rank only if the accuracy difference's two-sided
p-value is below ``alpha``; otherwise it shares the rank above. So a submission that beats
another by noise does not climb past it: coarse ranks of this kind are what keeps a public
leaderboard from being overfitted (Blum and Hardt 2015, "The Ladder").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from turn_eval.clips.significance import compare_predictions

__all__ = ["RANK_METRIC", "Ranked", "order_key", "gated_ranks"]

#: The metric ranks are ordered and tested on.
RANK_METRIC = "accuracy"


@dataclass(frozen=True)
class Ranked:
    """One entry's rank and the p-value of its test against the entry above (None: first)."""

    rank: int
    p_value: float | None


def order_key(scores: Mapping[str, Any], submitted: float) -> tuple[float, float, float]:
    """Sort key of an entry: accuracy descending, MAE ascending, earlier first."""
    accuracy = scores.get("accuracy")
    mae = scores.get("mae_deg")
    return (
        -(accuracy if accuracy is not None else -np.inf),
        mae if mae is not None else np.inf,
        submitted,
    )


def gated_ranks(
    n_entries: int,
    arrays: Callable[[int], Mapping[str, Any]],
    *,
    alpha: float,
    n_resamples: int,
    seed: int,
) -> list[Ranked]:
    """Ranks of entries already in leaderboard order.

    Parameters
    ----------
    n_entries
        How many entries.
    arrays
        Entry index -> ``pred_deg``, ``pred_speed_deg_s``, ``ref_deg``, ``ref_duration_s``
        on the ranked clips (:func:`turn_eval.server.scoring.side_arrays`).
    alpha
        Level of the test.
    n_resamples, seed
        Of the paired bootstrap.

    Returns
    -------
    list of Ranked
    """
    out: list[Ranked] = []
    above: Mapping[str, Any] | None = None
    for i in range(n_entries):
        this = arrays(i)
        if above is None:
            out.append(Ranked(rank=1, p_value=None))
        else:
            comparison = compare_predictions(
                above["pred_deg"],
                this["pred_deg"],
                this["ref_deg"],
                ref_duration_s=this["ref_duration_s"],
                pred_a_speed_deg_s=above["pred_speed_deg_s"],
                pred_b_speed_deg_s=this["pred_speed_deg_s"],
                n_resamples=max(n_resamples, 1),
                seed=seed,
            )
            p = comparison.differences[RANK_METRIC].p_value
            separated = p is not None and p < alpha
            out.append(Ranked(rank=i + 1 if separated else out[-1].rank, p_value=p))
        above = this
    return out
