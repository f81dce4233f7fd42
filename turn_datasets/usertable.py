"""The one reader of user tables: a CSV read with each row's own line number.

Every table a user hands turnbench (a submission, a reference, detections, sessions, context,
a clip index, a participants table, overrides) is read here (here, not in the harness,
because the curation's readers use it too and ``turn_datasets`` never imports ``turn_eval``), the same forgiving way, because
such files come out of spreadsheets and notebooks: the text is UTF-8 with or without a
byte-order mark; header names match ignoring case and surrounding spaces; the delimiter is a
comma, a semicolon or a tab, whichever the header uses; with a semicolon or tab delimiter a
decimal comma (``12,5``) is read as a decimal point, as a spreadsheet in a European locale
exports it; blank lines are skipped; CR and CRLF line ends count as one line each.

What is refused, as one :class:`~turn_datasets.errors.TurnbenchError` naming the file and the
file's own line number (line 1 is the header): a file that is missing, a folder, not UTF-8 or
UTF-16 in disguise, empty, or a header without rows; a column named twice; a row with the
wrong number of fields. :func:`numbers` then reads a numeric column strictly (not a number,
empty, NaN, infinite, beyond its plausible bound, negative), naming the first bad line and
counting the others.

A file without quotes is split by pandas' C parser, which reads the numeric columns in the
same pass (:func:`read_table`'s ``numeric_columns``) and numbers the text columns of few
distinct values a reader asks for (``coded_columns``); a quoted file goes through the csv
module; both give the same :class:`Table` (the csv module's without codes).
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError, require_columns
from turn_datasets.limits import MAX_ANGLE_DEG, MAX_SPEED_DEG_S
from turn_datasets.render.numbers import counted
from turn_datasets.strings import count, stripped_objects, text_array

__all__ = [
    "NUMERIC",
    "PLAUSIBLE",
    "Table",
    "read_table",
    "require",
    "numbers",
    "refuse_rows",
    "first_and_count",
    "and_more",
    "list_ids",
    "Problems",
    "reading_notes",
]

#: At most this many ids are listed in one message (then "...").
MAX_LISTED = 10


#: Columns read as numbers wherever they appear.
NUMERIC = ("angle_deg", "duration_s", "speed_deg_s")
#: The plausibility bound of each bounded column (turn_datasets.limits; the README's error
#: section): above it a value is a typo or a unit mix-up, and 1.7e308 turned MAE into null.
PLAUSIBLE = {"angle_deg": MAX_ANGLE_DEG, "speed_deg_s": MAX_SPEED_DEG_S}
_NAN_WORDS = ("nan", "+nan", "-nan", "na", "n/a", "null", "none")


@dataclass
class Table:
    """A CSV as read: normalised header, stripped text cells, each row's line number.

    ``numbers`` holds the numeric columns the C parser could read as finite floats in one
    go; a column it could not read is parsed from its text by :func:`numbers`, which then
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
    #: How many cells of each text column had white space around them (read without it).
    padded: dict[str, int] = field(default_factory=dict)
    #: The sha256 of the file's bytes as read (a signature names the input by it, without
    #: reading the file again).
    sha256: str = ""
    #: Each of :func:`read_table`'s ``coded_columns`` as the C parser numbered it: each row's
    #: number (int64) and each number's text, ``columns[col] == names[codes]`` (a column the
    #: fast path did not read is absent: its reader numbers it itself).
    codes: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


def _sniff_delimiter(header_line: str) -> str:
    # The header decides: a spreadsheet's export puts its delimiter between the column names.
    counts = {d: header_line.count(d) for d in (";", "\t", ",")}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] > 0 else ","


def _read_text(name: str, *, what: str) -> tuple[str, bytes, str]:
    """The file's text (UTF-8, a byte-order mark dropped), its bytes and their sha256: one
    read serves all three."""
    try:
        with open(name, "rb") as fh:
            data = fh.read()
    except FileNotFoundError:
        raise TurnbenchError(f"{what} file not found", file=name) from None
    except IsADirectoryError:
        raise TurnbenchError(f"{what} is a folder, not a CSV file", file=name) from None
    except OSError as exc:
        raise TurnbenchError(f"cannot read the {what} file: {exc.strerror}", file=name) from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise TurnbenchError(f"{what} file is not UTF-8 text ({exc.reason})", file=name) from None
    return text, data, hashlib.sha256(data).hexdigest()


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


def _records(text: str, name: str, delimiter: str) -> Iterator[tuple[int, list[str]]]:
    """Each record of the csv module's reader and the line it starts on.

    A record the module cannot read is one error naming the line where it starts: above
    all a stray quote, which opens a field that runs on until the module's field limit
    (131,072 characters) stops it with a ``_csv.Error``.
    """
    reader = csv.reader(io.StringIO(text), delimiter=delimiter)
    start = 0
    while True:
        try:
            record = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            if "field limit" in str(exc):
                message = (
                    f"a field runs on past {csv.field_size_limit():,} characters from this "
                    'line: a quote (") that is never closed?'
                )
            else:
                message = f"not a readable CSV: {exc}"
            raise TurnbenchError(message, file=name, row=start + 1) from None
        # reader.line_num is the line a record ends on; it starts after the previous one.
        line = start + 1
        start = reader.line_num
        yield line, record


def _read_quoted(text: str, name: str, delimiter: str) -> Table:
    """The exact reader: the csv module, for files with quoted fields (which may span lines)."""
    header: list[str] | None = None
    header_line = 0
    rows: list[list[str]] = []
    lines: list[int] = []
    for line, record in _records(text, name, delimiter):
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
    padded = {
        col: int(np.count_nonzero(columns[col] != cells[:, i]))
        for i, col in enumerate(header)
        if col
    }
    return Table(
        path=name,
        header=tuple(header),
        columns=columns,
        numbers={},
        lines=np.asarray(lines, dtype=np.int64),
        delimiter=delimiter,
        header_line=header_line,
        padded={c: n for c, n in padded.items() if n},
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


@dataclass(frozen=True)
class _Body:
    """The rows' text as UTF-8 for pandas' C parser: ``data`` from byte ``start`` on (the
    file's own bytes after its header: no copy of them)."""

    data: bytes
    start: int = 0

    def holds(self, byte: bytes) -> bool:
        return self.data.find(byte, self.start) >= 0

    def stream(self) -> io.BytesIO:
        # A stream over the bytes themselves, positioned at the rows (pandas' ``skiprows``
        # would test every line against a set of rows to skip).
        out = io.BytesIO(self.data)
        out.seek(self.start)
        return out


#: Bytes compared at a time when counting line ends and delimiters: the comparison's mask
#: stays in cache instead of being a second copy of a large file.
_COUNT_CHUNK = 1 << 18


def _count_two(data: np.ndarray, first: int, second: int) -> tuple[int, int]:
    """How many bytes of ``data`` (uint8) equal ``first``, and how many ``second``."""
    mask = np.empty(min(_COUNT_CHUNK, data.size), dtype=bool)
    n_first = n_second = 0
    for at in range(0, data.size, _COUNT_CHUNK):
        part = data[at : at + _COUNT_CHUNK]
        out = mask[: part.size]
        n_first += int(np.count_nonzero(np.equal(part, first, out=out)))
        n_second += int(np.count_nonzero(np.equal(part, second, out=out)))
    return n_first, n_second


def _well_formed_body(
    text: str, delimiter: str, raw: bytes | None = None
) -> tuple[str, _Body, int] | None:
    """The header's text, the body and its number of lines, when the body holds exactly the
    delimiters of that many lines of the header's width (two or more fields, the delimiter
    not white space); else None. ``raw``: the file's bytes, when ``text`` is exactly what
    they decode to (then the body is read from them, not encoded again).

    Then no line is blank (each would hold a delimiter), and no line has fewer fields than
    the header unless another has more, which pandas' C parser refuses (or, on the first
    line, takes as an index): :func:`_read_plain` checks that instead of counting each
    line's fields, which costs more than the parse of a clean file's numbers.
    """
    stop = len(text) - 1 if text.endswith("\n") else len(text)
    cut = text.find("\n", 0, stop)
    if cut < 0:
        return None
    header_text = text[:cut]
    fields = header_text.count(delimiter) + 1
    if cut + 1 >= stop or not header_text.strip() or delimiter.isspace() or fields < 2:
        return None
    if raw is None:
        body = _Body(text[cut + 1 : stop].encode("utf-8"))
        end = len(body.data)
    else:
        # The header's line end is the bytes' first newline (a byte-order mark before it).
        body = _Body(raw, start=raw.index(b"\n") + 1)
        end = len(raw) - 1 if raw.endswith(b"\n") else len(raw)
    data = np.frombuffer(body.data, dtype=np.uint8)[body.start : end]
    newlines, delimiters = _count_two(data, 10, ord(delimiter))
    n_lines = newlines + 1
    if delimiters != (fields - 1) * n_lines:
        return None
    return header_text, body, n_lines


def _parse_body(
    body: _Body,
    header: Sequence[str],
    delimiter: str,
    numeric_columns: Sequence[str],
    coded_columns: Sequence[str] = (),
) -> tuple[pd.DataFrame, set[int]]:
    """The body's fields by pandas' C parser, and which columns it gave as numbers (then the
    ``coded_columns`` are categorical: numbered as they are split, no object made per cell)."""
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
                body.stream(),
                # Text as object columns of str, as the table keeps them: pandas' str dtype
                # would be made only to be turned back into objects.
                dtype={
                    i: "float64" if i in numeric else "category" if col in coded_columns else object
                    for i, col in enumerate(header)
                },
                decimal="," if delimiter != "," else ".",
                **options,
            )
        except ValueError:
            pass
        else:
            if all(np.isfinite(frame[i].to_numpy(dtype=np.float64)).all() for i in numeric):
                return frame, numeric
    return pd.read_csv(body.stream(), dtype=object, **options), set()


def _read_plain(
    text: str,
    name: str,
    delimiter: str,
    numeric_columns: Sequence[str] = NUMERIC,
    *,
    count_each_line: bool = False,
    raw: bytes | None = None,
    coded_columns: Sequence[str] = (),
) -> Table:
    """The fast reader, for files without quotes: one record per line, so every row's line
    number is known before pandas' C parser splits the fields (``numeric_columns`` as
    numbers where they all parse). Each line's fields are counted when the body's total
    says some line may be blank or of the wrong width (:func:`_well_formed_body`), or
    ``count_each_line``. ``raw``: the file's bytes, when ``text`` is what they decode to;
    ``coded_columns``: as :func:`read_table`'s."""
    well_formed = None if count_each_line else _well_formed_body(text, delimiter, raw)
    if well_formed is not None:
        header_text, body, n_lines = well_formed
        header_line, lines, widths = 1, np.arange(2, 2 + n_lines, dtype=np.int64), None
    else:
        header_text, header_line, lines, widths, joined = _plain_lines(text, delimiter)
        body = _Body(joined)
    header = [cell.strip().lower() for cell in header_text.split(delimiter)]
    _check_header(header, name=name, line=header_line)
    if widths is not None:
        wrong = np.flatnonzero(widths != len(header))
        if wrong.size:
            i = int(wrong[0])
            raise _wrong_width(
                int(widths[i]), len(header), delimiter, name=name, line=int(lines[i])
            )
    table = Table(
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
        frame, numeric = _parse_body(body, header, delimiter, numeric_columns, coded_columns)
    except pd.errors.ParserError:
        if widths is not None:
            raise
        frame = None
    if widths is None and (frame is None or not isinstance(frame.index, pd.RangeIndex)):
        # A line with more fields than the header (and so one with fewer): counted line by
        # line to name the first.
        return _read_plain(
            text,
            name,
            delimiter,
            numeric_columns,
            count_each_line=True,
            coded_columns=coded_columns,
        )
    assert frame is not None
    # White space around cells only matters when there is some; finding none is cheap.
    padded = body.holds(b"\r") or body.holds(b" ") or (delimiter != "\t" and body.holds(b"\t"))
    for i, col in enumerate(header):
        if not col:
            continue
        if i in numeric:
            table.numbers[col] = frame[i].to_numpy(dtype=np.float64)
        elif isinstance(frame[i].dtype, pd.CategoricalDtype):
            _coded_column(table, col, frame[i].array, padded=padded)
        else:
            cells = frame[i].to_numpy(dtype=object)
            table.columns[col] = _stripped(cells) if padded else cells
            if padded:
                n_padded = int(np.count_nonzero(table.columns[col] != cells))
                if n_padded:
                    table.padded[col] = n_padded
    return table


def _coded_column(table: Table, col: str, values: pd.Categorical, *, padded: bool) -> None:
    """A categorical column of the parser into ``table``: its cells (stripped when
    ``padded``; names that strip to the same text become one) and its codes."""
    names = np.asarray(values.categories, dtype=object)
    codes = np.asarray(values.codes, dtype=np.int64)
    if padded:
        trimmed = _stripped(names)
        n_padded = int(np.count_nonzero((trimmed != names)[codes]))
        if n_padded:
            table.padded[col] = n_padded
            merged, unique = pd.factorize(trimmed)
            codes = merged.astype(np.int64)[codes]
            names = np.asarray(unique, dtype=object)
    table.columns[col] = names[codes]
    table.codes[col] = (codes, names)


def read_table(
    path: str | os.PathLike[str],
    *,
    what: str,
    numeric_columns: Sequence[str] = NUMERIC,
    allow_no_rows: bool = False,
    coded_columns: Sequence[str] = (),
) -> Table:
    """Read a CSV as :class:`Table`; ``numeric_columns`` are parsed as numbers by the C
    parser when every cell of them is a finite number (else :func:`numbers` parses them).
    A header without rows is refused unless ``allow_no_rows`` (a detector that found no
    turns writes one; a clip index of a corpus without turns). ``coded_columns``: text
    columns of few distinct values (names, kinds) that the C parser numbers as it reads
    them (:attr:`Table.codes`), so that their readers need not factorise them again."""
    name = os.fspath(path)
    read, raw, sha256 = _read_text(name, what=what)
    text = _one_newline(read, name, what=what)
    # Line ends as read (the text unchanged): the file's bytes are the text's UTF-8.
    lines_as_read = text is read
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
        else _read_plain(
            text,
            name,
            delimiter,
            numeric_columns,
            raw=raw if lines_as_read else None,
            coded_columns=coded_columns,
        )
    )
    table.ascii = text.isascii()
    table.sha256 = sha256
    if table.lines.size == 0 and not allow_no_rows:
        raise TurnbenchError(
            f"empty {what} file: a header on line {table.header_line} and no rows", file=name
        )
    return table


def require(table: Table, required: Sequence[str], *, what: str) -> None:
    require_columns(
        table.header,
        required,
        what=what,
        file=table.path,
        row=table.header_line,
        note=" (matched ignoring case and spaces)",
    )


def first_and_count(table: Table, bad: np.ndarray) -> tuple[int, int, int]:
    where = np.flatnonzero(bad)
    return int(where[0]), int(table.lines[where[0]]), int(where.size)


def and_more(count: int) -> str:
    return f" ({count - 1} more row{'s' if count > 2 else ''} like it)" if count > 1 else ""


def refuse_rows(
    table: Table,
    bad: np.ndarray,
    message: Callable[[int], str],
    *,
    hint: str | None = None,
    problems: Problems | None = None,
    kind: str | None = None,
    detail: Callable[[int], str] | None = None,
) -> None:
    """Raise for the first ``bad`` row (``message`` of its index), counting the others; with
    ``problems``, add them all there as ``kind`` (``detail`` of each row says what is there)."""
    if problems is not None and kind is not None:
        where = np.flatnonzero(bad)
        if where.size:
            details = [detail(int(i)) for i in where[: problems.shown]] if detail else []
            first = message(int(where[0]))
            single = first + and_more(int(where.size))
            problems.add(kind, table.lines[where], details, hint=hint, single=single, first=first)
        return
    if bad.any():
        i, line, count = first_and_count(table, bad)
        raise TurnbenchError(message(i) + and_more(count), file=table.path, row=line, hint=hint)


def numbers(
    table: Table,
    column: str,
    *,
    allow_empty: bool,
    allow_negative: bool,
    negative_hint: str | None,
    problems: Problems | None = None,
) -> np.ndarray:
    """A numeric column, strictly: empty cells are NaN only when ``allow_empty``.

    Without ``problems`` the first kind of bad cell raises; with it, every kind (not a
    number, empty, NaN, infinite, implausible, negative) is added there and the column is
    returned with NaN in the unreadable cells.
    """
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
            if problems is not None:
                words = {"bad": "is not a number", "empty": "is empty", "nan": "is NaN"}
                problems.add(
                    f"{column} {words.get(kind, 'is infinite')}",
                    table.lines[hits],
                    [repr(raw[k]) for k in hits[: problems.shown]] if kind != "empty" else (),
                    single=message + and_more(count),
                    first=message,
                )
                continue
            raise TurnbenchError(message + and_more(count), file=table.path, row=line)
    bound = PLAUSIBLE.get(column)
    if bound is not None:
        refuse_rows(
            table,
            np.isfinite(values) & (np.abs(values) > bound),
            lambda i: f"{column} {values[i]:g} is beyond the plausible {bound:g}",
            hint="see the bounds in the README's error section",
            problems=problems,
            kind=f"{column} is beyond the plausible {bound:g}",
            detail=lambda i: f"{values[i]:g}",
        )
    if not allow_negative:
        refuse_rows(
            table,
            np.isfinite(values) & (values < 0),
            lambda i: f"{column} is negative ({values[i]:g})",
            hint=negative_hint,
            problems=problems,
            kind=f"{column} is negative",
            detail=lambda i: f"{values[i]:g}",
        )
    return values


def list_ids(ids: Sequence[str]) -> str:
    shown = ", ".join(repr(str(i)) for i in ids[:MAX_LISTED])
    return shown + (", ..." if len(ids) > MAX_LISTED else "")


#: The delimiters as a reading note names them.
_DELIMITER_NAMES = {";": "semicolon", "\t": "tab", ",": "comma"}


def reading_notes(table: Table) -> list[str]:
    """What the reader did that the file does not say, one line each, for stderr: a
    delimiter other than the comma (a spreadsheet export; decimal commas read as points),
    and cells read without the spaces around them (``" S9_Walking"`` is ``S9_Walking``)."""
    notes = []
    if table.delimiter != ",":
        notes.append(
            f"{table.path}: read as {_DELIMITER_NAMES[table.delimiter]}-separated (a "
            "spreadsheet export?), with decimal commas read as points; turnbench writes "
            "comma-separated CSV"
        )
    for col, n in table.padded.items():
        notes.append(
            f"{table.path}: {counted(n, 'cell')} of {col} had spaces around the value, read "
            "without them"
        )
    return notes


@dataclass
class Problems:
    """Every problem one pass finds, grouped by kind, raised together.

    A check adds its kind (``"angle_deg is not a number"``), where each case is and, for the
    first few, what is there; :meth:`raise_if_any` raises one
    :class:`~turn_datasets.errors.TurnbenchError` listing each kind with its count and first
    places, so that a file with three kinds of problem needs one run, not three.

    Over one table (``path`` set) a place is the file's line number. Over several files
    (``path`` None: a folder of ELAN files) a place is named in full, as a
    :class:`~turn_datasets.errors.Where` prints it (file, annotation, tier, time), and a
    lone problem is raised as the error its check gave.
    """

    path: str | None
    kinds: dict[str, tuple[list[int | str], list[str], str | None]] = field(default_factory=dict)
    #: Places listed per kind.
    shown: int = 3
    singles: dict[str, str] = field(default_factory=dict)
    firsts: dict[str, str] = field(default_factory=dict)
    #: What one place of each kind is ("row", "file", "annotation"), to count them.
    units: dict[str, str] = field(default_factory=dict)
    #: The first error recorded of each kind, raised as it is when it is the only problem.
    errors: dict[str, TurnbenchError] = field(default_factory=dict)

    def add(
        self,
        kind: str,
        lines: Sequence[int | str] | np.ndarray,
        details: Sequence[str] = (),
        *,
        hint: str | None = None,
        single: str | None = None,
        first: str | None = None,
        unit: str = "row",
    ) -> None:
        """Places of one kind of problem (``lines`` in file order; ``details[k]`` says what
        is at ``lines[k]``); ``first`` says the first place's problem in full and ``single``
        is the whole message when it is the only kind (the first, the others counted)."""
        got, said, _ = self.kinds.setdefault(kind, ([], [], hint))
        got.extend(x if isinstance(x, str) else int(x) for x in lines)
        said.extend(details)
        self.singles.setdefault(kind, single or first or kind)
        self.firsts.setdefault(kind, first or kind)
        self.units.setdefault(kind, unit)

    def record(
        self,
        exc: TurnbenchError,
        *,
        kind: str | None = None,
        detail: str | None = None,
        unit: str = "row",
    ) -> None:
        """A problem a check raised. Over one table: its message (first row, the others
        counted) and line. Over several files: as ``kind`` (default: its message), placed
        where the error says, with ``detail`` saying what is there."""
        if self.path is not None:
            row = exc.where.row
            self.add(exc.message, [row] if row else [], hint=exc.hint, single=exc.message)
            return
        kind = kind or exc.message
        self.errors.setdefault(kind, exc)
        self.add(kind, [str(exc.where)], [detail] if detail else [], hint=exc.hint, unit=unit)

    def run(self, check: Callable[[], object]) -> bool:
        """Run one check, recording what it raises instead of stopping; True if it passed."""
        try:
            check()
        except TurnbenchError as exc:
            self.record(exc)
            return False
        return True

    def __bool__(self) -> bool:
        return bool(self.kinds)

    def _listed(self, kind: str) -> str:
        """One kind's line: what it is, how many places, the first few with what is there."""
        places, details, hint = self.kinds[kind]
        named = [
            f"{place}" + (f" ({details[k]})" if k < len(details) else "")
            for k, place in enumerate(places[: self.shown])
        ]
        more = ", ..." if len(places) > self.shown else ""
        if self.path is not None:
            lines = f"line{'s' if len(places) > 1 else ''} "
            where = f": {lines}{', '.join(named)}{more}" if places else ""
        else:
            where = f": {'; '.join(named)}{more.replace(',', ';')}" if places else ""
        count = f" ({counted(len(places), self.units[kind])})" if len(places) > 1 else ""
        return f"  {self.firsts[kind]}{count}{where}" + (f" [{hint}]" if hint else "")

    def raise_if_any(self, what: str = "nothing scored", *, scope: str = "") -> None:
        """Raise every problem at once (grouped by kind, the first places of each, a count);
        ``scope`` follows the count ("in 5 ELAN files")."""
        if not self.kinds:
            return
        if len(self.kinds) == 1:
            kind, (places, _, hint) = next(iter(self.kinds.items()))
            if self.path is not None:
                # One kind: the message its check has always given (first line, the rest
                # counted); over one table a place is a line number
                line = places[0] if places and isinstance(places[0], int) else None
                raise TurnbenchError(self.singles[kind], file=self.path, row=line, hint=hint)
            if len(places) <= 1 and kind in self.errors:
                raise self.errors[kind]
        n_places = sum(max(len(places), 1) for places, _, _ in self.kinds.values())
        out = [
            f"{counted(n_places, 'problem')} of {counted(len(self.kinds), 'kind')}{scope}; {what}:"
        ]
        out.extend(self._listed(kind) for kind in self.kinds)
        # The error's line is the file's first problem (each kind's lines are listed).
        starts = [p for entry in self.kinds.values() for p in entry[0] if isinstance(p, int)]
        raise TurnbenchError("\n".join(out), file=self.path, row=min(starts) if starts else None)
