"""The REMAP Open release's rater spreadsheet: one row per turning episode.

The University of Bristol's REMAP Open dataset (REal-world Mobility Activities in
Parkinson's disease, PD SENSORS study) ships its turn labels as
``Turning/Data/turning_human_labels/Turning_human_labels.xls`` (its description also says
``.xlsx``); a CSV export of it is read the same way. The columns, as the release's
description gives them:

``Turn ID``
    The ``n_<id>`` of the turn's skeleton folder ``Pt<participant>_<PD|C>_n_<id>``.
``Participant ID number``, ``PD_or_C``
    The participant (``204`` or ``Pt204``) and the group: ``PD`` or ``C`` (control, ``HC``
    here).
``number_of_turning_steps``
    Steps counted after the initial stance (a non-negative integer; may be empty).
``turning_angle``
    To the nearest 45° (``90_degrees``, ``90 degrees`` or ``90``): the bin.
``type_of_turn``
    ``pivot_turn`` (one or both feet swivel in place), ``step_turn`` (three steps or more
    without pivoting), or empty.
``turning_duration``
    Seconds (may be empty).
``On_or_Off_medication``
    ``Control``, ``On medication`` or ``Off medication`` (long-acting dopaminergic
    medication withheld for more than 24 h and short-acting for more than 12 h).
``DBS_state``
    ``Control``, ``On DBS``, ``Off DBS``, or ``-`` for no stimulator.
``clinical_assessment``
    ``yes`` (during a researcher's assessment: ``clinical``) or ``no`` (free-living).

A ``.xls`` is read with xlrd itself: pandas 3.1 deprecates its xlrd engine (pandas 4 drops
it), while xlrd still reads every BIFF8 file. A ``.xlsx`` is read by pandas with openpyxl,
a CSV by pandas. Every cell is read as text or a number, never guessed into a date.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import pandas as pd

from turn_datasets.errors import TurnbenchError, require_columns

__all__ = [
    "SHEET_COLUMNS",
    "SHEET_SUFFIXES",
    "TURN_TYPES",
    "MEDICATION",
    "DBS",
    "SheetRow",
    "read_sheet",
]

#: The spreadsheet's columns (matched after trimming spaces, in any case).
SHEET_COLUMNS = (
    "Turn ID",
    "Participant ID number",
    "PD_or_C",
    "number_of_turning_steps",
    "turning_angle",
    "type_of_turn",
    "turning_duration",
    "On_or_Off_medication",
    "DBS_state",
    "clinical_assessment",
)
#: Spreadsheet formats read: the release's (.xls, .xlsx) and a CSV export.
SHEET_SUFFIXES = (".xls", ".xlsx", ".csv")

_COHORTS = {"pd": "PD", "c": "HC"}
#: ``type_of_turn`` -> ``turn_type`` (empty: not labelled).
TURN_TYPES = {"pivot_turn": "pivot", "step_turn": "step", "": ""}
#: ``On_or_Off_medication`` -> ``medication``.
MEDICATION = {"control": "control", "on medication": "on", "off medication": "off"}
#: ``DBS_state`` -> ``dbs`` (``-``: no stimulator).
DBS = {"control": "control", "on dbs": "on", "off dbs": "off", "-": "none"}
_SCENARIOS = {"yes": "clinical", "no": "free-living"}
_ANGLE = re.compile(r"^\s*([0-9]+(?:\.[0-9]*)?)\s*(?:[_ ]?deg(?:rees?)?)?\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class SheetRow:
    """One turning episode of the spreadsheet, checked and in turnbench's words."""

    row: int
    turn_id: str
    subject: str
    cohort: str
    steps: int | None
    angle_deg: float
    turn_type: str
    duration_s: float
    medication: str
    dbs: str
    scenario: str


def _text(value: Any) -> str:
    """A cell as text: an integral number without ``.0`` (xlrd reads every number as float)."""
    if value is None:
        return ""
    if isinstance(value, float):
        if math.isnan(value):
            return ""
        if value.is_integer():
            return str(int(value))
    return " ".join(str(value).split())


def _read_cells(path: Path) -> tuple[list[str], list[tuple[int, list[Any]]]]:
    """The header and ``(row number, cells)`` of the first sheet (row 1 = the header)."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".xls":
            import xlrd

            with xlrd.open_workbook(str(path), on_demand=True) as book:
                sheet = book.sheet_by_index(0)
                table = [sheet.row_values(i) for i in range(sheet.nrows)]
        else:
            if suffix == ".xlsx":
                frame = pd.read_excel(path, header=None, dtype=object, engine="openpyxl")
            else:
                frame = pd.read_csv(
                    path,
                    header=None,
                    dtype=str,
                    keep_default_na=False,
                    skip_blank_lines=False,
                    encoding="utf-8-sig",
                )
            table = frame.astype(object).where(frame.notna(), None).values.tolist()
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise TurnbenchError(f"cannot read the spreadsheet: {exc}", file=path) from None
    except Exception as exc:  # xlrd, openpyxl and zipfile raise their own types
        raise TurnbenchError(
            f"cannot read the spreadsheet ({type(exc).__name__}: {exc})", file=path
        ) from None
    if not table:
        raise TurnbenchError("the spreadsheet is empty", file=path, row=1)
    header = [_text(c) for c in table[0]]
    rows = [(i + 1, list(cells)) for i, cells in enumerate(table) if i > 0]
    return header, [(n, cells) for n, cells in rows if any(_text(c) for c in cells)]


def _key(value: str) -> str:
    """A value as compared: lower case, underscores as spaces, single spaces."""
    return " ".join(value.lower().replace("_", " ").split())


def _choice(value: str, choices: dict[str, str], *, column: str, file: Path, row: int) -> str:
    found = {_key(k): v for k, v in choices.items()}.get(_key(value))
    if found is None:
        known = ", ".join(repr(k) for k in choices if k)
        raise TurnbenchError(f"{column} {value!r} is not one of {known}", file=file, row=row)
    return found


def _number(value: str, *, column: str, file: Path, row: int) -> float:
    try:
        x = float(value)
    except ValueError:
        raise TurnbenchError(f"{column} {value!r} is not a number", file=file, row=row) from None
    if not math.isfinite(x) or x < 0:
        raise TurnbenchError(
            f"{column} {value!r} is not a finite non-negative number", file=file, row=row
        )
    return x


def _angle(value: str, *, file: Path, row: int) -> float:
    match = _ANGLE.match(value)
    angle = float(match.group(1)) if match else math.nan
    if not (angle > 0 and angle % 45 == 0):
        raise TurnbenchError(
            f"turning_angle {value!r} is not a positive multiple of 45 degrees",
            file=file,
            row=row,
            hint="the release gives the angle to the nearest 45°, as 90_degrees or 90",
        )
    return angle


def _steps(value: str, *, file: Path, row: int) -> int | None:
    if not value:
        return None
    x = _number(value, column="number_of_turning_steps", file=file, row=row)
    if not x.is_integer():
        raise TurnbenchError(
            f"number_of_turning_steps {value!r} is not a whole number", file=file, row=row
        )
    return int(x)


def _row(cells: dict[str, str], *, file: Path, row: int) -> SheetRow:
    turn_id = cells["Turn ID"]
    participant = cells["Participant ID number"]
    if not turn_id:
        raise TurnbenchError("empty Turn ID", file=file, row=row)
    if not participant:
        raise TurnbenchError("empty Participant ID number", file=file, row=row)
    subject = participant if participant.lower().startswith("pt") else f"Pt{participant}"
    duration = cells["turning_duration"]
    return SheetRow(
        row=row,
        turn_id=turn_id,
        subject="Pt" + subject[2:],
        cohort=_choice(cells["PD_or_C"], _COHORTS, column="PD_or_C", file=file, row=row),
        steps=_steps(cells["number_of_turning_steps"], file=file, row=row),
        angle_deg=_angle(cells["turning_angle"], file=file, row=row),
        turn_type=_choice(
            cells["type_of_turn"], TURN_TYPES, column="type_of_turn", file=file, row=row
        ),
        duration_s=(
            _number(duration, column="turning_duration", file=file, row=row)
            if duration
            else math.nan
        ),
        medication=_choice(
            cells["On_or_Off_medication"],
            MEDICATION,
            column="On_or_Off_medication",
            file=file,
            row=row,
        ),
        dbs=_choice(cells["DBS_state"], DBS, column="DBS_state", file=file, row=row),
        scenario=_choice(
            cells["clinical_assessment"],
            _SCENARIOS,
            column="clinical_assessment",
            file=file,
            row=row,
        ),
    )


def read_sheet(path: str | PathLike[str]) -> list[SheetRow]:
    """Read and check the rater spreadsheet (``.xls``, ``.xlsx`` or CSV).

    Parameters
    ----------
    path
        The spreadsheet; its first sheet is read, the header on row 1. Blank rows are
        skipped; row numbers are the spreadsheet's own.

    Returns
    -------
    list of SheetRow
        One per turning episode, in sheet order.

    Raises
    ------
    TurnbenchError
        Naming the file and row: a missing column, a duplicate ``Turn ID`` (with the first
        row), an empty ``Turn ID`` or participant, an unknown ``PD_or_C``, medication, DBS,
        turn type or ``clinical_assessment`` value, an angle that is not a positive multiple
        of 45, a step count or duration that is not a non-negative number.
    """
    file = Path(path)
    header, rows = _read_cells(file)
    canonical = {c.lower(): c for c in SHEET_COLUMNS}
    names = [canonical.get(h.lower(), h) for h in header]
    require_columns(
        names, SHEET_COLUMNS, what="the rater spreadsheet", file=file, note=" (any case)"
    )
    where = {c: names.index(c) for c in SHEET_COLUMNS}
    out: list[SheetRow] = []
    first: dict[str, int] = {}
    for number, cells in rows:
        padded = cells + [None] * (len(header) - len(cells))
        values = {c: _text(padded[i]) for c, i in where.items()}
        parsed = _row(values, file=file, row=number)
        if parsed.turn_id in first:
            raise TurnbenchError(
                f"Turn ID {parsed.turn_id!r} is listed twice (first on row "
                f"{first[parsed.turn_id]})",
                file=file,
                row=number,
            )
        first[parsed.turn_id] = number
        out.append(parsed)
    if not out:
        raise TurnbenchError("the rater spreadsheet has no rows", file=file, row=2)
    return out
