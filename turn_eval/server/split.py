"""The public/private split of a hidden reference, seeded and recorded.

Clips of one participant stay on one side (a model tuned on a participant's public turns
would otherwise be scored on the same person's private ones), so the split is drawn over
participants where the reference names them (a ``subject`` column with no empty cell), and
over clips otherwise. The draw is ``numpy.random.default_rng(seed).permutation`` of the
units in natural order; the first ``round(private_fraction * n_units)`` of the permutation
are private (at least one unit on each side when there are two or more).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.render.order import natural_key

__all__ = ["Split", "draw_split", "PUBLIC", "PRIVATE"]

PUBLIC = "public"
PRIVATE = "private"


@dataclass(frozen=True)
class Split:
    """Which reference clips are public and which private.

    Attributes
    ----------
    table
        ``clip_id, split`` (``public`` or ``private``), in reference order.
    unit
        ``subject`` (drawn over participants) or ``clip_id`` (over clips).
    n_units_private, n_units
        How many units the draw put on the private side, of how many.
    """

    table: pd.DataFrame
    unit: str
    n_units_private: int
    n_units: int

    def mask(self, side: str) -> np.ndarray:
        """Boolean per reference clip: is it on ``side``?"""
        return (self.table["split"] == side).to_numpy()


def _units(reference: pd.DataFrame) -> tuple[str, np.ndarray]:
    if "subject" in reference.columns and (reference["subject"].astype(str) != "").all():
        return "subject", reference["subject"].astype(str).to_numpy()
    return "clip_id", reference["clip_id"].astype(str).to_numpy()


def draw_split(reference: pd.DataFrame, *, private_fraction: float, seed: int) -> Split:
    """Draw the split of ``reference`` (a frame from ``read_reference``).

    Parameters
    ----------
    reference
        ``clip_id`` and, where known, ``subject``.
    private_fraction
        Share of the units (participants, else clips) held out as private, in (0, 1).
    seed
        Seed of the permutation.

    Returns
    -------
    Split
    """
    if not 0 < private_fraction < 1:
        raise TurnbenchError(f"--private-fraction must be in (0, 1), got {private_fraction}")
    unit, values = _units(reference)
    names = sorted(set(values.tolist()), key=natural_key)
    if len(names) < 2:
        raise TurnbenchError(
            f"the reference has {len(names)} {'participant' if unit == 'subject' else 'clip'}: "
            "a public/private split needs two or more"
        )
    order = np.random.default_rng(seed).permutation(len(names))
    n_private = int(round(private_fraction * len(names)))
    n_private = min(max(n_private, 1), len(names) - 1)
    private = {names[i] for i in order[:n_private]}
    side = np.where(np.isin(values, list(private)), PRIVATE, PUBLIC)
    table = pd.DataFrame({"clip_id": reference["clip_id"].astype(str).to_numpy(), "split": side})
    return Split(table=table, unit=unit, n_units_private=n_private, n_units=len(names))
