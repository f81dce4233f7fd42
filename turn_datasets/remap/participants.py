"""The participants table of Turn-REMAP: who is who, and in which cohort.

``subject, cohort, pair, sex, age, years_since_diagnosis``; cohort ``PD`` (Parkinson's
disease) or ``HC`` (healthy control), as the paper's 12 + 12 people (Cheng et al.,
Section 3.2). :func:`read_participants` reads and checks it, naming the file and row of any
problem.
"""

from __future__ import annotations

import math
from os import PathLike
from typing import Any

import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.usertable import read_table, require

__all__ = [
    "PARTICIPANT_COLUMNS",
    "COHORTS",
    "read_participants",
]


#: Column contract of the participants table after :func:`read_participants`.
PARTICIPANT_COLUMNS = {
    "subject": "str",
    "cohort": "str",
    "pair": "str",
    "sex": "str",
    "age": "float64",
    "years_since_diagnosis": "float64",
}


COHORTS = ("PD", "HC")


def _number(text: str, *, column: str, file: str, row: int, lo: float, hi: float) -> float:
    text = text.strip()
    if not text:
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise TurnbenchError(f"{column} {text!r} is not a number", file=file, row=row) from None
    if not math.isfinite(value) or not lo <= value <= hi:
        raise TurnbenchError(f"{column} {text!r} is outside {lo:g} to {hi:g}", file=file, row=row)
    return value


def read_participants(path: str | PathLike[str]) -> pd.DataFrame:
    """Read and check the participants table.

    Parameters
    ----------
    path
        CSV with header ``subject, cohort, pair, sex, age, years_since_diagnosis`` (in any
        order; extra columns are ignored). ``cohort`` is ``PD`` or ``HC`` (any case); ``pair``
        (the matched PD/HC pair), ``sex``, ``age`` (years) and ``years_since_diagnosis`` may be
        empty; a healthy control has no years since diagnosis.

    Returns
    -------
    pandas.DataFrame
        :data:`PARTICIPANT_COLUMNS`, one row per subject in file order; ``attrs["source"]``
        is the file name.

    Raises
    ------
    TurnbenchError
        Naming the file and line: a missing column, an empty or repeated subject, a cohort
        other than PD or HC, an age or duration that is not a number in range, a control with
        years since diagnosis, a diagnosis longer ago than the subject's age.
    """
    file = str(path)
    # The one reader of user tables (turn_datasets.usertable): UTF-8 with or without a BOM,
    # header names ignoring case and spaces, comma, semicolon or tab, blank lines skipped.
    table = read_table(path, what="participants table", numeric_columns=(), allow_no_rows=True)
    require(table, list(PARTICIPANT_COLUMNS), what="the participants table")
    rows: list[dict[str, Any]] = []
    seen: dict[str, int] = {}
    for i, line in enumerate(table.lines.tolist()):

        def cell(name: str, i: int = i) -> str:
            return str(table.columns[name][i])

        subject = cell("subject")
        if not subject:
            raise TurnbenchError("empty subject", file=file, row=line)
        if subject in seen:
            raise TurnbenchError(
                f"subject {subject!r} is listed twice (first on line {seen[subject]})",
                file=file,
                row=line,
            )
        seen[subject] = line
        cohort = cell("cohort").upper()
        if cohort not in COHORTS:
            raise TurnbenchError(
                f"cohort {cell('cohort')!r} of {subject!r} is not PD or HC",
                file=file,
                row=line,
            )
        age = _number(cell("age"), column="age", file=file, row=line, lo=0, hi=130)
        years = _number(
            cell("years_since_diagnosis"),
            column="years_since_diagnosis",
            file=file,
            row=line,
            lo=0,
            hi=130,
        )
        if cohort == "HC" and years > 0:
            raise TurnbenchError(
                f"healthy control {subject!r} has years_since_diagnosis {years:g}; leave it empty",
                file=file,
                row=line,
            )
        if years > age:  # False when either is NaN
            raise TurnbenchError(
                f"{subject!r} was diagnosed {years:g} years ago but is {age:g}",
                file=file,
                row=line,
            )
        rows.append(
            {
                "subject": subject,
                "cohort": cohort,
                "pair": cell("pair"),
                "sex": cell("sex"),
                "age": age,
                "years_since_diagnosis": years,
            }
        )
    if not rows:
        raise TurnbenchError("participants table lists no subject", file=file)
    out = typed_frame(pd.DataFrame(rows, columns=list(PARTICIPANT_COLUMNS)), PARTICIPANT_COLUMNS)
    out.attrs["source"] = file
    return out
