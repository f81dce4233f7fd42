"""The files of score-events read from CSV equal the same tables checked as frames: the file
reader's shortcuts (text already stripped, numbers already parsed) change nothing."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from turn_datasets.errors import TurnbenchError
from turn_datasets.usertable import read_table
from turn_eval.events.reading import (
    Pairs,
    check_context,
    check_detections,
    check_detections_pairs,
    check_event_reference,
    check_sessions,
    read_context,
    read_detections,
    read_detections_pairs,
    read_event_reference,
    read_sessions,
    units_of,
)

# Padded cells, upper-case directions, an empty speed and direction, an extra column.
DETECTIONS = """session, subject ,start_s,end_s,angle_deg,direction,speed_deg_s,score,note
 s1 ,P1,0.0,2.0,80,LEFT,40,0.9,a
s1, P1 ,10.5,12,200,Right,,0.8,b
s1,P1,30,31,90,,90.5,0.7,
s2,P2,0.5,3,135,left,54,0.3,c
"""
REFERENCE = """clip_id,session,subject,start_s,end_s,angle_deg,cohort,scenario,location,direction
c1,s1,P1,0,2,90, PD ,scripted,kitchen,Left
c2,s1,P1,10,12,180,PD,scripted ,kitchen,right
c3,s1,P1,20,22,90,PD,free-living,kitchen,
c4,s2,P2,0,3,135,HC,scripted, hall,left
"""
CONTEXT = """session,subject,start_s,end_s,scenario,location
s1,,0,15,scripted,kitchen
s1,P1,15,40, free-living,
s2,P2,0,10,scripted,hall
"""
SESSIONS = """session,subject,duration_s
s1,P1,3600
 s2,P2 ,1800.5
"""


def _as_text_frame(path) -> pd.DataFrame:
    # What a caller might pass: every cell as pandas read it, text and all.
    frame = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=False)
    frame.columns = [c.strip().lower() for c in frame.columns]
    return frame


@pytest.mark.parametrize(
    ("text", "reader", "checker"),
    [
        (DETECTIONS, read_detections, check_detections),
        (REFERENCE, read_event_reference, check_event_reference),
        (CONTEXT, read_context, check_context),
        (SESSIONS, read_sessions, check_sessions),
    ],
)
def test_a_file_reads_as_its_frame_checks(tmp_path, text, reader, checker):
    path = tmp_path / "table.csv"
    path.write_text(text, encoding="utf-8")
    read = reader(path)
    checked = checker(_as_text_frame(path))
    assert list(read.columns) == list(checked.columns)
    for col in read.columns:
        assert read[col].dtype == checked[col].dtype, col
        a, b = read[col].to_numpy(), checked[col].to_numpy()
        if a.dtype == object:
            assert all(type(v) is str for v in a), col
            assert a.tolist() == b.tolist(), col
        else:
            np.testing.assert_array_equal(a, b, err_msg=col)
    assert list(read.attrs["lines"]) == list(range(2, 2 + read.shape[0]))


def test_directions_are_lower_cased_from_a_file(tmp_path):
    path = tmp_path / "det.csv"
    path.write_text(DETECTIONS, encoding="utf-8")
    assert read_detections(path)["direction"].tolist() == ["left", "right", "", "left"]


@settings(max_examples=200, deadline=None)
@given(
    rows=st.lists(
        st.tuples(st.sampled_from(["s1", "s2", "s10", ""]), st.sampled_from(["P1", "P2", ""])),
        min_size=1,
        max_size=30,
    ),
    extra=st.lists(
        st.tuples(st.sampled_from(["s1", "s3"]), st.sampled_from(["P1", "P3"])),
        max_size=4,
        unique=True,
    ),
    queries=st.lists(
        st.tuples(st.sampled_from(["s1", "s2", "s3", "s9"]), st.sampled_from(["P1", "P3"])),
        min_size=1,
        max_size=10,
    ),
)
def test_units_and_their_lookup_from_the_factorised_pairs(rows, extra, queries):
    # Units are the distinct (session, subject) pairs of the reference's rows and of the
    # sessions table, in sorted order; a row's unit is its pair's place among them; a
    # detection's is -1 where the pair is not one of them. Worked out with Python's own set,
    # sort and index, against the factorised pairs the scoring passes along.
    reference = pd.DataFrame(rows, columns=["session", "subject"])
    sessions = pd.DataFrame(extra, columns=["session", "subject"]) if extra else None
    names = sorted(set(rows) | set(extra))
    units, ref_unit = units_of(reference, sessions)
    assert list(zip(units.sessions, units.subjects, strict=True)) == names
    assert ref_unit.tolist() == [names.index(r) for r in rows]
    detections = pd.DataFrame(queries, columns=["session", "subject"])
    expected = [names.index(q) if q in names else -1 for q in queries]
    assert units.codes(detections).tolist() == expected
    pairs = Pairs.of(detections)
    assert units.lookup(pairs.sessions, pairs.subjects)[pairs.code].tolist() == expected


def test_an_empty_subject_of_the_reference_names_its_line(tmp_path):
    path = tmp_path / "ref.csv"
    path.write_text(REFERENCE.replace("c3,s1,P1", "c3,s1,  "), encoding="utf-8")
    with pytest.raises(TurnbenchError, match="subject is empty") as err:
        read_event_reference(path)
    assert err.value.where.row == 4


def test_pairs_number_a_missing_name_as_a_name():
    frame = pd.DataFrame({"session": ["s1", np.nan, "s1", np.nan], "subject": ["P1"] * 4})
    pairs = Pairs.of(frame)
    assert pairs.code.tolist() == [0, 1, 0, 1]
    assert pairs.sessions[0] == "s1" and pd.isna(pairs.sessions[1])
    assert pairs.subjects.tolist() == ["P1", "P1"]


# Every number given (the C parser's fast path, which numbers the name and kind columns as it
# reads them); names padded so that " s1 " and "s1" are one session; kinds in any case.
CODED_DETECTIONS = """session,subject,start_s,end_s,angle_deg,direction,steps,turn_type
 s1 ,P1,0.0,2.0,80,LEFT,3,Step
s2,P2 ,0.5,3,135,left,1,pivot
s1,P1,10.5,12,200,Right,2,PIVOT
s1, P1,30,31,90,,4,step
s2,P2,5,6,45,right,0,
"""


def test_the_readers_codes_are_the_columns_numbered(tmp_path):
    path = tmp_path / "det.csv"
    path.write_text(CODED_DETECTIONS, encoding="utf-8")
    table = read_table(
        path,
        what="detections",
        numeric_columns=("start_s", "end_s", "angle_deg", "steps"),
        coded_columns=("session", "subject", "direction", "turn_type"),
    )
    expected = {
        "session": ["s1", "s2", "s1", "s1", "s2"],
        "subject": ["P1", "P2", "P1", "P1", "P2"],
        "direction": ["LEFT", "left", "Right", "", "right"],
        "turn_type": ["Step", "pivot", "PIVOT", "step", ""],
    }
    assert set(table.codes) == set(expected)
    for col, cells in expected.items():
        codes, names = table.codes[col]
        assert table.columns[col].tolist() == cells
        assert names[codes].tolist() == cells
        assert sorted(names.tolist()) == sorted(set(cells)), col  # each text numbered once
    assert table.padded == {"session": 1, "subject": 2}


def test_detections_checked_with_the_readers_codes_equal_those_checked_without(tmp_path):
    # The reader's codes only spare a factorisation: the frame, its pairs and a refusal are
    # those of the same file's cells checked as a frame.
    path = tmp_path / "det.csv"
    path.write_text(CODED_DETECTIONS, encoding="utf-8")
    read, pairs = read_detections_pairs(path)
    checked, checked_pairs = check_detections_pairs(_as_text_frame(path))
    pd.testing.assert_frame_equal(read, checked, check_dtype=False)
    assert read["turn_type"].tolist() == ["step", "pivot", "pivot", "step", ""]
    assert read["direction"].tolist() == ["left", "left", "right", "", "right"]
    assert pairs.code.tolist() == checked_pairs.code.tolist() == [0, 1, 0, 0, 1]
    assert pairs.sessions.tolist() == checked_pairs.sessions.tolist() == ["s1", "s2"]
    assert pairs.subjects.tolist() == checked_pairs.subjects.tolist() == ["P1", "P2"]
    for col, bad in (("turn_type", "Spin"), ("direction", "Up")):
        path.write_text(CODED_DETECTIONS.replace("PIVOT" if col == "turn_type" else "Right", bad))
        with pytest.raises(TurnbenchError) as from_file:
            read_detections_pairs(path)
        with pytest.raises(TurnbenchError) as from_frame:
            check_detections_pairs(_as_text_frame(path), str(path))
        assert f"{col} {bad!r} is not one of" in str(from_file.value)
        assert str(from_file.value) == str(from_frame.value)
        assert from_file.value.where.row == 4
