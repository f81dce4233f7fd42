"""Read a reference table and a submission, validate the submission, join them per clip.

The reference is any CSV with ``clip_id, angle_deg`` and, optionally, ``duration_s`` and
group columns (``scenario, location, cohort, subject, action, split``, or any other): the
Turn-H3.6M clip index and the Turn-REMAP labels both qualify as they are (DESIGN.md).
A submission is ``clip_id, angle_deg`` and, optionally, ``speed_deg_s``; extra columns are
kept and ignored.

Both are read by the harness's one reader of user tables (:mod:`turn_datasets.usertable`),
the same forgiving way: header names match ignoring case and surrounding spaces; a UTF-8
byte-order mark is dropped; the delimiter is a comma, a semicolon or a tab, whichever the
header uses; with a semicolon or tab delimiter a decimal comma (``12,5``) is read as a decimal
point. Blank lines are skipped.

What the scoring is strict about, each found problem one :class:`TurnbenchError` naming the
file and the file's own line number (line 1 is the header): an empty file, a missing column,
a row with the wrong number of fields, an empty clip id, a non-numeric, NaN or infinite angle,
a negative angle (angles are magnitudes; ``abs_angles=True`` takes them as such), duplicate
clip ids, ids not in the reference, and reference ids missing from the submission (the first
ten and the count; ``allow_missing=True`` scores the rest and reports ``n_missing``). All
predicted angles below 2π while the reference's are not is only a warning: radians, perhaps.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import BIN_WIDTH_DEG, quantise_deg
from turn_datasets.usertable import (
    NUMERIC,
    Problems,
    Table,
    and_more,
    first_and_count,
    list_ids,
    numbers,
    read_table,
    reading_notes,
    refuse_rows,
    require,
)

__all__ = [
    "GROUP_COLUMNS",
    "BIN_COLUMN",
    "JOINED_COLUMNS",
    "Joined",
    "Checked",
    "read_reference",
    "check_predictions",
    "read_predictions",
]

#: The default groupings, in this order, when the reference has them. ``bin_deg``
#: is the reference angle's 45° bin, which every reference has.
GROUP_COLUMNS = ("scenario", "location", "cohort", "subject", "bin_deg", "action", "split")
#: The reference bin column: always recomputed from the reference angle.
BIN_COLUMN = "bin_deg"
#: The per-clip columns of a joined table, before the reference's other columns.
JOINED_COLUMNS = {
    "clip_id": "str",
    "ref_angle_deg": "float64",
    "pred_angle_deg": "float64",
    "ref_duration_s": "float64",
    "pred_speed_deg_s": "float64",
    "bin_deg": "float64",
}
_TWO_PI = 2 * math.pi


def _clip_ids(table: Table, problems: Problems | None = None) -> np.ndarray:
    ids = table.columns["clip_id"]
    if not table.ascii:
        # "Café" typed on a Mac (NFD) and on Windows (NFC) are different strings but the
        # same id; both sides are compared in NFC.
        ids = pd.Series(ids, dtype=object).str.normalize("NFC").to_numpy(dtype=object)
    refuse_rows(
        table, ids == "", lambda _: "clip_id is empty", problems=problems, kind="clip_id is empty"
    )
    duplicate = pd.Series(ids, dtype=object).duplicated(keep="first").to_numpy() & (ids != "")
    if problems is not None:
        where = np.flatnonzero(duplicate)
        if where.size:
            first_line: dict[object, int] = {}
            for k in range(ids.shape[0]):
                first_line.setdefault(ids[k], int(table.lines[k]))
            k0 = int(where[0])
            problems.add(
                "duplicate clip_id",
                table.lines[where],
                [
                    f"{ids[k]!r}, first on line {first_line[ids[k]]}"
                    for k in where[: problems.shown]
                ],
                first=f"duplicate clip_id {ids[k0]!r}, first on line {first_line[ids[k0]]}",
                single=f"duplicate clip_id {ids[k0]!r}, first on line {first_line[ids[k0]]}"
                f"{and_more(int(where.size))}",
            )
        return ids
    if duplicate.any():
        i, line, count = first_and_count(table, duplicate)
        first = int(np.flatnonzero(ids == ids[i])[0])
        raise TurnbenchError(
            f"duplicate clip_id {ids[i]!r}, first on line {int(table.lines[first])}"
            f"{and_more(count)}",
            file=table.path,
            row=line,
        )
    return ids


def read_reference(
    path: str | os.PathLike[str], *, bin_width_deg: float = BIN_WIDTH_DEG
) -> pd.DataFrame:
    """Read a reference table: clip index, labels, or any CSV with ``clip_id, angle_deg``.

    Parameters
    ----------
    path
        The reference CSV.
    bin_width_deg
        Width of the angle bins; ``bin_deg`` is recomputed from ``angle_deg`` with
        :func:`turn_datasets.geometry.quantise_deg` so that it always agrees with the metrics.

    Returns
    -------
    DataFrame
        ``clip_id`` (str), ``angle_deg`` (float64), ``duration_s`` (float64, only when the
        reference has it; an empty cell is NaN), ``bin_deg`` (float64), then every other
        column of the file as stripped strings, in file order. ``attrs["path"]`` is the file,
        ``attrs["sha256"]`` the sha256 of its bytes as read and ``attrs["lines"]`` each row's
        line number.

    Raises
    ------
    TurnbenchError
        The same problems as a submission (see the module docstring), each with its line.
    """
    table = read_table(path, what="reference")
    require(table, ("clip_id", "angle_deg"), what="the reference")
    ids = _clip_ids(table)
    angle = numbers(
        table,
        "angle_deg",
        allow_empty=False,
        allow_negative=False,
        negative_hint="reference angles are magnitudes in degrees",
    )
    data: dict[str, object] = {"clip_id": ids, "angle_deg": angle}
    dtypes: dict[str, str] = {"clip_id": "str", "angle_deg": "float64"}
    if "duration_s" in table.header:
        data["duration_s"] = numbers(
            table,
            "duration_s",
            allow_empty=True,
            allow_negative=False,
            negative_hint="durations are end minus start, in seconds",
        )
        dtypes["duration_s"] = "float64"
    data[BIN_COLUMN] = np.asarray(quantise_deg(angle, bin_width_deg), dtype=np.float64)
    dtypes[BIN_COLUMN] = "float64"
    for col in table.header:
        # Numeric columns (a clip index's speed_deg_s) are values, not groups.
        if col and col not in dtypes and col not in NUMERIC:
            data[col] = table.columns[col]
            dtypes[col] = "str"
    frame = typed_frame(pd.DataFrame(data), dtypes)
    frame.attrs["path"] = table.path
    frame.attrs["sha256"] = table.sha256
    frame.attrs["lines"] = table.lines
    frame.attrs["bin_width_deg"] = float(bin_width_deg)
    return frame


@dataclass(frozen=True)
class Joined:
    """A submission joined to its reference, one row per scored clip, in reference order.

    Attributes
    ----------
    table
        ``clip_id, ref_angle_deg, pred_angle_deg, ref_duration_s, pred_speed_deg_s, bin_deg``
        and then the reference's other columns (strings), usable as groupings.
        ``ref_duration_s`` is NaN where the reference has no duration, ``pred_speed_deg_s``
        NaN where the submission gives no speed.
    n_missing
        Reference clips the submission left out (only non-zero with ``allow_missing``).
    missing_ids
        Those clips' ids, in reference order.
    has_durations
        Whether the reference has a ``duration_s`` column (else no speed metric).
    predictions_path, reference_path
        The files read.
    predictions_sha256, reference_sha256
        The sha256 of their bytes as read ("" where not known: a reference frame made in
        memory).
    bin_width_deg
        The bin width ``bin_deg`` was computed with.
    abs_angles, allow_missing
        How the submission was read (:func:`read_predictions`' options of those names).
    """

    table: pd.DataFrame
    n_missing: int
    missing_ids: tuple[str, ...] = field(repr=False)
    has_durations: bool
    predictions_path: str
    reference_path: str
    bin_width_deg: float = BIN_WIDTH_DEG
    abs_angles: bool = False
    allow_missing: bool = False
    predictions_sha256: str = ""
    reference_sha256: str = ""

    @property
    def group_columns(self) -> tuple[str, ...]:
        """Columns a ``--by`` may name: ``bin_deg`` and the reference's other columns."""
        return tuple(self.table.columns[len(JOINED_COLUMNS) - 1 :])

    @property
    def default_groupings(self) -> tuple[str, ...]:
        """:data:`GROUP_COLUMNS` the reference has with at least one non-empty value."""
        out = []
        for col in GROUP_COLUMNS:
            if col == BIN_COLUMN:
                out.append(col)
            elif col in self.table.columns and (self.table[col] != "").any():
                out.append(col)
        return tuple(out)

    def __len__(self) -> int:
        return int(self.table.shape[0])


def _place_in_reference(
    table: Table,
    ids: np.ndarray,
    ref: pd.DataFrame,
    *,
    ref_path: str,
    allow_missing: bool,
    say: Callable[[str], None],
    problems: Problems | None = None,
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Each prediction's row in the reference, which reference rows are covered, and the
    ids of those that are not (refused unless ``allow_missing``; an unknown id always;
    with ``problems``, added there instead of raised)."""
    ref_ids = ref["clip_id"].to_numpy(dtype=object)
    position = pd.Index(ref_ids).get_indexer(ids)
    unknown = (position < 0) & (ids != "")
    if problems is not None and unknown.any():
        where = np.flatnonzero(unknown)
        n = int(where.size)
        problems.add(
            f"clip_id not in the reference {ref_path}",
            table.lines[where],
            [repr(ids[k]) for k in where[: problems.shown]],
            single=f"{n} clip id{'s are' if n > 1 else ' is'} not in the reference "
            f"{ref_path}: {list_ids(list(ids[unknown]))}",
            first=f"{n} clip id{'s are' if n > 1 else ' is'} not in the reference {ref_path}",
        )
    elif unknown.any():
        _, line, count = first_and_count(table, unknown)
        listed = list_ids(list(ids[unknown]))
        raise TurnbenchError(
            f"{count} clip id{'s are' if count > 1 else ' is'} not in the reference "
            f"{ref_path}: {listed}",
            file=table.path,
            row=line,
        )
    covered = np.zeros(ref.shape[0], dtype=bool)
    covered[position] = True
    missing_ids = tuple(str(i) for i in ref_ids[~covered])
    if missing_ids:
        message = (
            f"{len(missing_ids)} of the reference's {ref.shape[0]} clips "
            f"{'are' if len(missing_ids) > 1 else 'is'} missing from the predictions: "
            f"{list_ids(missing_ids)}"
        )
        if not allow_missing:
            hint = "pass --allow-missing to score the clips that are there"
            if problems is not None:
                problems.add(message, [], hint=hint)
                return position, covered, missing_ids
            raise TurnbenchError(message, file=table.path, hint=hint)
        say(f"{table.path}: {message}; scoring the other {int(covered.sum())}")

    return position, covered, missing_ids


def _checked_rows(
    table: Table,
    ref: pd.DataFrame,
    *,
    ref_path: str,
    allow_missing: bool,
    abs_angles: bool,
    say: Callable[[str], None],
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray, tuple[str, ...]]:
    """A submission's angles, speeds and place in the reference, after every check; every
    problem of the file is found in one pass and raised together, grouped by kind."""
    # Every problem of the file in one pass (grouped by kind), then one error.
    problems = Problems(table.path)
    ids = _clip_ids(table, problems)
    hint = "angles are magnitudes; pass --abs to take the absolute value"
    angle = numbers(
        table,
        "angle_deg",
        allow_empty=False,
        allow_negative=abs_angles,
        negative_hint=hint,
        problems=problems,
    )
    speed = None
    if "speed_deg_s" in table.header:
        # An empty speed means "not given": the metric falls back to angle / duration.
        speed = numbers(
            table,
            "speed_deg_s",
            allow_empty=True,
            allow_negative=abs_angles,
            negative_hint=hint,
            problems=problems,
        )
    if abs_angles:
        angle = np.abs(angle)
        speed = None if speed is None else np.abs(speed)

    position, covered, missing_ids = _place_in_reference(
        table,
        ids,
        ref,
        ref_path=ref_path,
        allow_missing=allow_missing,
        say=say,
        problems=problems,
    )
    problems.raise_if_any()
    return angle, speed, position, covered, missing_ids


@dataclass(frozen=True)
class Checked:
    """A submission that passed every check of :func:`check_predictions`, placed in its
    reference but not yet joined to it.

    Attributes
    ----------
    angle_deg, speed_deg_s
        The submission's angles and speeds (None: no ``speed_deg_s`` column), in file order,
        as magnitudes where ``abs_angles`` was given.
    position
        Each submission row's row in the reference.
    covered
        Which reference rows the submission has.
    missing_ids
        The ids of the reference rows it does not have, in reference order.
    path, sha256
        The file read and the sha256 of its bytes as read.
    """

    angle_deg: np.ndarray
    speed_deg_s: np.ndarray | None
    position: np.ndarray
    covered: np.ndarray
    missing_ids: tuple[str, ...] = field(repr=False)
    path: str = ""
    sha256: str = ""

    @property
    def n_clips(self) -> int:
        """How many reference clips the submission scores."""
        return int(np.count_nonzero(self.covered))


def check_predictions(
    path: str | os.PathLike[str],
    reference: pd.DataFrame,
    *,
    allow_missing: bool = False,
    abs_angles: bool = False,
    warn: Callable[[str], None] | None = None,
) -> Checked:
    """Read a submission and make every check of :func:`read_predictions` (the module
    docstring lists them), without building the joined table.

    ``read_predictions`` is this and then the join, which refuses nothing more; a caller
    that only needs to know whether a file would be scored, and on how many clips (the
    server, before it answers an upload), asks this. ``reference`` is a frame from
    :func:`read_reference`; the other parameters are ``read_predictions``'.

    Raises
    ------
    TurnbenchError
        Every problem listed in the module docstring, with the file and line.
    """
    say = warn if warn is not None else (lambda message: None)
    ref_path = str(reference.attrs.get("path", "reference"))
    table = read_table(path, what="predictions")
    for note in reading_notes(table):
        say(note)
    require(table, ("clip_id", "angle_deg"), what="the predictions")
    angle, speed, position, covered, missing_ids = _checked_rows(
        table,
        reference,
        ref_path=ref_path,
        allow_missing=allow_missing,
        abs_angles=abs_angles,
        say=say,
    )
    ref_angle = reference["angle_deg"].to_numpy(dtype=np.float64)
    if angle.size and float(np.max(angle)) < _TWO_PI and float(np.max(ref_angle)) >= _TWO_PI:
        say(
            f"{table.path}: every predicted angle is below 2π (the largest is "
            f"{float(np.max(angle)):.4g}) while the reference's reach "
            f"{float(np.max(ref_angle)):.4g}: are they in radians? turnbench expects degrees"
        )
    return Checked(
        angle_deg=angle,
        speed_deg_s=speed,
        position=position,
        covered=covered,
        missing_ids=missing_ids,
        path=table.path,
        sha256=table.sha256,
    )


def read_predictions(
    path: str | os.PathLike[str],
    reference: pd.DataFrame | str | os.PathLike[str],
    *,
    allow_missing: bool = False,
    abs_angles: bool = False,
    warn: Callable[[str], None] | None = None,
    bin_width_deg: float = BIN_WIDTH_DEG,
) -> Joined:
    """Read and validate a submission and join it to the reference per clip.

    Parameters
    ----------
    path
        The predictions CSV: ``clip_id, angle_deg`` and optionally ``speed_deg_s``.
    reference
        A frame from :func:`read_reference`, or a reference CSV to read with it.
    allow_missing
        Score the clips the submission has and report how many it left out, instead of
        refusing a submission that misses reference clips.
    abs_angles
        Take negative angles (and speeds) as their magnitudes (a signed-rotation submission),
        instead of refusing them.
    warn
        Called with a one-line message for what is suspicious but scoreable (radians,
        missing clips under ``allow_missing``); ignored when None.
    bin_width_deg
        Used only when ``reference`` is a path.

    Returns
    -------
    Joined
        See :class:`Joined`.

    Raises
    ------
    TurnbenchError
        Every problem listed in the module docstring, with the file and line
        (:func:`check_predictions`, which this calls).
    """
    ref = (
        reference
        if isinstance(reference, pd.DataFrame)
        else read_reference(reference, bin_width_deg=bin_width_deg)
    )
    checked = check_predictions(
        path, ref, allow_missing=allow_missing, abs_angles=abs_angles, warn=warn
    )
    return _joined(
        checked,
        ref,
        bin_width_deg=float(ref.attrs.get("bin_width_deg", bin_width_deg)),
        abs_angles=abs_angles,
        allow_missing=allow_missing,
    )


def _joined(
    checked: Checked,
    ref: pd.DataFrame,
    *,
    bin_width_deg: float,
    abs_angles: bool,
    allow_missing: bool,
) -> Joined:
    """The checked submission and its reference, one row per covered clip, in reference
    order (so the output does not depend on the submission's row order)."""
    covered, position = checked.covered, checked.position
    pred_angle = np.full(ref.shape[0], np.nan)
    pred_angle[position] = checked.angle_deg
    pred_speed = np.full(ref.shape[0], np.nan)
    if checked.speed_deg_s is not None:
        pred_speed[position] = checked.speed_deg_s
    has_durations = "duration_s" in ref.columns
    duration = (
        ref["duration_s"].to_numpy(dtype=np.float64)
        if has_durations
        else np.full(ref.shape[0], np.nan)
    )
    data: dict[str, object] = {
        "clip_id": ref["clip_id"][covered].reset_index(drop=True),
        "ref_angle_deg": ref["angle_deg"].to_numpy(dtype=np.float64)[covered],
        "pred_angle_deg": pred_angle[covered],
        "ref_duration_s": duration[covered],
        "pred_speed_deg_s": pred_speed[covered],
        BIN_COLUMN: ref[BIN_COLUMN].to_numpy(dtype=np.float64)[covered],
    }
    dtypes = dict(JOINED_COLUMNS)
    for col in ref.columns:
        if col not in ("clip_id", "angle_deg", "duration_s") and col not in JOINED_COLUMNS:
            data[col] = ref[col][covered].reset_index(drop=True)
            dtypes[col] = "str"
    joined = typed_frame(pd.DataFrame(data), dtypes)
    return Joined(
        table=joined,
        n_missing=len(checked.missing_ids),
        missing_ids=checked.missing_ids,
        has_durations=has_durations,
        predictions_path=checked.path,
        reference_path=str(ref.attrs.get("path", "reference")),
        bin_width_deg=bin_width_deg,
        abs_angles=abs_angles,
        allow_missing=allow_missing,
        predictions_sha256=checked.sha256,
        reference_sha256=str(ref.attrs.get("sha256", "")),
    )
