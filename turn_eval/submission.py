"""Read a reference table and a submission, validate the submission, join them per clip.

The reference is any CSV with ``clip_id, angle_deg`` and, optionally, ``duration_s`` and
group columns (``scenario, location, cohort, subject, action, split``, or any other): the
Turn-H3.6M clip index and the Turn-REMAP labels both qualify as they are (DESIGN.md).
A submission is ``clip_id, angle_deg`` and, optionally, ``speed_deg_s``; extra columns are
kept and ignored.

Both are read the same forgiving way, because submissions come out of spreadsheets and
notebooks: header names match ignoring case and surrounding spaces; a UTF-8 byte-order mark is
dropped; the delimiter is a comma, a semicolon or a tab, whichever the header uses; with a
semicolon or tab delimiter a decimal comma (``12,5``) is read as a decimal point, as a
spreadsheet in a European locale exports it. Blank lines are skipped.

What the scoring is strict about, each found problem one :class:`TurnbenchError` naming the
file and the file's own line number (line 1 is the header): an empty file, a missing column,
a row with the wrong number of fields, an empty clip id, a non-numeric, NaN or infinite angle,
a negative angle (angles are magnitudes; ``abs_angles=True`` takes them as such), duplicate
clip ids, ids not in the reference, and reference ids missing from the submission (the first
ten and the count; ``allow_missing=True`` scores the rest and reports ``n_missing``). All
predicted angles below 2π while the reference's are not is only a warning: radians, perhaps.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError, require_columns
from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import quantise_deg
from turn_datasets.limits import MAX_ANGLE_DEG, MAX_SPEED_DEG_S
from turn_datasets.strings import count, stripped_objects, text_array

__all__ = [
    "GROUP_COLUMNS",
    "BIN_COLUMN",
    "JOINED_COLUMNS",
    "Joined",
    "read_reference",
    "read_predictions",
    "group_label",
]

#: The default groupings, in this order, when the reference has them (issue 5). ``bin_deg``
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
_MAX_LISTED = 10
_TWO_PI = 2 * math.pi


#: Columns read as numbers wherever they appear.
_NUMERIC = ("angle_deg", "duration_s", "speed_deg_s")
#: The plausibility bound of each bounded column (turn_datasets.limits; the README's error
#: section): above it a value is a typo or a unit mix-up, and 1.7e308 turned MAE into null.
_PLAUSIBLE = {"angle_deg": MAX_ANGLE_DEG, "speed_deg_s": MAX_SPEED_DEG_S}
_NAN_WORDS = ("nan", "+nan", "-nan", "na", "n/a", "null", "none")


@dataclass
class _Table:
    """A CSV as read: normalised header, stripped text cells, each row's line number.

    ``numbers`` holds the numeric columns the C parser could read as finite floats in one
    go; a column it could not read is parsed from its text by :func:`_numbers`, which then
    names the first bad line.
    """

    path: str
    header: tuple[str, ...]
    columns: dict[str, np.ndarray]
    numbers: dict[str, np.ndarray]
    lines: np.ndarray
    delimiter: str
    header_line: int
    ascii: bool = True


def _sniff_delimiter(header_line: str) -> str:
    # The header decides: a spreadsheet's export puts its delimiter between the column names.
    counts = {d: header_line.count(d) for d in (";", "\t", ",")}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] > 0 else ","


def _read_text(name: str, *, what: str) -> str:
    try:
        with open(name, encoding="utf-8-sig", newline="") as fh:
            return fh.read()
    except FileNotFoundError:
        raise TurnbenchError(f"{what} file not found", file=name) from None
    except IsADirectoryError:
        raise TurnbenchError(f"{what} is a folder, not a CSV file", file=name) from None
    except UnicodeDecodeError as exc:
        raise TurnbenchError(f"{what} file is not UTF-8 text ({exc.reason})", file=name) from None
    except OSError as exc:
        raise TurnbenchError(f"cannot read the {what} file: {exc.strerror}", file=name) from None


def _one_newline(text: str, name: str, *, what: str) -> str:
    """The text with ``\n`` line ends, refusing text that is not UTF-8 in disguise.

    UTF-16 without a byte-order mark decodes as "UTF-8" with a NUL after every ASCII
    character, and then every row "has 1 field"; old Mac and Excel exports end lines with a
    lone CR, which the csv module refuses, and files edited on two systems mix the three:
    each line end counts as one line, as an editor shows it.
    """
    if "\x00" in text:
        raise TurnbenchError(
            f"{what} file is not UTF-8 text: it holds NUL bytes, as UTF-16 text does",
            file=name,
            hint="save it as UTF-8 (CSV UTF-8 in a spreadsheet)",
        )
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text


def _check_header(header: list[str], *, name: str, line: int) -> None:
    seen: dict[str, int] = {}
    for i, col in enumerate(header):
        if col and col in seen:
            raise TurnbenchError(
                f"column {col!r} appears twice in the header (columns {seen[col] + 1} and {i + 1})",
                file=name,
                row=line,
            )
        seen[col] = i


def _wrong_width(n_fields: int, n_header: int, delimiter: str, *, name: str, line: int):
    return TurnbenchError(
        f"row has {n_fields} fields but the header has {n_header} (delimiter {delimiter!r})",
        file=name,
        row=line,
    )


def _stripped(values) -> np.ndarray:
    """Cells without surrounding white space, as an object array of ``str``."""
    return stripped_objects(values)


def _read_quoted(text: str, name: str, delimiter: str) -> _Table:
    """The exact reader: the csv module, for files with quoted fields (which may span lines)."""
    reader = csv.reader(io.StringIO(text), delimiter=delimiter)
    header: list[str] | None = None
    header_line = 0
    rows: list[list[str]] = []
    lines: list[int] = []
    start = 0
    for record in reader:
        # reader.line_num is the line a record ends on; it starts after the previous one.
        line = start + 1
        start = reader.line_num
        if not record or all(not cell.strip() for cell in record):
            continue
        if header is None:
            header = [cell.strip().lower() for cell in record]
            header_line = line
            _check_header(header, name=name, line=line)
            continue
        if len(record) != len(header):
            raise _wrong_width(len(record), len(header), delimiter, name=name, line=line)
        rows.append(record)
        lines.append(line)
    assert header is not None  # the text has a non-blank line
    cells = np.array(rows, dtype=object).reshape(len(rows), len(header))
    columns = {col: _stripped(cells[:, i]) for i, col in enumerate(header) if col}
    return _Table(
        path=name,
        header=tuple(header),
        columns=columns,
        numbers={},
        lines=np.asarray(lines, dtype=np.int64),
        delimiter=delimiter,
        header_line=header_line,
    )


#: A line of nothing but white space (or nothing) between two others. Starting with a
#: literal newline, it is searched for as fast as a substring (a pattern anchored with ^ in
#: multi-line mode is tried at every character).
_BLANK_BETWEEN = re.compile(r"\n[^\S\n]*\n")


def _has_blank_line(text: str) -> bool:
    """Whether any line of ``text`` (split on ``\n``) is empty or white space only."""
    if not text.partition("\n")[0].strip():
        return True
    if _BLANK_BETWEEN.search(text) is not None:
        return True
    return not text[text.rfind("\n") + 1 :].strip()


def _plain_lines(text: str, delimiter: str) -> tuple[str, int, np.ndarray, np.ndarray, bytes]:
    """Split a quote-free text into its header and body, skipping blank lines.

    Returns the header's text and line number, each body line's line number and number of
    fields, and the body's lines joined by ``\n`` for pandas, as UTF-8 (what its C parser
    reads: given text, it would encode it again).
    """
    last = text[:-1] if text.endswith("\n") else text
    if not _has_blank_line(last):
        # No blank line (the usual file): the header is line 1, the body the rest, as it is;
        # the fields per line are counted from the delimiters' and line ends' positions in
        # the UTF-8 bytes (delimiters and newlines are ASCII, never inside a multi-byte
        # character), without splitting the text into lines.
        header_text, _, body = last.partition("\n")
        if not body:
            return header_text, 1, np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64), b""
        encoded = body.encode("utf-8")
        data = np.frombuffer(encoded, dtype=np.uint8)
        # One scan for both marks: a line's delimiters are the marks between its newline
        # and the previous one (the body ends without a newline: its last line ends there).
        newline = data == 10
        marks = np.flatnonzero(newline | (data == ord(delimiter)))
        stops = np.append(np.flatnonzero(newline[marks]), marks.size)
        fields = np.diff(stops, prepend=-1)
        lines = np.arange(2, 2 + stops.size, dtype=np.int64)
        return header_text, 1, lines, fields, encoded
    # Variable-width strings: one long line must not widen every other one in memory.
    split = text.split("\n")
    all_lines = text_array(split)
    # Python's strip, as the fast path's: numpy's string functions drop trailing NULs, so a
    # line of a NUL would be blank here and not there.
    nonblank = np.fromiter((bool(line.strip()) for line in split), dtype=bool, count=len(split))
    numbers = np.flatnonzero(nonblank) + 1
    kept = all_lines[nonblank]
    body_lines = kept[1:]
    return (
        str(kept[0]),
        int(numbers[0]),
        numbers[1:].astype(np.int64),
        count(body_lines, delimiter) + 1,
        "\n".join(body_lines.tolist()).encode("utf-8"),
    )


def _well_formed_body(text: str, delimiter: str) -> tuple[str, bytes, int] | None:
    """The header's text, the body as UTF-8 and its number of lines, when the body holds
    exactly the delimiters of that many lines of the header's width (two or more fields, the
    delimiter not white space); else None.

    Then no line is blank (each would hold a delimiter), and no line has fewer fields than
    the header unless another has more, which pandas' C parser refuses (or, on the first
    line, takes as an index): :func:`_read_plain` checks that instead of counting each
    line's fields, which costs more than the parse of a clean file's numbers.
    """
    last = text[:-1] if text.endswith("\n") else text
    header_text, _, body = last.partition("\n")
    fields = header_text.count(delimiter) + 1
    if not body or not header_text.strip() or delimiter.isspace() or fields < 2:
        return None
    encoded = body.encode("utf-8")
    data = np.frombuffer(encoded, dtype=np.uint8)
    n_lines = int(np.count_nonzero(data == 10)) + 1
    if int(np.count_nonzero(data == ord(delimiter))) != (fields - 1) * n_lines:
        return None
    return header_text, encoded, n_lines


def _parse_body(
    joined: bytes, header: Sequence[str], delimiter: str, numeric_columns: Sequence[str]
) -> tuple[pd.DataFrame, set[int]]:
    """The body's fields by pandas' C parser, and which columns it gave as numbers."""
    options = {
        "sep": delimiter,
        "header": None,
        "names": list(range(len(header))),
        "keep_default_na": False,
        "quoting": csv.QUOTE_NONE,
        "skip_blank_lines": False,
        "engine": "c",
    }
    numeric = {i for i, col in enumerate(header) if col in numeric_columns}
    if numeric:
        # Numbers straight from the C parser (the clean, common case); anything it refuses
        # ("nan", an empty cell, a word) sends the file through the strict text path.
        try:
            frame = pd.read_csv(
                io.BytesIO(joined),
                # Text as object columns of str, as the table keeps them: pandas' str dtype
                # would be made only to be turned back into objects.
                dtype={i: ("float64" if i in numeric else object) for i in range(len(header))},
                decimal="," if delimiter != "," else ".",
                **options,
            )
        except ValueError:
            pass
        else:
            if all(np.isfinite(frame[i].to_numpy(dtype=np.float64)).all() for i in numeric):
                return frame, numeric
    return pd.read_csv(io.BytesIO(joined), dtype=object, **options), set()


def _read_plain(
    text: str,
    name: str,
    delimiter: str,
    numeric_columns: Sequence[str] = _NUMERIC,
    *,
    count_each_line: bool = False,
) -> _Table:
    """The fast reader, for files without quotes: one record per line, so every row's line
    number is known before pandas' C parser splits the fields (``numeric_columns`` as
    numbers where they all parse). Each line's fields are counted when the body's total
    says some line may be blank or of the wrong width (:func:`_well_formed_body`), or
    ``count_each_line``."""
    well_formed = None if count_each_line else _well_formed_body(text, delimiter)
    if well_formed is not None:
        header_text, joined, n_lines = well_formed
        header_line, lines, widths = 1, np.arange(2, 2 + n_lines, dtype=np.int64), None
    else:
        header_text, header_line, lines, widths, joined = _plain_lines(text, delimiter)
    header = [cell.strip().lower() for cell in header_text.split(delimiter)]
    _check_header(header, name=name, line=header_line)
    if widths is not None:
        wrong = np.flatnonzero(widths != len(header))
        if wrong.size:
            i = int(wrong[0])
            raise _wrong_width(
                int(widths[i]), len(header), delimiter, name=name, line=int(lines[i])
            )
    table = _Table(
        path=name,
        header=tuple(header),
        columns={},
        numbers={},
        lines=lines,
        delimiter=delimiter,
        header_line=header_line,
    )
    if lines.size == 0:
        table.columns = {col: np.empty(0, dtype=object) for col in header if col}
        return table
    try:
        frame, numeric = _parse_body(joined, header, delimiter, numeric_columns)
    except pd.errors.ParserError:
        if widths is not None:
            raise
        frame = None
    if widths is None and (frame is None or not isinstance(frame.index, pd.RangeIndex)):
        # A line with more fields than the header (and so one with fewer): counted line by
        # line to name the first.
        return _read_plain(text, name, delimiter, numeric_columns, count_each_line=True)
    assert frame is not None
    # White space around cells only matters when there is some; finding none is cheap.
    padded = b"\r" in joined or b" " in joined or (delimiter != "\t" and b"\t" in joined)
    for i, col in enumerate(header):
        if not col:
            continue
        if i in numeric:
            table.numbers[col] = frame[i].to_numpy(dtype=np.float64)
        else:
            cells = frame[i].to_numpy(dtype=object)
            table.columns[col] = _stripped(cells) if padded else cells
    return table


def _read_table(
    path: str | os.PathLike[str],
    *,
    what: str,
    numeric_columns: Sequence[str] = _NUMERIC,
    allow_no_rows: bool = False,
) -> _Table:
    """Read a CSV as :class:`_Table`; ``numeric_columns`` are parsed as numbers by the C
    parser when every cell of them is a finite number (else :func:`_numbers` parses them).
    A header without rows is refused unless ``allow_no_rows`` (a detector that found no
    turns writes one)."""
    name = os.fspath(path)
    text = _one_newline(_read_text(name, what=what), name, what=what)
    if not text or text.isspace():  # blank (strip would copy the whole text to say so)
        raise TurnbenchError(f"empty {what} file: no header and no rows", file=name)
    # The first line with something on it, found without splitting the whole text.
    first = re.search(r"\S", text)
    assert first is not None  # the text is not blank (checked above)
    start = first.start()
    end = text.find("\n", start)
    first_line = text[text.rfind("\n", 0, start) + 1 : end if end >= 0 else len(text)]
    delimiter = _sniff_delimiter(first_line)
    quoted = '"' in text
    table = (
        _read_quoted(text, name, delimiter)
        if quoted
        else _read_plain(text, name, delimiter, numeric_columns)
    )
    table.ascii = text.isascii()
    if table.lines.size == 0 and not allow_no_rows:
        raise TurnbenchError(
            f"empty {what} file: a header on line {table.header_line} and no rows", file=name
        )
    return table


def _require(table: _Table, required: Sequence[str], *, what: str) -> None:
    require_columns(
        table.header,
        required,
        what=what,
        file=table.path,
        row=table.header_line,
        note=" (matched ignoring case and spaces)",
    )


def _first_and_count(table: _Table, bad: np.ndarray) -> tuple[int, int, int]:
    where = np.flatnonzero(bad)
    return int(where[0]), int(table.lines[where[0]]), int(where.size)


def _and_more(count: int) -> str:
    return f" ({count - 1} more row{'s' if count > 2 else ''} like it)" if count > 1 else ""


def _refuse_rows(
    table: _Table, bad: np.ndarray, message: Callable[[int], str], *, hint: str | None = None
) -> None:
    """Raise for the first ``bad`` row (``message`` of its index), counting the others."""
    if bad.any():
        i, line, count = _first_and_count(table, bad)
        raise TurnbenchError(message(i) + _and_more(count), file=table.path, row=line, hint=hint)


def _numbers(
    table: _Table,
    column: str,
    *,
    allow_empty: bool,
    allow_negative: bool,
    negative_hint: str | None,
) -> np.ndarray:
    """A numeric column, strictly: empty cells are NaN only when ``allow_empty``."""
    values = table.numbers.get(column)
    if values is None:
        raw = table.columns[column]
        text = pd.Series(raw, dtype=object)
        if table.delimiter != ",":
            # A decimal comma only makes sense when the comma is not the delimiter.
            text = text.str.replace(",", ".", regex=False)
        values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=np.float64)
        undefined = ~np.isfinite(values)
        # Only the offending cells are looked at one by one.
        where = np.flatnonzero(undefined)
        words = text.iloc[where].str.lower()
        kinds = np.select(
            [
                (words == "").to_numpy(),
                words.isin(_NAN_WORDS).to_numpy(),
                np.isinf(values[where]),
            ],
            ["empty", "nan", "inf"],
            default="bad",
        )
        for kind in ("bad", "empty", "nan", "inf"):
            if kind == "empty" and allow_empty:
                continue
            hits = where[kinds == kind]
            if not hits.size:
                continue
            i, line, count = int(hits[0]), int(table.lines[hits[0]]), int(hits.size)
            message = {
                "bad": f"{column} {raw[i]!r} is not a number",
                "empty": f"{column} is empty",
                "nan": f"{column} is NaN ({raw[i]!r})",
                "inf": f"{column} is infinite ({raw[i]!r})",
            }[kind]
            raise TurnbenchError(message + _and_more(count), file=table.path, row=line)
    bound = _PLAUSIBLE.get(column)
    if bound is not None:
        _refuse_rows(
            table,
            np.abs(values) > bound,
            lambda i: f"{column} {values[i]:g} is beyond the plausible {bound:g}",
            hint="see the bounds in the README's error section",
        )
    if not allow_negative:
        _refuse_rows(
            table,
            values < 0,
            lambda i: f"{column} is negative ({values[i]:g})",
            hint=negative_hint,
        )
    return values


def _clip_ids(table: _Table) -> np.ndarray:
    ids = table.columns["clip_id"]
    if not table.ascii:
        # "Café" typed on a Mac (NFD) and on Windows (NFC) are different strings but the
        # same id; both sides are compared in NFC.
        ids = pd.Series(ids, dtype=object).str.normalize("NFC").to_numpy(dtype=object)
    _refuse_rows(table, ids == "", lambda _: "clip_id is empty")
    duplicate = pd.Series(ids, dtype=object).duplicated(keep="first").to_numpy()
    if duplicate.any():
        i, line, count = _first_and_count(table, duplicate)
        first = int(np.flatnonzero(ids == ids[i])[0])
        raise TurnbenchError(
            f"duplicate clip_id {ids[i]!r}, first on line {int(table.lines[first])}"
            f"{_and_more(count)}",
            file=table.path,
            row=line,
        )
    return ids


def _list_ids(ids: Sequence[str]) -> str:
    shown = ", ".join(repr(str(i)) for i in ids[:_MAX_LISTED])
    return shown + (", ..." if len(ids) > _MAX_LISTED else "")


def group_label(value: object) -> str:
    """The label of a group as the scores print it: bins as ``45``, text as it is."""
    if isinstance(value, (float, np.floating)):
        return f"{float(value):g}"
    return str(value)


def read_reference(path: str | os.PathLike[str], *, bin_width_deg: float = 45.0) -> pd.DataFrame:
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
        column of the file as stripped strings, in file order. ``attrs["path"]`` is the file
        and ``attrs["lines"]`` each row's line number.

    Raises
    ------
    TurnbenchError
        The same problems as a submission (see the module docstring), each with its line.
    """
    table = _read_table(path, what="reference")
    _require(table, ("clip_id", "angle_deg"), what="the reference")
    ids = _clip_ids(table)
    angle = _numbers(
        table,
        "angle_deg",
        allow_empty=False,
        allow_negative=False,
        negative_hint="reference angles are magnitudes in degrees",
    )
    data: dict[str, object] = {"clip_id": ids, "angle_deg": angle}
    dtypes: dict[str, str] = {"clip_id": "str", "angle_deg": "float64"}
    if "duration_s" in table.header:
        data["duration_s"] = _numbers(
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
        if col and col not in dtypes and col not in _NUMERIC:
            data[col] = table.columns[col]
            dtypes[col] = "str"
    frame = typed_frame(pd.DataFrame(data), dtypes)
    frame.attrs["path"] = table.path
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
    bin_width_deg
        The bin width ``bin_deg`` was computed with.
    """

    table: pd.DataFrame
    n_missing: int
    missing_ids: tuple[str, ...] = field(repr=False)
    has_durations: bool
    predictions_path: str
    reference_path: str
    bin_width_deg: float = 45.0

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
    table: _Table,
    ids: np.ndarray,
    ref: pd.DataFrame,
    *,
    ref_path: str,
    allow_missing: bool,
    say: Callable[[str], None],
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Each prediction's row in the reference, which reference rows are covered, and the
    ids of those that are not (refused unless ``allow_missing``; an unknown id always)."""
    ref_ids = ref["clip_id"].to_numpy(dtype=object)
    position = pd.Index(ref_ids).get_indexer(ids)
    unknown = position < 0
    if unknown.any():
        _, line, count = _first_and_count(table, unknown)
        listed = _list_ids(list(ids[unknown]))
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
            f"{_list_ids(missing_ids)}"
        )
        if not allow_missing:
            raise TurnbenchError(
                message,
                file=table.path,
                hint="pass --allow-missing to score the clips that are there",
            )
        say(f"{table.path}: {message}; scoring the other {int(covered.sum())}")

    return position, covered, missing_ids


def read_predictions(
    path: str | os.PathLike[str],
    reference: pd.DataFrame | str | os.PathLike[str],
    *,
    allow_missing: bool = False,
    abs_angles: bool = False,
    warn: Callable[[str], None] | None = None,
    bin_width_deg: float = 45.0,
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
        Every problem listed in the module docstring, with the file and line.
    """
    say = warn if warn is not None else (lambda message: None)
    ref = (
        reference
        if isinstance(reference, pd.DataFrame)
        else read_reference(reference, bin_width_deg=bin_width_deg)
    )
    ref_path = str(ref.attrs.get("path", "reference"))
    table = _read_table(path, what="predictions")
    _require(table, ("clip_id", "angle_deg"), what="the predictions")
    ids = _clip_ids(table)
    hint = "angles are magnitudes; pass --abs to take the absolute value"
    angle = _numbers(
        table, "angle_deg", allow_empty=False, allow_negative=abs_angles, negative_hint=hint
    )
    speed = None
    if "speed_deg_s" in table.header:
        # An empty speed means "not given": the metric falls back to angle / duration.
        speed = _numbers(
            table, "speed_deg_s", allow_empty=True, allow_negative=abs_angles, negative_hint=hint
        )
    if abs_angles:
        angle = np.abs(angle)
        speed = None if speed is None else np.abs(speed)

    position, covered, missing_ids = _place_in_reference(
        table, ids, ref, ref_path=ref_path, allow_missing=allow_missing, say=say
    )
    ref_angle = ref["angle_deg"].to_numpy(dtype=np.float64)
    if angle.size and float(np.max(angle)) < _TWO_PI and float(np.max(ref_angle)) >= _TWO_PI:
        say(
            f"{table.path}: every predicted angle is below 2π (the largest is "
            f"{float(np.max(angle)):.4g}) while the reference's reach "
            f"{float(np.max(ref_angle)):.4g}: are they in radians? turnbench expects degrees"
        )

    # Reference order, so the output does not depend on the submission's row order.
    pred_angle = np.full(ref.shape[0], np.nan)
    pred_angle[position] = angle
    pred_speed = np.full(ref.shape[0], np.nan)
    if speed is not None:
        pred_speed[position] = speed
    has_durations = "duration_s" in ref.columns
    duration = (
        ref["duration_s"].to_numpy(dtype=np.float64)
        if has_durations
        else np.full(ref.shape[0], np.nan)
    )
    data: dict[str, object] = {
        "clip_id": ref["clip_id"][covered].reset_index(drop=True),
        "ref_angle_deg": ref_angle[covered],
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
        n_missing=len(missing_ids),
        missing_ids=missing_ids,
        has_durations=has_durations,
        predictions_path=table.path,
        reference_path=ref_path,
        bin_width_deg=float(ref.attrs.get("bin_width_deg", bin_width_deg)),
    )
