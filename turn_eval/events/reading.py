"""Read and validate the files of ``score-events``: detections, reference, context, sessions.

Every file is read by the harness's one reader of user tables (:mod:`turn_datasets.usertable`:
header names matched ignoring case and spaces, comma, semicolon or tab delimiter, a UTF-8 BOM dropped, each
row's own line number kept), so a detections file is as forgiving to write as a predictions
file and every error names the file and its line (line 1 is the header).

The checks, each one :class:`TurnbenchError` naming file and line: a missing column; an empty
session or subject; a time that is not a number, NaN, infinite or negative; an end not after its
start; a duplicate row (same session, subject, start and end); two intervals of one
(session, subject) that overlap, naming both lines (detections, reference turns, context
intervals); an angle outside ``[0, MAX_ANGLE_DEG]``, a speed outside ``[0, MAX_SPEED_DEG_S]``,
a direction other than ``left``/``right``; a detection of a (session, subject) the reference
does not annotate (or, with ``ignore_unknown``, such rows dropped and counted).

A frame passed from Python (not read from a file) gets the same checks; its rows are named by
the line they would have in a CSV with a header (row 0 is line 2).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError, require_columns
from turn_datasets.strings import stripped_objects
from turn_datasets.usertable import Problems, Table, numbers, read_table, require
from turn_eval.events.contract import (
    CLIP_INDEX_SESSION,
    CONTEXT_COLUMNS,
    DETECTION_OPTIONAL,
    DETECTION_REQUIRED,
    DIRECTIONS,
    MAX_ANGLE_DEG,
    MAX_SPEED_DEG_S,
    MAX_STEPS,
    REFERENCE_REQUIRED,
    SESSIONS_COLUMNS,
    SESSIONS_OPTIONAL,
    TURN_TYPES,
)

__all__ = [
    "read_detections",
    "read_event_reference",
    "read_context",
    "read_sessions",
    "check_detections",
    "check_event_reference",
    "check_context",
    "check_sessions",
    "check_within_durations",
    "Units",
    "known_units",
    "units_of",
    "pair_codes",
    "Pairs",
    "check_detections_pairs",
    "check_event_reference_pairs",
    "read_detections_pairs",
    "read_event_reference_pairs",
    "units_of_pairs",
]

_UNIT = ("session", "subject")
#: The detections' required and optional numeric columns; an optional one may be empty.
_DETECTION_NUMBERS = tuple(c for c, t in DETECTION_REQUIRED.items() if t == "float64")
_OPTIONAL_NUMBERS = tuple(c for c, t in DETECTION_OPTIONAL.items() if t != "str")
#: The detections' text columns of few distinct values, numbered by the file reader as it
#: reads them (:attr:`turn_datasets.usertable.Table.codes`) rather than factorised after.
_DETECTION_CODED = ("session", "subject", "direction", "turn_type")
#: A text column's codes: each row's number and each number's text.
Codes = Mapping[str, tuple[np.ndarray, np.ndarray]]


def _texts(frame: pd.DataFrame, col: str) -> np.ndarray:
    """A text column as stripped ``str`` objects, empty where missing (as the file reader
    leaves them: a frame it made, marked ``attrs["stripped"]``, is taken as it is)."""
    values = frame[col].to_numpy(dtype=object)
    if frame.attrs.get("stripped"):
        return values
    values = np.where(pd.isna(values), "", values).astype(str)
    return stripped_objects(values)


def _text_series(values: np.ndarray, frame: pd.DataFrame) -> pd.Series:
    """Text as an object column: pandas' string dtype would convert every cell on the way in
    and again on every ``to_numpy(dtype=object)``."""
    return pd.Series(np.asarray(values, dtype=object), index=frame.index, dtype=object)


def _set_texts(frame: pd.DataFrame, columns: Sequence[str]) -> None:
    """Make ``columns`` of ``frame`` stripped ``str`` objects (:func:`_texts`), in place; a
    column of the file reader's frame is one already and is left as it is."""
    for col in columns:
        if frame.attrs.get("stripped") and frame[col].dtype == object:
            continue
        frame[col] = _text_series(_texts(frame, col), frame)


def _set_floats(frame: pd.DataFrame, columns: Sequence[str]) -> None:
    """Make ``columns`` of ``frame`` float64, anything not a number NaN, in place."""
    for col in columns:
        if frame[col].dtype != np.float64:
            frame[col] = pd.to_numeric(frame[col], errors="coerce").astype(np.float64)


def _lines_of(frame: pd.DataFrame) -> np.ndarray:
    lines = frame.attrs.get("lines")
    if lines is None or len(lines) != frame.shape[0]:
        return np.arange(2, 2 + frame.shape[0], dtype=np.int64)
    return np.asarray(lines, dtype=np.int64)


def pair_codes(*columns: np.ndarray, split: Sequence[int] = ()) -> list[np.ndarray]:
    """One int64 code per distinct (first, second) pair of two text columns.

    Columns may be concatenations of several tables' rows; ``split`` cuts the codes back into
    those tables (positions as ``numpy.split``). Equal pairs get equal codes in every part.
    Two factorisations and an integer combination: far cheaper than a MultiIndex.
    """
    first, second = columns
    a, uniq_a = pd.factorize(np.asarray(first, dtype=object))
    b, uniq_b = pd.factorize(np.asarray(second, dtype=object))
    code = a.astype(np.int64) * max(len(uniq_b), 1) + b
    return np.split(code, list(split))


def _factorize_names(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``pandas.factorize``, a missing name (NaN) numbered as a name too (rarely needed, and
    twice as slow to ask for)."""
    codes, names = pd.factorize(values)
    if (codes < 0).any():
        codes, names = pd.factorize(values, use_na_sentinel=False)
    return codes, names


@dataclass(frozen=True)
class Pairs:
    """The (session, subject) pair of every row of a table, factorised once for its checks,
    its unit numbers and the lookup of its units: each row's pair number (in order of first
    appearance) and each number's session and subject."""

    code: np.ndarray
    sessions: np.ndarray
    subjects: np.ndarray

    @classmethod
    def of(cls, frame: pd.DataFrame, codes: Codes | None = None) -> Pairs:
        """The pairs of ``frame``'s rows; ``codes``: its ``session`` and ``subject`` as the
        file reader numbered them (any numbering: the pairs are numbered here)."""
        known = codes or {}
        if "session" in known and "subject" in known:
            (a, uniq_a), (b, uniq_b) = known["session"], known["subject"]
        else:
            a, uniq_a = _factorize_names(frame["session"].to_numpy(dtype=object))
            b, uniq_b = _factorize_names(frame["subject"].to_numpy(dtype=object))
        width = max(len(uniq_b), 1)
        code, pairs = pd.factorize(a.astype(np.int64) * width + b)
        return cls(
            code=code.astype(np.int64),
            sessions=np.asarray(uniq_a, dtype=object)[pairs // width],
            subjects=np.asarray(uniq_b, dtype=object)[pairs % width],
        )


def _path_of(frame: pd.DataFrame, what: str) -> str:
    return str(frame.attrs.get("path", what))


def _fail(message: str, frame: pd.DataFrame, what: str, i: int, count: int = 1) -> TurnbenchError:
    more = f" ({count - 1} more row{'s' if count > 2 else ''} like it)" if count > 1 else ""
    return TurnbenchError(message + more, file=_path_of(frame, what), row=int(_lines_of(frame)[i]))


def _first(bad: np.ndarray) -> tuple[int, int]:
    where = np.flatnonzero(bad)
    return int(where[0]), int(where.size)


def _check_text(frame: pd.DataFrame, what: str, columns: Sequence[str]) -> None:
    for col in columns:
        values = frame[col].to_numpy(dtype=object)
        # The file reader leaves no missing cell (an empty one is ""): one comparison.
        bad = values == ""
        if not frame.attrs.get("stripped"):
            bad |= pd.isna(values)
        if bad.any():
            i, count = _first(bad)
            raise _fail(f"{col} is empty", frame, what, i, count)


def _check_unit_names(frame: pd.DataFrame, what: str, pairs: Pairs) -> None:
    """:func:`_check_text` of ``session`` and ``subject``, through their distinct pairs."""
    for col, names in (("session", pairs.sessions), ("subject", pairs.subjects)):
        empty = names == ""
        if empty.any():
            i, count = _first(empty[pairs.code])
            raise _fail(f"{col} is empty", frame, what, i, count)


def _check_number(
    frame: pd.DataFrame,
    what: str,
    col: str,
    *,
    high: float = np.inf,
    allow_nan: bool = False,
    allow_negative: bool = False,
    hint: str = "",
) -> None:
    values = frame[col].to_numpy(dtype=np.float64)
    nan = np.isnan(values)
    if not allow_nan and nan.any():
        i, count = _first(nan)
        raise _fail(f"{col} is NaN or empty", frame, what, i, count)
    inf = np.isinf(values)
    if inf.any():
        i, count = _first(inf)
        raise _fail(f"{col} is infinite ({values[i]:g})", frame, what, i, count)
    low = -np.inf if allow_negative else 0.0
    out = ~nan & ((values < low) | (values > high))
    if out.any():
        i, count = _first(out)
        bound = f"[{low:g}, {high:g}]" if np.isfinite(low) else f"at most {high:g}"
        raise _fail(
            f"{col} {values[i]:g} is outside the plausible range {bound}{hint}",
            frame,
            what,
            i,
            count,
        )


def _check_intervals(
    frame: pd.DataFrame,
    what: str,
    unit: Sequence[str],
    noun: str,
    unit_code: np.ndarray | None = None,
) -> None:
    """End after start, no duplicate rows, no two intervals of one unit overlapping
    (``unit_code``: each row's unit, if already numbered)."""
    start = frame["start_s"].to_numpy(dtype=np.float64)
    end = frame["end_s"].to_numpy(dtype=np.float64)
    backwards = end <= start
    if backwards.any():
        i, count = _first(backwards)
        raise _fail(f"end_s {end[i]:g} is not after start_s {start[i]:g}", frame, what, i, count)
    if frame.shape[0] < 2:
        return
    if unit_code is None:
        (unit_code,) = pair_codes(*(frame[c].to_numpy(dtype=object) for c in unit))
    # Codes number the units in order of appearance, so a file written unit by unit in time
    # order (what a detector or the labels write) is already sorted: no sort needed.
    step = np.diff(unit_code)
    in_order = bool(((step > 0) | ((step == 0) & (np.diff(start) >= 0))).all())
    if in_order:
        order = np.arange(start.shape[0])
        u, s, e = unit_code, start, end
    else:
        order = np.lexsort((start, unit_code))
        u, s, e = unit_code[order], start[order], end[order]
    same = u[1:] == u[:-1]
    # In start order, any two overlapping intervals imply an overlapping adjacent pair.
    overlap = same & (s[1:] < e[:-1])
    if not overlap.any():
        return
    lines = _lines_of(frame)
    duplicate = overlap & (s[1:] == s[:-1]) & (e[1:] == e[:-1])
    if duplicate.any():
        # Equal rows need not be adjacent among rows of the same start: look them all up.
        k = int(np.flatnonzero(duplicate)[0])
        rows = order[(u == u[k]) & (s == s[k]) & (e == e[k])]
        i, j = (int(r) for r in sorted(rows, key=lambda r: lines[r])[:2])
        raise TurnbenchError(
            f"duplicate {noun}: same {', '.join(unit)}, start_s and end_s as line {lines[i]}",
            file=_path_of(frame, what),
            row=int(lines[j]),
        )
    if overlap.any():
        k = int(np.flatnonzero(overlap)[0])
        i, j = sorted((int(order[k]), int(order[k + 1])), key=lambda r: lines[r])
        names = ", ".join(f"{c} {frame[c].iat[i]!r}" for c in unit)
        raise TurnbenchError(
            f"{noun}s on lines {lines[i]} and {lines[j]} overlap ({names}: "
            f"{start[i]:g}-{end[i]:g} s and {start[j]:g}-{end[j]:g} s); "
            f"{noun}s of one person must not overlap",
            file=_path_of(frame, what),
            row=int(lines[j]),
        )


def _coded(
    frame: pd.DataFrame, col: str, coded: tuple[np.ndarray, np.ndarray] | None
) -> tuple[np.ndarray, np.ndarray]:
    """A text column's codes and distinct values: the file reader's, else factorised."""
    if coded is not None:
        return coded
    codes, uniq = pd.factorize(_texts(frame, col))
    return codes, np.asarray(uniq, dtype=object)


def _check_direction(
    frame: pd.DataFrame, what: str, coded: tuple[np.ndarray, np.ndarray] | None = None
) -> None:
    # Lower-cased and checked through the few distinct values, not per row.
    codes, uniq = _coded(frame, "direction", coded)
    lowered = [str(u).lower() for u in uniq]
    allowed = ("", *DIRECTIONS)
    if not all(u in allowed for u in lowered):
        bad = np.array([u not in allowed for u in lowered])[codes]
        i, count = _first(bad)
        raise _fail(
            f"direction {frame['direction'].iat[i]!r} is not one of {', '.join(DIRECTIONS)} "
            "(or empty)",
            frame,
            what,
            i,
            count,
        )
    if lowered != list(uniq) or not (
        frame.attrs.get("stripped") and frame["direction"].dtype == object
    ):
        frame["direction"] = _text_series(np.array(lowered, dtype=object)[codes], frame)


def _check_steps(frame: pd.DataFrame, what: str) -> None:
    """A step count is empty or a whole number in ``[0, MAX_STEPS]``."""
    _check_number(frame, what, "steps", high=MAX_STEPS, allow_nan=True)
    values = frame["steps"].to_numpy(dtype=np.float64)
    fractional = np.isfinite(values) & (values != np.round(values))
    if fractional.any():
        i, count = _first(fractional)
        raise _fail(f"steps {values[i]:g} is not a whole number", frame, what, i, count)


def _check_turn_type(
    frame: pd.DataFrame, what: str, coded: tuple[np.ndarray, np.ndarray] | None = None
) -> None:
    """A turn type is empty or one of :data:`TURN_TYPES` (any case; lower-cased here)."""
    codes, uniq = _coded(frame, "turn_type", coded)
    lowered = [str(u).lower() for u in uniq]
    allowed = ("", *TURN_TYPES)
    if not all(u in allowed for u in lowered):
        bad = np.array([u not in allowed for u in lowered])[codes]
        i, count = _first(bad)
        raise _fail(
            f"turn_type {frame['turn_type'].iat[i]!r} is not one of {', '.join(TURN_TYPES)} "
            "(or empty)",
            frame,
            what,
            i,
            count,
        )
    frame["turn_type"] = _text_series(np.array(lowered, dtype=object)[codes], frame)


def _missing(frame: pd.DataFrame, required: Sequence[str], what: str) -> None:
    require_columns(frame.columns, required, what=what, file=_path_of(frame, what))


def check_detections(frame: pd.DataFrame, *, what: str = "detections") -> pd.DataFrame:
    """Validate a detections frame (the contract of :mod:`turn_eval.events.contract`).

    Returns the frame with exactly the contract's columns it has, typed, optional ones after
    the required ones, ``direction`` lower-cased (empty where not given), and ``attrs``
    ``path`` and ``lines`` kept. Raises :class:`TurnbenchError` as the module docstring says.
    """
    return check_detections_pairs(frame, what)[0]


def check_detections_pairs(
    frame: pd.DataFrame, what: str = "detections", *, codes: Codes | None = None
) -> tuple[pd.DataFrame, Pairs]:
    """:func:`check_detections`, and the rows' (session, subject) pairs it factorised.

    ``codes``: text columns of ``frame`` as its file reader numbered them (each row's number
    and each number's text, :attr:`turn_datasets.usertable.Table.codes`), used instead of
    factorising those columns again."""
    codes = codes or {}
    _missing(frame, list(DETECTION_REQUIRED), what)
    cols = [*DETECTION_REQUIRED, *(c for c in DETECTION_OPTIONAL if c in frame.columns)]
    # Shallow: every column this changes is replaced, never written into, so the caller's
    # frame stays as it was without copying its cells.
    out = frame.loc[:, cols].copy(deep=False)
    out.attrs = dict(frame.attrs)
    _set_texts(out, _UNIT)
    pairs = Pairs.of(out, codes)
    # Every kind of problem in one pass (each check's first line and count), then one error
    problems = Problems(_path_of(out, what))
    problems.run(lambda: _check_unit_names(out, what, pairs))
    _set_floats(out, (*_DETECTION_NUMBERS, *(c for c in _OPTIONAL_NUMBERS if c in out)))
    times_ok = problems.run(lambda: _check_number(out, what, "start_s"))
    times_ok &= problems.run(lambda: _check_number(out, what, "end_s"))
    hint = "; angles are magnitudes in degrees, with the sense in direction"
    problems.run(lambda: _check_number(out, what, "angle_deg", high=MAX_ANGLE_DEG, hint=hint))
    for col in ("speed_deg_s", "peak_speed_deg_s"):
        if col in out:
            problems.run(
                partial(_check_number, out, what, col, high=MAX_SPEED_DEG_S, allow_nan=True)
            )
    if "steps" in out:
        problems.run(lambda: _check_steps(out, what))
    if "turn_type" in out:
        problems.run(lambda: _check_turn_type(out, what, codes.get("turn_type")))
    if "score" in out:
        try:
            out = _scores_given_or_none(out, what)
        except TurnbenchError as exc:
            problems.record(exc)
    if "direction" in out:
        problems.run(lambda: _check_direction(out, what, codes.get("direction")))
    if times_ok:  # overlaps of unreadable times would only repeat those problems
        problems.run(lambda: _check_intervals(out, what, _UNIT, "detection", pairs.code))
    problems.raise_if_any("nothing scored")
    return out.reset_index(drop=True).pipe(_keep_attrs, frame), pairs


def _scores_given_or_none(out: pd.DataFrame, what: str) -> pd.DataFrame:
    """The frame with its ``score`` column checked, or without it when every cell is empty.

    ``score`` is optional: a detector without confidences leaves the column empty, which is
    the same as not having it (no average precision). A score on some rows but not on
    others cannot rank the detections, so it is refused, naming the first empty row.
    """
    score = out["score"].to_numpy(dtype=np.float64)
    empty = np.isnan(score)
    if empty.all():
        return out.drop(columns="score").pipe(_keep_attrs, out)
    if empty.any():
        i, count = _first(empty)
        raise _fail(
            "score is empty here but given on other rows: give every detection a score "
            "(to rank them for average precision) or none",
            out,
            what,
            i,
            count,
        )
    _check_number(out, what, "score", allow_negative=True)
    return out


def _keep_attrs(out: pd.DataFrame, source: pd.DataFrame) -> pd.DataFrame:
    out.attrs = dict(source.attrs)
    return out


class _SharedLines(np.ndarray):
    """Row line numbers as a frame's ``attrs["lines"]``, shared rather than copied.

    pandas deep-copies a frame's ``attrs`` into nearly every result (each column taken, each
    ``loc``), which for a 100,000-row file copied this array over a hundred times per run.
    It is read-only, so every copy may be the array itself.
    """

    def __deepcopy__(self, memo: dict[int, Any] | None = None) -> _SharedLines:
        return self


def _shared_lines(lines: np.ndarray) -> _SharedLines:
    out = np.array(lines, dtype=np.int64).view(_SharedLines)
    out.flags.writeable = False
    return out


def _frame_of(
    table: Table, numeric: Sequence[str], allow_empty: Sequence[str] = ()
) -> pd.DataFrame:
    """A file's columns as a frame: ``numeric`` ones parsed strictly, the rest as text."""
    data: dict[str, object] = {}
    for col in table.header:
        if not col:
            continue
        if col in numeric:
            data[col] = numbers(
                table, col, allow_empty=col in allow_empty, allow_negative=True, negative_hint=None
            )
        else:
            data[col] = pd.Series(table.columns[col], dtype=object, copy=False)
    # The arrays are the reader's own: no copy, and no block of all the text columns copied
    # together (pandas copies arrays given to a constructor unless told not to).
    frame = pd.DataFrame(data, copy=False)
    frame.attrs["path"] = table.path
    frame.attrs["sha256"] = table.sha256
    frame.attrs["lines"] = _shared_lines(table.lines)
    # The reader strips every cell and has no missing text (an empty cell is "").
    frame.attrs["stripped"] = True
    return frame


def read_detections(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a detections CSV (:func:`check_detections`); other columns ignored."""
    return read_detections_pairs(path)[0]


def read_detections_pairs(path: str | os.PathLike[str]) -> tuple[pd.DataFrame, Pairs]:
    """:func:`read_detections`, and the rows' (session, subject) pairs."""
    numeric = (*_DETECTION_NUMBERS, *_OPTIONAL_NUMBERS)
    # A detector that finds no turn (a still person, a video with nobody in it) writes the
    # header alone: zero detections, scored as such.
    table = read_table(
        path,
        what="detections",
        numeric_columns=numeric,
        allow_no_rows=True,
        coded_columns=_DETECTION_CODED,
    )
    require(table, list(DETECTION_REQUIRED), what="the detections file")
    frame = _frame_of(table, numeric, allow_empty=_OPTIONAL_NUMBERS)
    return check_detections_pairs(frame, what=table.path, codes=table.codes)


def check_event_reference(frame: pd.DataFrame, *, what: str = "reference") -> pd.DataFrame:
    """Validate a reference frame: labels, or a clip index (``session`` made from
    :data:`CLIP_INDEX_SESSION`).

    Returns ``session, subject, start_s, end_s, angle_deg`` (typed), ``direction`` when the
    reference has it, then every other text column (stripped strings) as possible groupings.
    """
    return check_event_reference_pairs(frame, what)[0]


def check_event_reference_pairs(
    frame: pd.DataFrame, what: str = "reference"
) -> tuple[pd.DataFrame, Pairs]:
    """:func:`check_event_reference`, and the rows' (session, subject) pairs it factorised."""
    frame = frame if "session" in frame.columns else _clip_index_sessions(frame, what)
    _missing(frame, REFERENCE_REQUIRED, what)
    out = frame.copy(deep=False)
    _set_texts(out, _UNIT)
    pairs = Pairs.of(out)
    _check_unit_names(out, what, pairs)
    for col in ("start_s", "end_s", "angle_deg"):
        _set_floats(out, (col,))
        high = MAX_ANGLE_DEG if col == "angle_deg" else np.inf
        _check_number(out, what, col, high=high)
    if "direction" in out:
        _check_direction(out, what)
    _check_intervals(out, what, _UNIT, "reference turn", pairs.code)
    numeric = {"start_s", "end_s", "angle_deg"}
    rest = [
        c
        for c in out.columns
        if c not in (*REFERENCE_REQUIRED, "direction")
        and c not in numeric
        and (out[c].dtype == object or pd.api.types.is_string_dtype(out[c]))
    ]
    _set_texts(out, rest)
    cols = [*REFERENCE_REQUIRED, *(["direction"] if "direction" in out else []), *rest]
    return out.loc[:, cols].reset_index(drop=True).pipe(_keep_attrs, frame), pairs


def _clip_index_sessions(frame: pd.DataFrame, what: str) -> pd.DataFrame:
    if not all(c in frame.columns for c in CLIP_INDEX_SESSION):
        _missing(frame, REFERENCE_REQUIRED, what)
    out = frame.copy(deep=False)
    action = _texts(out, "action")
    sub = _texts(out, "subaction")
    out.insert(0, "session", _text_series(np.where(sub == "", action, action + " " + sub), out))
    out.attrs = dict(frame.attrs)
    return out


def read_event_reference(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a reference CSV (:func:`check_event_reference`)."""
    return read_event_reference_pairs(path)[0]


def read_event_reference_pairs(path: str | os.PathLike[str]) -> tuple[pd.DataFrame, Pairs]:
    """:func:`read_event_reference`, and the rows' (session, subject) pairs."""
    numeric = ("start_s", "end_s", "angle_deg")
    table = read_table(path, what="reference", numeric_columns=numeric)
    frame = _frame_of(table, numeric)
    return check_event_reference_pairs(frame, what=table.path)


def check_context(frame: pd.DataFrame, *, what: str = "context") -> pd.DataFrame:
    """Validate a context frame (:data:`CONTEXT_COLUMNS`; ``subject`` optional, empty = shared).

    Intervals of one (session, subject) must not overlap; ``scenario`` and ``location`` may
    be empty (not annotated there).
    """
    required = [c for c in CONTEXT_COLUMNS if c != "subject"]
    _missing(frame, required, what)
    out = frame.copy(deep=False)
    if "subject" not in out:
        out["subject"] = ""
    _set_texts(out, ("session", "subject", "scenario", "location"))
    _check_text(out, what, ("session",))
    for col in ("start_s", "end_s"):
        _set_floats(out, (col,))
        _check_number(out, what, col)
    _check_intervals(out, what, _UNIT, "context interval")
    return out.loc[:, list(CONTEXT_COLUMNS)].reset_index(drop=True).pipe(_keep_attrs, frame)


def read_context(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a ``context.csv`` (:func:`check_context`)."""
    table = read_table(path, what="context", numeric_columns=("start_s", "end_s"))
    return check_context(_frame_of(table, ("start_s", "end_s")), what=table.path)


def check_sessions(frame: pd.DataFrame, *, what: str = "sessions") -> pd.DataFrame:
    """Validate a sessions frame (:data:`SESSIONS_COLUMNS`): positive finite durations, one row
    per (session, subject). The optional ``start_time`` (ISO 8601 with its UTC offset) is kept
    as text when the frame has it (``turn-eval profile`` parses it)."""
    _missing(frame, list(SESSIONS_COLUMNS), what)
    out = frame.copy(deep=False)
    _set_texts(out, _UNIT)
    _check_text(out, what, _UNIT)
    _set_floats(out, ("duration_s",))
    _check_number(out, what, "duration_s")
    zero = out["duration_s"].to_numpy() <= 0
    if zero.any():
        i, count = _first(zero)
        raise _fail("duration_s is not positive", out, what, i, count)
    dup = out.duplicated(subset=list(_UNIT), keep="first").to_numpy()
    if dup.any():
        i, count = _first(dup)
        raise _fail(
            f"duplicate session {out['session'].iat[i]!r} and subject {out['subject'].iat[i]!r}",
            out,
            what,
            i,
            count,
        )
    cols = [*SESSIONS_COLUMNS, *(c for c in SESSIONS_OPTIONAL if c in out.columns)]
    _set_texts(out, [c for c in SESSIONS_OPTIONAL if c in out.columns])
    return out.loc[:, cols].reset_index(drop=True).pipe(_keep_attrs, frame)


def read_sessions(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a ``sessions.csv`` (:func:`check_sessions`)."""
    table = read_table(path, what="sessions", numeric_columns=("duration_s",))
    return check_sessions(_frame_of(table, ("duration_s",)), what=table.path)


#: How much longer than its session's annotated duration the turns of a (session, subject)
#: may last in all (seconds): ELAN's time resolution, a millisecond, so turns that fill the
#: whole annotated time are not refused for rounding.
DURATION_TOLERANCE_S = 1e-3


def check_within_durations(
    frame: pd.DataFrame, unit: np.ndarray, duration: np.ndarray, *, what: str, sessions: str
) -> None:
    """Refuse turns (or detections) of a unit that last longer in all than its annotated
    duration.

    ``unit`` is each row's unit number, ``duration`` each unit's ``duration_s`` (from
    ``sessions``, the file named in the message). ``duration_s`` is how long the unit was
    annotated, not where its time line ends (the annotated span may start after 0), so the
    test is the one that holds either way: the turns of a unit do not overlap, so together
    they fit in its annotated time. Turns per hour divide by the duration: a session of 1 s
    holding a 480 s turn gave thousands of turns per hour. The error names the row, in time
    order, at which the running total first exceeds the duration.
    """
    if frame.shape[0] == 0:
        return
    start = frame["start_s"].to_numpy(dtype=np.float64)
    length = frame["end_s"].to_numpy(dtype=np.float64) - start
    unit = np.asarray(unit, dtype=np.int64)
    order = np.lexsort((start, unit))
    total = np.cumsum(length[order])
    # the running total within each unit: subtract the total before the unit's first row
    first = np.r_[True, unit[order][1:] != unit[order][:-1]]
    offset = np.maximum.accumulate(np.where(first, np.arange(order.size), 0))
    before = np.where(offset > 0, total[offset - 1], 0.0)
    running = np.empty_like(total)
    running[order] = total - before
    over = running > duration[unit] + DURATION_TOLERANCE_S
    if over.any():
        # the first row in time order of the first unit that overflows
        k = int(order[np.flatnonzero(over[order])[0]])
        count = int(over.sum())
        u = int(unit[k])
        raise _fail(
            f"the turns of session {frame['session'].iat[k]!r}, subject "
            f"{frame['subject'].iat[k]!r} up to this one last {running[k]:g} s, longer than "
            f"its annotated duration_s in {sessions}, {duration[u]:g} s",
            frame,
            what,
            k,
            count,
        )


@dataclass(frozen=True)
class Units:
    """The annotated (session, subject) units, numbered in sorted order.

    ``sessions`` and ``subjects`` hold each unit's names; :meth:`codes` numbers rows.
    """

    sessions: np.ndarray
    subjects: np.ndarray

    def __len__(self) -> int:
        return int(self.sessions.shape[0])

    def codes(self, frame: pd.DataFrame) -> np.ndarray:
        """Each row's unit number, -1 where the unit is not annotated."""
        return self.lookup(
            frame["session"].to_numpy(dtype=object), frame["subject"].to_numpy(dtype=object)
        )

    def lookup(self, sessions: np.ndarray, subjects: np.ndarray) -> np.ndarray:
        """The unit number of each (session, subject), -1 where not annotated."""
        n = len(self)
        mine, theirs = pair_codes(
            np.concatenate([self.sessions, np.asarray(sessions, dtype=object)]),
            np.concatenate([self.subjects, np.asarray(subjects, dtype=object)]),
            split=[n],
        )
        # The units are numbered in sorted order and unique, so their codes are unique too.
        order = np.argsort(mine, kind="stable")
        pos = np.minimum(np.searchsorted(mine[order], theirs), max(n - 1, 0))
        found = (mine[order][pos] == theirs) if n else np.zeros(theirs.shape[0], dtype=bool)
        return np.where(found, order[pos] if n else -1, -1).astype(np.int64)


def known_units(reference: pd.DataFrame, sessions: pd.DataFrame | None = None) -> Units:
    """Every (session, subject) the reference annotates: its rows' and ``sessions``'s units
    (a participant annotated without a turn is in ``sessions.csv`` only)."""
    return units_of(reference, sessions)[0]


def units_of(
    reference: pd.DataFrame, sessions: pd.DataFrame | None = None
) -> tuple[Units, np.ndarray]:
    """:func:`known_units` and each reference row's unit number, from one factorisation."""
    return units_of_pairs(Pairs.of(reference), sessions)


def units_of_pairs(pairs: Pairs, sessions: pd.DataFrame | None) -> tuple[Units, np.ndarray]:
    """:func:`units_of` from the reference's pairs: only its distinct pairs and the sessions
    table's rows are numbered, not every reference row again."""
    sessions_all, subjects_all = pairs.sessions, pairs.subjects
    if sessions is not None:
        sessions_all = np.concatenate([sessions_all, sessions["session"].to_numpy(dtype=object)])
        subjects_all = np.concatenate([subjects_all, sessions["subject"].to_numpy(dtype=object)])
    (code,) = pair_codes(sessions_all, subjects_all)
    _, first, inverse = np.unique(code, return_index=True, return_inverse=True)
    # Units in sorted (session, subject) order: rank the distinct pairs by their names.
    order = sorted(
        range(first.shape[0]), key=lambda i: (sessions_all[first[i]], subjects_all[first[i]])
    )
    rank = np.empty(first.shape[0], dtype=np.int64)
    rank[order] = np.arange(first.shape[0])
    chosen = first[order]
    units = Units(sessions=sessions_all[chosen], subjects=subjects_all[chosen])
    return units, rank[inverse.reshape(-1)][: pairs.sessions.shape[0]][pairs.code]


def drop_unknown(
    detections: pd.DataFrame,
    units: Units,
    *,
    ignore_unknown: bool,
    warn: Callable[[str], None] | None = None,
    pairs: Pairs | None = None,
) -> tuple[pd.DataFrame, np.ndarray, int]:
    """The detections of annotated units, their unit numbers, and how many were dropped.

    A detection of a unit the reference lacks is an error naming its line, unless
    ``ignore_unknown``: then such rows are dropped and counted (and ``warn`` told).
    ``pairs`` (the detections' own, if factorised) has each distinct pair looked up once.
    """
    if pairs is None:
        codes = units.codes(detections)
    else:
        codes = units.lookup(pairs.sessions, pairs.subjects)[pairs.code]
    unknown = codes < 0
    if not unknown.any():
        return detections, codes, 0
    i, count = _first(unknown)
    what = "detections"
    message = (
        f"session {detections['session'].iat[i]!r}, subject {detections['subject'].iat[i]!r} "
        "is not annotated in the reference"
    )
    if not ignore_unknown:
        err = _fail(message, detections, what, i, count)
        err.hint = "pass --ignore-unknown to drop such detections"
        raise TurnbenchError(err.message, file=err.where.file, row=err.where.row, hint=err.hint)
    if warn is not None:
        warn(
            f"{_path_of(detections, what)}: dropped {count} detection{'s' if count > 1 else ''} "
            f"of (session, subject) units the reference does not annotate (first: line "
            f"{_lines_of(detections)[i]}, {message})"
        )
    keep = ~unknown
    out = detections.loc[keep].reset_index(drop=True)
    out.attrs = dict(detections.attrs)
    out.attrs["lines"] = _shared_lines(_lines_of(detections)[keep])
    return out, codes[keep], count
