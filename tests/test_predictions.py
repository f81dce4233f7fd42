"""Reading and validating submissions: every problem of issue 5 with a malformed file.

Each test writes the file it needs; line numbers in the expected messages are counted by hand
from the file's text (line 1 is the header).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from turn_datasets.errors import TurnbenchError
from turn_datasets.usertable import _has_blank_line, _plain_lines, _read_plain
from turn_eval.clips.submission import (
    GROUP_COLUMNS,
    JOINED_COLUMNS,
    check_predictions,
    read_predictions,
    read_reference,
)

REFERENCE = (
    "clip_id,subject,action,split,angle_deg,duration_s\n"
    "S1_Walking_0-100,S1,Walking,train,90.0,2.0\n"
    "S1_Walking_200-300,S1,Walking,train,180.0,3.0\n"
    "S9_Phoning_0-80,S9,Phoning,test,47.5,1.0\n"
    "S11_Greeting_10-90,S11,Greeting,test,135.0,\n"
)
IDS = ["S1_Walking_0-100", "S1_Walking_200-300", "S9_Phoning_0-80", "S11_Greeting_10-90"]


def write(path: Path, text: str, *, encoding: str = "utf-8") -> Path:
    path.write_bytes(text.encode(encoding))
    return path


@pytest.fixture()
def ref(tmp_path: Path):
    return read_reference(write(tmp_path / "ref.csv", REFERENCE))


def preds_text(angles=("92.5", "170", "40", "100"), header="clip_id,angle_deg") -> str:
    return header + "\n" + "".join(f"{i},{a}\n" for i, a in zip(IDS, angles, strict=True))


def error_of(tmp_path: Path, text: str, ref, **kwargs) -> TurnbenchError:
    path = write(tmp_path / "pred.csv", text)
    with pytest.raises(TurnbenchError) as info:
        read_predictions(path, ref, **kwargs)
    return info.value


# --- the reference -----------------------------------------------------------------------


def test_reference_columns_types_and_recomputed_bins(ref):
    assert list(ref.columns) == [
        "clip_id",
        "angle_deg",
        "duration_s",
        "bin_deg",
        "subject",
        "action",
        "split",
    ]
    assert ref["angle_deg"].dtype == np.float64 and ref["duration_s"].dtype == np.float64
    # 47.5 / 45 + 0.5 = 1.56 -> floor 1 -> 45; 135 -> 135; an empty duration is NaN.
    assert ref["bin_deg"].tolist() == [90.0, 180.0, 45.0, 135.0]
    assert math.isnan(ref["duration_s"].iloc[3])
    assert ref["subject"].tolist() == ["S1", "S1", "S9", "S11"]


def test_clip_index_and_labels_headers_qualify_as_they_are(tmp_path):
    # The two file contracts of DESIGN.md, one row each, exactly their headers.
    index = write(
        tmp_path / "index.csv",
        "clip_id,subject,action,subaction,split,start_frame,end_frame,n_frames,fps,start_s,"
        "end_s,duration_s,angle_deg,direction,bin_deg,speed_deg_s,source\n"
        "S1_Walking-Dog_10-110,S1,Walking Dog,1,train,10,110,100,50,0.2,2.2,2.0,95.0,left,"
        "90,47.5,S1/Walking Dog.cdf\n",
    )
    labels = write(
        tmp_path / "labels.csv",
        "clip_id,session,subject,cohort,annotator,start_s,end_s,duration_s,angle_deg,"
        "scenario,location,double_annotated,source\n"
        "s01_0001,s01,P01,PD,A1,1.0,3.5,2.5,180,free-living,kitchen,true,s01.eaf\n",
    )
    clip_index = read_reference(index)
    assert clip_index["action"].tolist() == ["Walking Dog"]
    assert clip_index["duration_s"].tolist() == [2.0]
    assert "speed_deg_s" not in clip_index.columns  # a number, not a group
    remap = read_reference(labels)
    assert remap[["cohort", "scenario", "location"]].iloc[0].tolist() == [
        "PD",
        "free-living",
        "kitchen",
    ]
    joined = read_predictions(write(tmp_path / "p.csv", "clip_id,angle_deg\ns01_0001,170\n"), remap)
    assert joined.default_groupings == ("scenario", "location", "cohort", "subject", "bin_deg")
    assert set(joined.default_groupings) <= set(GROUP_COLUMNS)


def test_reference_negative_angle_is_refused_with_its_line(tmp_path):
    path = write(tmp_path / "ref.csv", "clip_id,angle_deg\na,90\nb,-45\n")
    with pytest.raises(TurnbenchError) as info:
        read_reference(path)
    assert info.value.where.row == 3 and "negative" in str(info.value)


# --- a good submission, read the forgiving way ---------------------------------------------


def test_join_in_reference_order_with_group_columns(tmp_path, ref):
    text = "clip_id,angle_deg,note\n" + "".join(
        f"{i},{a},x\n"
        for i, a in reversed(list(zip(IDS, ["92.5", "170", "40", "100"], strict=True)))
    )
    joined = read_predictions(write(tmp_path / "p.csv", text), ref)
    t = joined.table
    assert list(t.columns) == [*JOINED_COLUMNS, "subject", "action", "split"]
    assert t["clip_id"].tolist() == IDS
    assert t["pred_angle_deg"].tolist() == [92.5, 170.0, 40.0, 100.0]
    assert t["ref_angle_deg"].tolist() == [90.0, 180.0, 47.5, 135.0]
    assert t["ref_duration_s"].tolist()[:3] == [2.0, 3.0, 1.0]
    assert t["pred_speed_deg_s"].isna().all()  # no speed column: not given
    assert "note" not in t.columns  # extra columns are ignored
    assert joined.n_missing == 0 and joined.has_durations
    assert joined.default_groupings == ("subject", "bin_deg", "action", "split")


@pytest.mark.parametrize(
    "raw",
    [
        # Header names in any case with spaces, a byte-order mark, CRLF line ends.
        "\ufeff Clip_ID , ANGLE_DEG \r\n"
        + "".join(f"{i} , {a}\r\n" for i, a in zip(IDS, ["92.5", "170", "40", "100"], strict=True)),
        # A spreadsheet's export: semicolons and a decimal comma.
        "clip_id;angle_deg\n"
        + "".join(f"{i};{a}\n" for i, a in zip(IDS, ["92,5", "170", "40", "100"], strict=True)),
        # Tab-separated, with a decimal comma too.
        "clip_id\tangle_deg\n"
        + "".join(f"{i}\t{a}\n" for i, a in zip(IDS, ["92,5", "170", "40", "100"], strict=True)),
        # Quoted fields (read by the exact reader), blank lines between rows.
        "clip_id,angle_deg\n\n"
        + "".join(
            f'"{i}","{a}"\n\n' for i, a in zip(IDS, ["92.5", "170", "40", "100"], strict=True)
        ),
    ],
    ids=["bom-case-spaces-crlf", "semicolon-decimal-comma", "tab", "quoted-blank-lines"],
)
def test_spreadsheet_variants_read_the_same(tmp_path, ref, raw):
    joined = read_predictions(write(tmp_path / "p.csv", raw), ref)
    assert joined.table["pred_angle_deg"].tolist() == [92.5, 170.0, 40.0, 100.0]
    assert joined.table["clip_id"].tolist() == IDS


@pytest.mark.parametrize(
    "raw, line, expected",
    [
        # BOM, odd header case and spaces, CRLF, a blank line 3: 'x' is on line 5.
        (
            "\ufeff Clip_ID , ANGLE_DEG \r\n"
            f"{IDS[0]} , 92.5\r\n\r\n{IDS[1]} , 170\r\n"
            f"{IDS[2]} , x\r\n{IDS[3]} , 100\r\n",
            5,
            "angle_deg 'x' is not a number",
        ),
        # A spreadsheet's semicolons and decimal commas: a negative magnitude on line 3.
        (
            f"clip_id;angle_deg\n{IDS[0]};92,5\n{IDS[1]};-12,5\n{IDS[2]};40\n{IDS[3]};100\n",
            3,
            "angle_deg is negative (-12.5)",
        ),
        # Tabs and decimal commas: NaN on line 4.
        (
            f"clip_id\tangle_deg\n{IDS[0]}\t92,5\n{IDS[1]}\t170\n{IDS[2]}\tNaN\n{IDS[3]}\t1\n",
            4,
            "angle_deg is NaN ('NaN')",
        ),
        # Semicolons: a cell with two decimal commas is not a number, line 2.
        (
            f"clip_id;angle_deg\n{IDS[0]};1,2,5\n{IDS[1]};170\n{IDS[2]};40\n{IDS[3]};1\n",
            2,
            "angle_deg '1,2,5' is not a number",
        ),
        # Semicolons: an infinite angle on line 5.
        (
            f"clip_id;angle_deg\n{IDS[0]};1\n{IDS[1]};170\n{IDS[2]};40\n{IDS[3]};-inf\n",
            5,
            "angle_deg is infinite ('-inf')",
        ),
        # A BOM before a header that lacks angle_deg: the header's line, 1.
        (f"\ufeffclip_id;angle\n{IDS[0]};1\n", 1, "lacks column 'angle_deg'"),
        # Tabs: a duplicate id on line 4, first on line 2.
        (
            f"clip_id\tangle_deg\n{IDS[0]}\t1\n{IDS[1]}\t2\n{IDS[0]}\t3\n",
            4,
            f"duplicate clip_id {IDS[0]!r}, first on line 2",
        ),
        # Semicolons: an id not in the reference on line 3.
        (f"clip_id;angle_deg\n{IDS[0]};1\nghost;2\n", 3, "1 clip id is not in the reference"),
    ],
    ids=[
        "bom-crlf-word",
        "semicolon-negative",
        "tab-nan",
        "semicolon-two-commas",
        "semicolon-inf",
        "bom-missing-column",
        "tab-duplicate",
        "semicolon-unknown",
    ],
)
def test_spreadsheet_variants_report_the_files_own_line(tmp_path, ref, raw, line, expected):
    err = error_of(tmp_path, raw, ref)
    assert err.where.row == line, str(err)
    assert expected in str(err)
    if "negative" in expected:
        assert "--abs" in str(err)


def test_speed_column_empty_cells_mean_not_given(tmp_path, ref):
    text = "clip_id,angle_deg,speed_deg_s\n" + "".join(
        f"{i},{a},{s}\n"
        for i, a, s in zip(IDS, ["92.5", "170", "40", "100"], ["40", "", "30.5", ""], strict=True)
    )
    t = read_predictions(write(tmp_path / "p.csv", text), ref).table
    assert t["pred_speed_deg_s"].iloc[0] == 40.0 and t["pred_speed_deg_s"].iloc[2] == 30.5
    assert t["pred_speed_deg_s"].iloc[[1, 3]].isna().all()


# --- every validation error, with the file's own line numbers ------------------------------


def test_missing_ids_list_first_ten_and_the_count(tmp_path):
    ids = [f"c{i:02d}" for i in range(15)]
    ref = read_reference(
        write(tmp_path / "ref.csv", "clip_id,angle_deg\n" + "".join(f"{i},90\n" for i in ids))
    )
    text = "clip_id,angle_deg\nc00,90\nc01,90\nc02,90\n"
    err = error_of(tmp_path, text, ref)
    # 15 - 3 = 12 missing; the first ten listed, then an ellipsis.
    message = str(err)
    assert "12 of the reference's 15 clips are missing" in message
    assert ", ".join(repr(f"c{i:02d}") for i in range(3, 13)) + ", ..." in message
    assert "'c13'" not in message
    assert "--allow-missing" in message and err.where.file.endswith("pred.csv")


def test_allow_missing_scores_the_rest_and_warns(tmp_path, ref):
    warnings: list[str] = []
    text = f"clip_id,angle_deg\n{IDS[0]},92.5\n{IDS[2]},40\n"
    joined = read_predictions(
        write(tmp_path / "p.csv", text), ref, allow_missing=True, warn=warnings.append
    )
    assert joined.n_missing == 2
    assert joined.missing_ids == (IDS[1], IDS[3])
    assert joined.table["clip_id"].tolist() == [IDS[0], IDS[2]]
    assert len(warnings) == 1 and "2 of the reference's 4 clips are missing" in warnings[0]


def test_check_places_each_row_in_the_reference_without_the_join(tmp_path, ref):
    # rows out of reference order, one speed empty, two clips left out
    text = f"clip_id,angle_deg,speed_deg_s\n{IDS[2]},40,20\n{IDS[0]},92.5,\n"
    path = write(tmp_path / "p.csv", text)
    checked = check_predictions(path, ref, allow_missing=True)
    assert checked.position.tolist() == [2, 0]
    assert checked.covered.tolist() == [True, False, True, False]
    assert checked.n_clips == 2 and checked.missing_ids == (IDS[1], IDS[3])
    assert checked.angle_deg.tolist() == [40.0, 92.5]
    assert checked.speed_deg_s[0] == 20.0 and math.isnan(checked.speed_deg_s[1])
    assert len(read_predictions(path, ref, allow_missing=True)) == checked.n_clips


@pytest.mark.parametrize(
    "text, line",
    [
        (preds_text(angles=("92.5", "-170", "40", "100")), 3),
        (preds_text(angles=("92.5", "x", "40", "100")), 3),
        (preds_text() + f"{IDS[1]},175\n", 6),
        (preds_text() + "ghost_1,90\n", 6),
        ("clip,angle_deg\nx,1\n", 1),
        (f"clip_id,angle_deg\n{IDS[0]},90\n", None),
        ("", None),
    ],
    ids=["negative", "not-a-number", "duplicate", "unknown", "no-clip-id", "missing", "empty"],
)
def test_check_refuses_what_read_refuses_in_the_same_words(tmp_path, ref, text, line):
    path = write(tmp_path / "pred.csv", text)
    with pytest.raises(TurnbenchError) as checked:
        check_predictions(path, ref)
    with pytest.raises(TurnbenchError) as read:
        read_predictions(path, ref)
    assert str(checked.value) == str(read.value)
    assert checked.value.where.row == line


def test_ids_not_in_reference_name_the_first_line(tmp_path, ref):
    text = preds_text() + "ghost_1,90\nghost_2,45\n"
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 6  # header + 4 good rows, then the ghost
    assert "2 clip ids are not in the reference" in str(err)
    assert "'ghost_1', 'ghost_2'" in str(err)


def test_duplicate_ids_name_both_lines(tmp_path, ref):
    text = preds_text() + f"{IDS[1]},175\n"
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 6
    assert f"duplicate clip_id {IDS[1]!r}, first on line 3" in str(err)


@pytest.mark.parametrize(
    "text, expected",
    [
        ("", "no header and no rows"),
        ("  \n\n", "no header and no rows"),
        ("clip_id,angle_deg\n\n", "a header on line 1 and no rows"),
    ],
    ids=["zero-bytes", "blank-lines", "header-only"],
)
def test_empty_file(tmp_path, ref, text, expected):
    err = error_of(tmp_path, text, ref)
    assert "empty predictions file" in str(err) and expected in str(err)


def test_missing_column_names_header_line_and_what_is_there(tmp_path, ref):
    text = "\nclip,angle_deg\nx,1\n"
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 2  # the header is the first non-blank line
    assert "lacks column 'clip_id'" in str(err) and "'clip', 'angle_deg'" in str(err)


def test_wrong_number_of_fields(tmp_path, ref):
    text = preds_text().replace(f"{IDS[2]},40", f"{IDS[2]},40,extra")
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 4 and "row has 3 fields but the header has 2" in str(err)


@pytest.mark.parametrize(
    "cell, expected",
    [
        ("ninety", "angle_deg 'ninety' is not a number"),
        ("nan", "angle_deg is NaN ('nan')"),
        ("NaN", "angle_deg is NaN ('NaN')"),
        ("inf", "angle_deg is infinite ('inf')"),
        ("-Infinity", "angle_deg is infinite ('-Infinity')"),
        ("1e999", "angle_deg is infinite ('1e999')"),
        ("", "angle_deg is empty"),
    ],
)
def test_bad_angles_name_their_line(tmp_path, ref, cell, expected):
    # Two blank lines before the bad row (lines 2 and 4): it is the file's line 7.
    text = preds_text(angles=("92.5", "170", "40", "100")).replace("\n", "\n\n", 2)
    text = text.replace(f"{IDS[3]},100", f"{IDS[3]},{cell}")
    assert text.splitlines()[6] == f"{IDS[3]},{cell}"
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 7
    assert expected in str(err)


def test_several_bad_rows_are_counted(tmp_path, ref):
    err = error_of(tmp_path, preds_text(angles=("x", "170", "y", "z")), ref)
    assert err.where.row == 2 and "(2 more rows like it)" in str(err)


def test_negative_angle_hints_at_magnitudes_and_abs(tmp_path, ref):
    text = preds_text(angles=("92.5", "-170", "40", "100"))
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 3
    assert "negative" in str(err) and "--abs" in str(err) and "magnitudes" in str(err)
    joined = read_predictions(tmp_path / "pred.csv", ref, abs_angles=True)
    assert joined.table["pred_angle_deg"].tolist() == [92.5, 170.0, 40.0, 100.0]


def test_negative_speed_is_refused_too(tmp_path, ref):
    text = "clip_id,angle_deg,speed_deg_s\n" + "".join(
        f"{i},90,{s}\n" for i, s in zip(IDS, ["1", "2", "-3", "4"], strict=True)
    )
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 4 and "speed_deg_s is negative" in str(err)


def test_radians_warning_only_when_the_reference_is_in_degrees(tmp_path, ref):
    warnings: list[str] = []
    # pi/2, pi, pi/4, 3pi/4: the reference's angles in radians.
    text = preds_text(angles=("1.5708", "3.1416", "0.7854", "2.3562"))
    read_predictions(write(tmp_path / "p.csv", text), ref, warn=warnings.append)
    assert len(warnings) == 1 and "radians" in warnings[0] and "2π" in warnings[0]
    small_ref = read_reference(
        write(tmp_path / "r2.csv", "clip_id,angle_deg\n" + "".join(f"{i},3\n" for i in IDS))
    )
    warnings.clear()
    read_predictions(tmp_path / "p.csv", small_ref, warn=warnings.append)
    assert warnings == []


def test_duplicate_header_and_missing_file(tmp_path, ref):
    err = error_of(tmp_path, "clip_id,Angle_Deg,angle_deg\na,1,2\n", ref)
    assert "column 'angle_deg' appears twice" in str(err) and err.where.row == 1
    with pytest.raises(TurnbenchError, match="predictions file not found"):
        read_predictions(tmp_path / "nope.csv", ref)


def test_quoted_file_counts_lines_of_a_multiline_field(tmp_path, ref):
    # A quoted note spanning lines 2-3; the bad angle is on line 4.
    text = f'clip_id,angle_deg,note\n{IDS[0]},92.5,"two\nlines"\n{IDS[1]},oops,""\n'
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 4 and "'oops' is not a number" in str(err)


def test_not_utf8(tmp_path, ref):
    path = tmp_path / "pred.csv"
    path.write_bytes("clip_id,angle_deg\nS1_é,90\n".encode("latin-1"))
    with pytest.raises(TurnbenchError, match="not UTF-8"):
        read_predictions(path, ref)


# --- the line scan: its fast path (no blank line) against the line-by-line one ------------

_CELL = st.text(
    alphabet=st.characters(blacklist_characters='\n"', blacklist_categories=("Cs",)), max_size=6
)


@settings(max_examples=150, deadline=None)
@given(
    rows=st.lists(st.lists(_CELL, min_size=1, max_size=4), min_size=1, max_size=8),
    delimiter=st.sampled_from([",", ";", "\t"]),
    crlf=st.booleans(),
    final_newline=st.booleans(),
)
def test_line_scan_fast_path_equals_line_by_line(rows, delimiter, crlf, final_newline):
    # Lines with something on them (any unicode, the delimiter included); a trailing
    # white-space line forces the line-by-line path, which must give the same header, line
    # numbers, field counts and body.
    lines = [delimiter.join(cells) for cells in rows]
    lines = [line for line in lines if line.strip()]
    if not lines:
        return
    end = "\r\n" if crlf else "\n"
    text = end.join(lines) + (end if final_newline else "")
    fast = _plain_lines(text, delimiter)
    slow = _plain_lines(text + ("" if final_newline else "\n") + " \u00a0\n", delimiter)
    assert fast[:2] == slow[:2]
    assert np.array_equal(fast[2], slow[2]) and np.array_equal(fast[3], slow[3])
    assert fast[4] == slow[4]
    # Counted by hand from the lines themselves.
    assert fast[2].tolist() == list(range(2, len(lines) + 1))
    assert fast[3].tolist() == [line.count(delimiter) + 1 for line in lines[1:]]


@settings(max_examples=300, deadline=None)
@given(
    width=st.integers(1, 4),
    cells=st.lists(
        st.one_of(_CELL, st.sampled_from(["", " ", "\t", "\u00a0", "\x0c"])),
        min_size=1,
        max_size=40,
    ),
    delimiter=st.sampled_from([",", ";", "\t"]),
    final_newline=st.booleans(),
)
def test_line_scan_of_rows_of_one_width_equals_the_definition(
    width, cells, delimiter, final_newline
):
    # Rows of the header's width (the well-formed file the scan shortcuts), cells that may
    # be white space or the delimiter: the header, line numbers, field counts and body are
    # those of the lines with something on them, taken one by one.
    rows = [cells[i : i + width] for i in range(0, len(cells), width)]
    lines = [delimiter.join(row) for row in rows]
    if not lines[0].strip():
        return
    text = "\n".join(lines) + ("\n" if final_newline else "")
    kept = [(n, line) for n, line in enumerate(text.split("\n"), start=1) if line.strip()]
    header, *body = kept
    got = _plain_lines(text, delimiter)
    assert got[:2] == (header[1], header[0])
    assert got[2].tolist() == [n for n, _ in body]
    assert got[3].tolist() == [line.count(delimiter) + 1 for _, line in body]
    assert got[4] == "\n".join(line for _, line in body).encode("utf-8")


def _outcome(read):
    try:
        table = read()
    except TurnbenchError as exc:
        return ("error", str(exc))
    return (
        table.header,
        table.header_line,
        table.lines.tolist(),
        {c: v.tolist() for c, v in table.columns.items()},
        {c: v.tolist() for c, v in table.numbers.items()},
    )


@settings(max_examples=300, deadline=None)
@given(
    widths=st.lists(st.integers(0, 4), min_size=1, max_size=8),
    cells=st.lists(st.sampled_from(["1", "2.5", "x", "", " ", "nan"]), min_size=32, max_size=32),
    delimiter=st.sampled_from([",", ";", "\t"]),
    header_width=st.integers(1, 3),
)
def test_reader_without_a_count_per_line_reads_as_with_one(widths, cells, delimiter, header_width):
    # Lines of any width, blank ones among them (width 0), so that the body's total of
    # delimiters may be right while lines are not (one long, one short): the reader that
    # trusts the total and the parser reads exactly what it reads counting every line's
    # fields, and refuses the same line with the same message.
    header = delimiter.join(["angle_deg", "note", "speed_deg_s"][:header_width])
    it = iter(cells)
    rows = [delimiter.join(next(it) for _ in range(w)) if w else "" for w in widths]
    text = header + "\n" + "\n".join(rows) + "\n"
    assert _outcome(lambda: _read_plain(text, "f.csv", delimiter)) == _outcome(
        lambda: _read_plain(text, "f.csv", delimiter, count_each_line=True)
    )


@settings(max_examples=300, deadline=None)
@given(
    # mostly rows of the header's width: the file the bytes are read from as they are
    widths=st.lists(st.sampled_from([3, 3, 3, 3, 2, 0]), min_size=1, max_size=8),
    cells=st.lists(
        st.sampled_from(["1", "2.5", "x", "", " 3 ", "é", "\u00a0", "nan"]),
        min_size=24,
        max_size=24,
    ),
    delimiter=st.sampled_from([",", ";", "\t"]),
    header=st.sampled_from(["angle_deg,note,speed_deg_s", " Angle_deg , note,speed_deg_s"]),
    final_newlines=st.integers(0, 2),
    bom=st.booleans(),
)
def test_reader_of_the_files_bytes_reads_as_from_its_text(
    widths, cells, delimiter, header, final_newlines, bom
):
    # The rows taken from the file's own bytes (a byte-order mark, padded header names,
    # non-ASCII cells, no, one or two final newlines) read exactly as the text encoded again
    # and counted line by line: same cells, numbers, line numbers, padding, or the same error.
    header = header.replace(",", delimiter)
    it = iter(cells)
    rows = [delimiter.join(next(it) for _ in range(w)) if w else "" for w in widths]
    text = header + "\n" + "\n".join(rows) + "\n" * final_newlines
    raw = (b"\xef\xbb\xbf" if bom else b"") + text.encode("utf-8")

    def outcome(read):
        got = _outcome(read)
        return got if got[0] == "error" else (*got, read().padded)

    assert outcome(lambda: _read_plain(text, "f.csv", delimiter, raw=raw)) == outcome(
        lambda: _read_plain(text, "f.csv", delimiter, count_each_line=True)
    )


@pytest.mark.parametrize(
    "rows",
    [
        ["1,2,3,4", "1,2", "1,2,3"],  # the first line long, a later one short
        ["1,2", "1,2,3,4", "1,2,3"],  # a short line, then a long one
        ["1,2,3", "", "1,2,3,4,5"],  # a blank line made up for by a long one
    ],
)
def test_a_long_line_hidden_by_a_short_one_is_named(rows):
    text = "a,b,c\n" + "\n".join(rows) + "\n"
    with pytest.raises(TurnbenchError, match="fields but the header has 3") as err:
        _read_plain(text, "f.csv", ",")
    bad = next(i for i, row in enumerate(rows) if row and row.count(",") != 2)
    assert err.value.where.row == bad + 2


def test_a_line_of_unicode_white_space_is_blank(tmp_path, ref):
    # No-break spaces alone on lines 2 and 4 are blank lines, skipped: header line 1, rows
    # on lines 3, 5, 6 and 7, the bad cell on line 7.
    text = preds_text().replace("\n", "\n\u00a0\n", 2).replace(f"{IDS[3]},100", f"{IDS[3]},x")
    err = error_of(tmp_path, text, ref)
    assert err.where.row == 7 and "'x' is not a number" in str(err)


@settings(max_examples=300, deadline=None)
@given(
    st.text(alphabet=st.sampled_from(["a", ",", " ", "\t", "\r", "\n", "\u00a0", "é"]), max_size=30)
)
def test_blank_line_detection_equals_splitting(text):
    # The definition, line by line: some line of the text split on newlines is empty or
    # white space only.
    assert _has_blank_line(text) == any(not line.strip() for line in text.split("\n"))
