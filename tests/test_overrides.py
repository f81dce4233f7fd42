"""The curation overrides file (``curation.csv``) read by the one reader of user tables."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from turn_datasets.errors import TurnbenchError
from turn_datasets.h36m.overrides import read_overrides

HEADER = "clip_id,decision,start_frame,end_frame,note"


def _write_bytes(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def test_a_semicolon_export_with_a_bom_crlf_and_a_blank_line_is_read_and_said(tmp_path):
    # A spreadsheet's export in a European locale: BOM, semicolons, CRLF, a blank line 3,
    # a capitalised header and padded cells. Lines by hand: header 1, rows 2, 4 and 5.
    text = (
        "Clip_ID;Decision;Start_Frame;End_Frame;Note\r\n"
        "S1_Walking-1_10-90;exclude;;;a false turn\r\n"
        "\r\n"
        " S9_WalkDog_5-80 ;adjust;7;70;tighter, by eye\r\n"
        "S11_Directions_1-50;KEEP;;;\r\n"
    )
    path = _write_bytes(tmp_path / "curation.csv", b"\xef\xbb\xbf" + text.encode("utf-8"))
    said: list[str] = []
    ovr = read_overrides(path, warn=said.append)
    got = {
        c: (o.decision, o.start_frame, o.end_frame, o.note, o.line) for c, o in ovr.by_id.items()
    }
    assert got == {
        "S1_Walking-1_10-90": ("exclude", None, None, "a false turn", 2),
        "S9_WalkDog_5-80": ("adjust", 7, 70, "tighter, by eye", 4),
        "S11_Directions_1-50": ("keep", None, None, "", 5),
    }
    assert any(f"{path}: read as semicolon-separated" in line for line in said), said


def test_line_numbers_are_the_files_own(tmp_path):
    # A note holding a form feed (a line break to str.splitlines, not to an editor) on
    # line 2, then a note quoted over lines 3-4: the bad decision is on line 5, as an editor
    # numbers it.
    rows = [HEADER, "a,keep,,,page\x0cbreak", 'b,keep,,,"two\nlines"', "c,remove,,,", ""]
    text = "\n".join(rows)
    path = _write_bytes(tmp_path / "curation.csv", text.encode("utf-8"))
    with pytest.raises(TurnbenchError) as err:
        read_overrides(path)
    assert err.value.where.row == 5
    assert "decision 'remove' is not one of exclude, keep, adjust" in err.value.message


def test_every_bad_row_is_said_in_one_pass(tmp_path):
    # Three kinds of problem on lines 3, 4 and 6 (and a second bad decision on line 5).
    rows = [HEADER, "a,keep,,,", "b,remove,,,", "c,adjust,1.5,9,", "d,drop,,,", "a,exclude,,,", ""]
    text = "\n".join(rows)
    path = _write_bytes(tmp_path / "curation.csv", text.encode("utf-8"))
    with pytest.raises(TurnbenchError) as err:
        read_overrides(path)
    message = err.value.message
    assert message.splitlines()[0] == "4 problems of 3 kinds; no override applied:"
    assert re.search(r"decision .*\(2 rows\): lines 3 \('remove'\), 5 \('drop'\)", message)
    assert re.search(r"start_frame '1.5' is not a whole number of frames: line 4\b", message)
    assert re.search(r"clip 'a' already has an override on line 2: line 6\b", message)
    assert err.value.where.row == 3  # the file's first problem


def test_a_header_without_rows_is_no_overrides(tmp_path):
    path = _write_bytes(tmp_path / "curation.csv", f"{HEADER}\n".encode())
    assert len(read_overrides(path)) == 0
