"""Validating and scoring an upload against the hidden reference: ``turn-eval score``'s code.

An upload is checked, before it is accepted, by
:func:`turn_eval.clips.submission.check_predictions`, the checks of the very function
``turn-eval score`` calls (:func:`~turn_eval.clips.submission.read_predictions`: those checks,
then the join, which refuses nothing more), against the reference read by
:func:`turn_eval.clips.submission.read_reference`; a worker reads it with ``read_predictions``
and scores it with :func:`turn_eval.clips.tables.build_scores`. The server adds only what a
hidden reference needs:

- a refusal names the upload by the name its sender gave and the reference as
  ``reference.csv`` (never a path on the server), and lists none of the reference's clip ids
  (a submission missing clips is told how many, not which);
- scores are computed on the public and on the private clips separately
  (:mod:`turn_eval.server.split`) and reduced to what may leave the server: ``n``, the four
  metrics, their 95% intervals, and the same per group of the columns named at init.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_eval.clips.metrics import METRICS
from turn_eval.clips.submission import (
    BIN_COLUMN,
    Joined,
    check_predictions,
    read_predictions,
    read_reference,
)
from turn_eval.clips.tables import build_scores
from turn_eval.server.datadir import REFERENCE_NAME, Challenge
from turn_eval.server.split import PRIVATE, PUBLIC

__all__ = [
    "reference_of",
    "check_upload",
    "check_job",
    "serve_checks",
    "validate_upload",
    "score_upload",
    "side_arrays",
    "SIDES",
]

SIDES = (PUBLIC, PRIVATE)
_MISSING = " missing from the predictions"


@functools.lru_cache(maxsize=4)
def _reference(path: str, version: str) -> pd.DataFrame:
    frame = read_reference(path)
    frame.attrs["path"] = REFERENCE_NAME
    return frame


def reference_of(challenge: Challenge) -> pd.DataFrame:
    """The challenge's reference as ``read_reference`` gives it, read once per process."""
    return _reference(str(challenge.reference_path), challenge.reference_version)


def _hidden(exc: TurnbenchError, path: Path, shown_name: str) -> TurnbenchError:
    """The refusal as ``turn-eval score`` words it, naming the file as its sender did and
    listing no reference clip id."""
    message = exc.message.replace(str(path), shown_name)
    if _MISSING in message:
        message = message.split(_MISSING)[0] + _MISSING + " (the reference's ids are not shown)"
    where = exc.where
    return TurnbenchError(
        message,
        file=shown_name if where.file == str(path) else where.file,
        row=where.row,
        item=where.item,
        hint=exc.hint,
    )


def check_upload(challenge: Challenge, path: Path, shown_name: str) -> int:
    """Check an upload exactly as ``turn-eval score`` does, without joining it to the
    reference (what an upload waits for before its answer); how many clips it scores.

    Raises
    ------
    TurnbenchError
        The score command's one-line message, naming ``shown_name``.
    """
    try:
        return check_predictions(path, reference_of(challenge)).n_clips
    except TurnbenchError as exc:
        raise _hidden(exc, path, shown_name) from None


def validate_upload(challenge: Challenge, path: Path, shown_name: str) -> Joined:
    """Read and validate an upload exactly as ``turn-eval score`` does.

    Raises
    ------
    TurnbenchError
        The score command's one-line message, naming ``shown_name``.
    """
    try:
        return read_predictions(path, reference_of(challenge))
    except TurnbenchError as exc:
        raise _hidden(exc, path, shown_name) from None


def _reduced(scores: dict[str, Any], named: tuple[str, ...]) -> dict[str, Any]:
    """What of a scores document may leave the server (module docstring): the groupings
    ``named`` at init and no other."""

    def entry(values: dict[str, Any]) -> dict[str, Any]:
        out = {"n": values["n"], **{m: values.get(m) for m in METRICS}}
        if "ci95" in values:
            out["ci95"] = {m: values["ci95"].get(m) for m in METRICS}
        return out

    by = {
        col: {
            "groups": {label: entry(g) for label, g in part["groups"].items()},
            "avg": entry(part["avg"]),
        }
        for col, part in scores["by"].items()
        if col in named
    }
    return {**entry(scores["overall"]), "by": by}


def _side(joined: Joined, split: pd.DataFrame, side: str) -> Joined:
    on_side = set(split.loc[split["split"] == side, "clip_id"])
    mask = joined.table["clip_id"].isin(on_side).to_numpy()
    return dataclasses.replace(joined, table=joined.table[mask].reset_index(drop=True))


def score_upload(challenge: Challenge, path: Path) -> dict[str, Any]:
    """Score an accepted upload on the public and the private clips.

    Returns
    -------
    dict
        ``{"public": scores, "private": scores}``, each reduced (module docstring), with
        every interval from ``challenge.n_resamples`` resamples seeded ``challenge.seed``.
    """
    joined = validate_upload(challenge, path, "the upload")
    split = challenge.read_split()
    out: dict[str, Any] = {}
    # build_scores groups by every default column when given none; with no --by the
    # cheapest grouping is computed instead, and _reduced drops it
    by = list(challenge.by) or [BIN_COLUMN]
    for side in SIDES:
        part = _side(joined, split, side)
        scores = build_scores(part, by=by, n_resamples=challenge.n_resamples, seed=challenge.seed)
        out[side] = _reduced(scores, challenge.by)
    return out


def side_arrays(challenge: Challenge, path: Path, side: str) -> dict[str, np.ndarray | None]:
    """One upload's predictions and the reference on one side's clips, in reference order,
    as :func:`turn_eval.clips.significance.compare_predictions` takes them."""
    part = _side(validate_upload(challenge, path, "the upload"), challenge.read_split(), side)
    t = part.table
    return {
        "pred_deg": t["pred_angle_deg"].to_numpy(),
        "pred_speed_deg_s": t["pred_speed_deg_s"].to_numpy(),
        "ref_deg": t["ref_angle_deg"].to_numpy(),
        "ref_duration_s": t["ref_duration_s"].to_numpy() if part.has_durations else None,
    }


def score_job(root: str, upload: str) -> dict[str, Any]:
    """What a scoring worker process runs: open the data directory, score one upload."""
    from turn_eval.server.datadir import open_challenge

    return score_upload(open_challenge(root), Path(upload))


def check_job(root: str, upload: str, shown_name: str) -> int:
    """What a check worker process runs: open the data directory, check one upload
    (:func:`check_upload`); how many clips it scores, or its refusal."""
    from turn_eval.server.datadir import open_challenge

    return check_upload(open_challenge(root), Path(upload), shown_name)


def warm_job(root: str) -> None:
    """Read the reference into a new worker process before the first upload needs it."""
    from turn_eval.server.datadir import open_challenge

    reference_of(open_challenge(root))


def serve_checks(
    conn: Any, root: str, parent_pid: int, job: Callable[[str, str, str], int] = check_job
) -> None:
    """A check worker's life: ``job(*args)`` for each ``args`` received on ``conn`` (one end
    of a :func:`multiprocessing.Pipe`), answered on it as ``(True, clips)`` or ``(False,
    exception)``, until the server closes its end (or is gone: :func:`watch_parent`).

    The server's thread that asks waits on the pipe itself: no executor threads in the
    server's process between the request and the answer.
    """
    watch_parent(parent_pid)
    with contextlib.suppress(Exception):
        # a data directory that cannot be read is the first check's refusal, not a crash
        warm_job(root)
    while True:
        try:
            args = conn.recv()
        except EOFError:
            return
        try:
            reply: tuple[bool, Any] = (True, job(*args))
        except Exception as exc:
            reply = (False, exc)
        try:
            conn.send(reply)
        except (pickle.PicklingError, TypeError, AttributeError):
            conn.send((False, RuntimeError(f"the check failed ({type(reply[1]).__name__})")))


#: How much lower the scoring workers' CPU priority is than the server's (``nice``): scoring
#: is queued work, and on a machine whose cores it fills the uploads and pages must still be
#: answered first.
WORKER_NICENESS = 10


def scoring_worker_init(parent_pid: int) -> None:
    """A scoring worker's initializer: a lower CPU priority (:data:`WORKER_NICENESS`), and
    exit when the server that started it is gone (:func:`watch_parent`)."""
    import os

    os.nice(WORKER_NICENESS)
    watch_parent(parent_pid)


def watch_parent(parent_pid: int, interval_s: float = 1.0) -> None:
    """A worker's initializer: exit when the server that started it is gone.

    A server killed with SIGKILL cannot stop its pool, and a worker blocked on the job
    queue would wait for ever; this thread ends it within ``interval_s`` of the server's
    death (the worker's own parent may be a fork server, so the server is watched by id).
    """
    import os
    import threading
    import time

    def alive() -> bool:
        try:
            os.kill(parent_pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True

    def watch() -> None:
        while alive():
            time.sleep(interval_s)
        os._exit(0)

    threading.Thread(target=watch, name="turnbench-parent-watch", daemon=True).start()
