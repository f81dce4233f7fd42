"""``turn-eval profile``'s use case: detections in, three tables and a JSON document out.

:func:`turning_profile` reads and cross-checks the inputs (:mod:`turn_eval.profile.inputs`),
computes one row of measures per participant (:mod:`turn_eval.profile.measures`), the turns per
local hour, and the contrasts between the two groups with their bootstrap intervals
(:mod:`turn_eval.profile.contrasts`). The document says what was suppressed, the settings and
the inputs' sha256, so a reader can reproduce every number.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets import __version__
from turn_datasets.fileio import sha256_file
from turn_datasets.params import check_params, param
from turn_eval.profile.contrasts import contrasts_table
from turn_eval.profile.inputs import DEFAULT_BY, read_inputs
from turn_eval.profile.measures import by_hour_table, profile_table
from turn_eval.scoring.bootstrap import CONFIDENCE

__all__ = ["ProfileParams", "ProfileResult", "turning_profile", "contrast_measures"]


@dataclass(frozen=True)
class ProfileParams:
    """The profile's own parameter (the bootstrap's are every scorer's ``--bootstrap``/``--seed``)."""

    min_turns: int = param(
        5,
        "Participants with fewer turns get blank measures and stay out of the contrasts (a "
        "measure from a handful of turns is noise).",
        min=0,
        max=100_000,
    )

    def __post_init__(self) -> None:
        check_params(self)


_FIXED = ("subject", "recorded_h", "turns")


@dataclass(frozen=True)
class ProfileResult:
    """The three tables and the JSON document of one profile."""

    profile: pd.DataFrame
    by_hour: pd.DataFrame
    contrasts: pd.DataFrame
    doc: dict[str, Any]


def contrast_measures(profile: pd.DataFrame, by: str) -> list[str]:
    """The profile's measure columns, in order: everything after ``turns``."""
    return [c for c in profile.columns if c not in (*_FIXED, by)]


def _sha(
    path: str | os.PathLike[str] | pd.DataFrame, read: pd.DataFrame | None = None
) -> str | None:
    """The sha256 of an input file: the one its reader took of the bytes it read (``read``'s
    ``attrs``), else the file's, hashed here; None for a frame given in memory."""
    if isinstance(path, pd.DataFrame):
        return None
    digest = None if read is None else read.attrs.get("sha256")
    return str(digest) if digest else sha256_file(path)


def turning_profile(
    detections: str | os.PathLike[str] | pd.DataFrame,
    sessions: str | os.PathLike[str],
    participants: str | os.PathLike[str],
    *,
    by: str = DEFAULT_BY,
    min_turns: int = 5,
    n_resamples: int = 1000,
    seed: int = 0,
    warn: Callable[[str], None] | None = None,
    progress: Callable[[Iterable[int], int], Iterable[int]] | None = None,
) -> ProfileResult:
    """Per-participant turning profiles and the contrasts between two groups.

    Parameters
    ----------
    detections
        The detections contract (``turn-eval detect``'s output), a CSV path or a frame.
    sessions
        ``session, subject, duration_s`` and optionally ``start_time`` (ISO 8601 with offset).
    participants
        The participants table: ``subject`` and the ``by`` column.
    by
        The two-level grouping column (``cohort``: PD against HC).
    min_turns
        Participants with fewer turns get blank measures and are left out of the contrasts.
    n_resamples, seed
        The stratified bootstrap (0 resamples: no intervals).
    warn, progress
        Told of suppressed participants and sessions without a start time; wraps the
        bootstrap's chunks.

    Raises
    ------
    TurnbenchError
        As :mod:`turn_eval.profile.inputs` says; a negative ``min_turns``.
    """
    ProfileParams(min_turns=min_turns)  # checks it
    inputs = read_inputs(detections, sessions, participants, by=by)
    profile = profile_table(inputs, min_turns=min_turns)
    small = profile["turns"].to_numpy() < min_turns
    by_hour = by_hour_table(inputs, keep=~small)
    measures = contrast_measures(profile, inputs.by)
    contrasts = contrasts_table(
        profile.loc[~small],
        measures,
        by=inputs.by,
        levels=inputs.levels,
        n_resamples=n_resamples,
        seed=seed,
        progress=progress,
    )
    no_start = int(np.isnan(inputs.sessions["local_start_s"].to_numpy()).sum())
    if warn is not None and small.any():
        warn(
            f"{int(small.sum())} of {small.size} participants have fewer than {min_turns} "
            "turns: their measures are blank and they are left out of the contrasts"
        )
    if warn is not None and no_start:
        warn(
            f"{no_start} session(s) have no start_time: left out of by_hour.csv and of the "
            "across-day variation"
        )
    doc = {
        "by": inputs.by,
        "groups": {"pd": inputs.levels[0], "hc": inputs.levels[1]},
        "participants": int(small.size),
        "suppressed": int(small.sum()),
        "sessions_without_start_time": no_start,
        "contrasts": contrasts.to_dict(orient="records"),
        "settings": {
            "min_turns": min_turns,
            "resamples": n_resamples,
            "seed": seed,
            "confidence": CONFIDENCE,
            "ci_method": "percentile, bootstrap of participants within each group",
            "version": __version__,
        },
        "signature": {
            "version": __version__,
            "options": f"by={inputs.by} min_turns={min_turns} resamples={n_resamples} seed={seed}",
            "detections_sha256": _sha(detections, inputs.detections),
            "sessions_sha256": _sha(sessions, inputs.sessions),
            "participants_sha256": _sha(participants),
        },
    }
    return ProfileResult(profile=profile, by_hour=by_hour, contrasts=contrasts, doc=doc)
