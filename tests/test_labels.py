"""Labels: participants table, adjudication of two raters, clip ids, Tables 1 and 2."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _eaf_builder import Tier, write_eaf

from turn_datasets.errors import TurnbenchError
from turn_datasets.remap.eaf import read_annotations
from turn_datasets.remap.labels import LABEL_COLUMNS, adjudicate, clip_id_for, make_labels
from turn_datasets.remap.participants import PARTICIPANT_COLUMNS, read_participants
from turn_datasets.remap.stats import read_labels, stats_csv, table1, table2, turns_per_location

REPO = Path(__file__).resolve().parents[1]

# ---------------------------------------------------------------------------------------
# Participants


def _csv(tmp_path: Path, text: str, name: str = "participants.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_example_participants_table() -> None:
    df = read_participants(REPO / "annotations" / "participants-example.csv")
    assert list(df.columns) == list(PARTICIPANT_COLUMNS)
    assert df["subject"].tolist() == ["PD01", "HC01", "PD02", "HC02"]
    assert df["cohort"].tolist() == ["PD", "HC", "PD", "HC"]
    assert df["age"].tolist() == [67.0, 69.0, 72.0, 70.0]
    assert df["years_since_diagnosis"].iloc[2] == 9.5
    assert math.isnan(df["years_since_diagnosis"].iloc[1])


def test_participants_forgiving_layout(tmp_path: Path) -> None:
    # BOM, columns in another order, an extra column, a blank line, lower-case cohort.
    path = _csv(
        tmp_path,
        "\ufeffCohort,subject,age,sex,pair,years_since_diagnosis,notes\n"
        "pd, P1 ,60,F,a,3,x\n\n"
        "HC,P2,,M,a,,\n",
    )
    df = read_participants(path)
    assert df["subject"].tolist() == ["P1", "P2"]
    assert df["cohort"].tolist() == ["PD", "HC"]
    assert math.isnan(df["age"].iloc[1])


HEADER = "subject,cohort,pair,sex,age,years_since_diagnosis\n"


@pytest.mark.parametrize(
    "body,line,fragment",
    [
        ("P1,PD,a,F,60,3\nP1,HC,a,M,61,\n", 3, "listed twice (first on line 2)"),
        ("P1,XX,a,F,60,3\n", 2, "not PD or HC"),
        ("P1,PD,a,F,60,3\nP2,PD,a,F,sixty,3\n", 3, "age 'sixty' is not a number"),
        ("P1,PD,a,F,160,3\n", 2, "outside"),
        ("P1,HC,a,F,60,2\n", 2, "healthy control"),
        ("P1,PD,a,F,40,50\n", 2, "diagnosed 50 years ago"),
        (",PD,a,F,40,5\n", 2, "empty subject"),
    ],
)
def test_participants_errors_name_file_and_line(
    tmp_path: Path, body: str, line: int, fragment: str
) -> None:
    path = _csv(tmp_path, HEADER + body)
    with pytest.raises(TurnbenchError) as info:
        read_participants(path)
    assert f"{path}:{line}" in str(info.value)
    assert fragment in str(info.value)


def test_participants_missing_column_and_empty(tmp_path: Path) -> None:
    path = _csv(tmp_path, "subject,cohort\nP1,PD\n")
    with pytest.raises(TurnbenchError, match="lacks column"):
        read_participants(path)
    with pytest.raises(TurnbenchError, match="no subject"):
        read_participants(_csv(tmp_path, HEADER, "empty.csv"))
    with pytest.raises(TurnbenchError, match="not found"):
        read_participants(tmp_path / "nope.csv")


# ---------------------------------------------------------------------------------------
# Adjudication on a session whose every case is known by construction


def _session(tmp_path: Path, *, with_unresolved: bool = True) -> Path:
    alice = [
        (1000, 2000, "90"),  # T1: bob agrees (ratio 0.9/1.0)
        (3000, 4000, "180"),  # T2: bob says 135 (ratio 1.0/1.1); consensus says 180
        (6000, 7000, "90"),  # T3: only alice
        (11000, 12000, "90"),  # T5: bob's 11.5-13 overlaps 0.5 of 1.5 s: ratio 1/3, unmatched
    ]
    bob = [
        (1100, 2000, "90"),
        (3000, 4100, "135"),
        (9000, 9500, "270"),  # T4: only bob
        (11500, 13000, "90"),
    ]
    if with_unresolved:
        alice.append((15000, 16000, "90"))  # T6: bob says 180, nobody decides
        bob.append((15000, 16000, "180"))
    return write_eaf(
        tmp_path / "S01.eaf",
        [
            Tier("Turn alice P01", annotator="alice", participant="P01", annotations=alice),
            Tier("Turn bob P01", annotator="bob", participant="P01", annotations=bob),
            Tier(
                "Turn consensus P01",
                annotator="Consensus",
                participant="P01",
                # matches T2; 20-21 s matches nothing: a turn only the consensus labelled
                annotations=[(3050, 4050, "180"), (20000, 21000, "225")],
            ),
            Tier("Scenario", annotations=[(0, 30000, "clinical")]),
            Tier("Location", annotations=[(0, 30000, "kitchen")]),
        ],
    )


def test_adjudication_by_hand(tmp_path: Path) -> None:
    path = _session(tmp_path)
    adj = adjudicate(read_annotations(path))
    got = adj.labels[["annotator", "start_s", "end_s", "angle_deg", "double_annotated"]]
    expected = pd.DataFrame(
        [
            ("alice", 1.0, 2.0, 90.0, True),  # T1 agreed: the first rater's times
            ("consensus", 3.05, 4.05, 180.0, True),  # T2 decided by consensus
            ("alice", 6.0, 7.0, 90.0, False),  # T3
            ("bob", 9.0, 9.5, 270.0, False),  # T4
            # T5 (ratio 1/3 < 0.6): two overlapping turns of one person is no label (issue 10)
            ("consensus", 20.0, 21.0, 225.0, False),  # consensus only
        ],
        columns=got.columns,
    )
    pd.testing.assert_frame_equal(got, expected, check_dtype=False)
    assert list(adj.labels.columns) == list(LABEL_COLUMNS)
    assert set(adj.labels["scenario"]) == {"clinical"}
    assert set(adj.labels["location"]) == {"kitchen"}
    assert adj.labels["duration_s"].tolist() == [1.0, 1.0, 1.0, 0.5, 1.0]
    assert adj.labels["clip_id"].iloc[0] == "S01_P01_1000-2000"
    assert set(adj.labels["source"]) == {str(path)}
    # T5 and T6 are listed, not labelled.
    assert len(adj.unresolved) == 2
    u5, u6 = adj.unresolved.iloc[0], adj.unresolved.iloc[1]
    assert (u5["session"], u5["participant"], u5["start_s"], u5["end_s"]) == (
        "S01",
        "P01",
        11.0,
        13.0,
    )
    assert u5["values"] == (
        "overlapping turns: alice 90 (11.000-12.000 s), bob 90 (11.500-13.000 s)"
    )
    assert (u6["session"], u6["participant"], u6["start_s"], u6["end_s"]) == (
        "S01",
        "P01",
        15.0,
        16.0,
    )
    assert u6["values"] == "alice 90, bob 180"
    assert u5["tier"] == u6["tier"] == "Turn alice P01"


def test_lower_min_overlap_joins_turns(tmp_path: Path) -> None:
    adj = adjudicate(read_annotations(_session(tmp_path)), min_overlap=0.3)
    # T5 (ratio 1/3) is now one double-annotated turn with alice's times.
    t5 = adj.labels[adj.labels["start_s"].between(10.9, 11.6)]
    assert t5[["annotator", "start_s", "double_annotated"]].values.tolist() == [
        ["alice", 11.0, True]
    ]


def test_first_rater_resolves(tmp_path: Path) -> None:
    adj = adjudicate(read_annotations(_session(tmp_path)), resolve="first-rater")
    assert adj.unresolved.empty
    t6 = adj.labels[adj.labels["start_s"] == 15.0]
    assert t6[["annotator", "angle_deg", "double_annotated"]].values.tolist() == [
        ["alice", 90.0, True]
    ]
    # T5's two overlapping turns: the first rater's stands, bob's overlapping one goes
    t5 = adj.labels[adj.labels["start_s"].between(10.9, 11.6)]
    assert t5[["annotator", "start_s", "end_s"]].values.tolist() == [["alice", 11.0, 12.0]]
    assert len(adj.labels) == 7


def _participants(tmp_path: Path, rows: str = "P01,PD,a,F,60,3\n") -> pd.DataFrame:
    return read_participants(_csv(tmp_path, HEADER + rows))


def test_make_labels_adds_cohort(tmp_path: Path) -> None:
    ann = read_annotations(_session(tmp_path, with_unresolved=False))
    # min_overlap 0.3 makes T5 one turn, so no disagreement is left: T1-T5 and the consensus'
    labels = make_labels(ann, _participants(tmp_path), min_overlap=0.3)
    assert len(labels) == 6
    assert set(labels["cohort"]) == {"PD"}
    assert list(labels.columns) == list(LABEL_COLUMNS)
    assert labels["double_annotated"].dtype == bool


def test_make_labels_unresolved_error(tmp_path: Path) -> None:
    path = _session(tmp_path)
    listed: list[pd.DataFrame] = []
    with pytest.raises(TurnbenchError) as info:
        make_labels(read_annotations(path), _participants(tmp_path), on_unresolved=listed.append)
    msg = str(info.value)
    # the first of two (T5's overlapping turns at 11 s, then T6 at 15 s) locates the error
    assert str(path) in msg and "'Turn alice P01'" in msg and "11.000 s" in msg
    assert "2 turn(s)" in msg and "overlapping turns" in msg and "--resolve first-rater" in msg
    assert len(listed) == 1 and len(listed[0]) == 2
    assert listed[0]["values"].tolist()[1] == "alice 90, bob 180"
    assert listed[0]["start_s"].tolist() == [11.0, 15.0]


def test_make_labels_missing_participant(tmp_path: Path) -> None:
    path = _session(tmp_path)
    with pytest.raises(TurnbenchError) as info:
        make_labels(read_annotations(path), _participants(tmp_path, "P02,HC,a,F,60,\n"))
    msg = str(info.value)
    assert "'P01'" in msg and str(path) in msg and "'Turn alice P01'" in msg and "1.000 s" in msg


def test_clip_id() -> None:
    # Spaces become "-"; times are whole milliseconds, as ELAN stores them.
    assert clip_id_for(session="home visit 1", subject="PD 01", start_s=1.0, end_s=2.5) == (
        "home-visit-1_PD-01_1000-2500"
    )
    assert (
        clip_id_for(session="S1", subject="P1", start_s=12.345, end_s=13.0) == "S1_P1_12345-13000"
    )
    # 0.1 + 0.2 is 0.30000000000000004 in floating point: still 300 ms.
    assert clip_id_for(session="S", subject="P", start_s=0.1 + 0.2, end_s=1.0) == "S_P_300-1000"


def test_against_synthetic_ground_truth(tmp_path: Path) -> None:
    """Sessions from the project's generator: every label matches its planted turn."""
    from turn_datasets.synthetic.eaf import Raters, write_sessions

    synth = write_sessions(
        tmp_path / "eaf",
        seed=7,
        n_pairs=2,
        turns_per_subject=16,
        raters=Raters(disagreement_rate=0.25, missed_rate=0.1),
    )
    labels = make_labels(
        read_annotations(tmp_path / "eaf"), read_participants(synth.participants_path)
    )
    truth = synth.truth
    assert len(labels) == len(truth)
    # Each label overlaps exactly one planted turn of its session and subject.
    pairs = truth.merge(labels, on=["session", "subject"], suffixes=("_t", "_l"))
    overlap = pairs[["end_s_t", "end_s_l"]].min(axis=1) - pairs[["start_s_t", "start_s_l"]].max(
        axis=1
    )
    pairs = pairs[overlap > 0]
    assert len(pairs) == len(truth)
    assert (pairs["angle_deg_t"] == pairs["angle_deg_l"]).all()
    assert (pairs["scenario_t"] == pairs["scenario_l"]).all()
    assert (pairs["location_t"] == pairs["location_l"]).all()
    assert (pairs["cohort_t"] == pairs["cohort_l"]).all()
    # Labelled by both raters (agreed or adjudicated) is double-annotated; a turn one rater
    # missed is not, even in a double-annotated session.
    both = pairs["kind"].isin(["agree", "disagree"])
    assert (pairs["double_annotated_l"] == both).all()
    assert (pairs.loc[pairs["kind"] == "disagree", "annotator"] == "consensus").all()


# ---------------------------------------------------------------------------------------
# Tables 1 and 2, worked out by hand


def _labels_frame() -> pd.DataFrame:
    rows = [
        # subject, cohort, angle, scenario, location
        ("PD01", "PD", 90.0, "scripted", "kitchen"),
        ("PD01", "PD", 90.0, "scripted", "kitchen"),
        ("PD01", "PD", 135.0, "free-living", "hallway"),
        ("PD02", "PD", 180.0, "scripted", "kitchen"),
        ("HC01", "HC", 360.0, "free-living", "bedroom"),
        ("HC01", "HC", 90.0, "", "kitchen"),
    ]
    df = pd.DataFrame(rows, columns=["subject", "cohort", "angle_deg", "scenario", "location"])
    df["clip_id"] = [f"c{i}" for i in range(len(df))]
    return df


def test_table1_by_hand(tmp_path: Path) -> None:
    participants = _participants(
        tmp_path,
        "PD01,PD,a,F,60,4\nPD02,PD,b,M,70,10\nHC01,HC,a,M,65,\nHC02,HC,b,F,80,\n",
    )
    t1 = table1(_labels_frame(), participants).set_index("cohort")
    assert t1.loc["PD", "subjects"] == 2 and t1.loc["PD", "turns"] == 4
    assert t1.loc["HC", "subjects"] == 1 and t1.loc["HC", "turns"] == 2
    # HC02 has no turns, so is not counted (nor is their age).
    assert t1.loc["all", "subjects"] == 3 and t1.loc["all", "turns"] == 6
    # PD ages 60, 70: mean 65, sample sd sqrt(25 + 25) = 7.0711.
    assert t1.loc["PD", "age_mean"] == pytest.approx(65.0)
    assert t1.loc["PD", "age_sd"] == pytest.approx(math.sqrt(50))
    # Years since diagnosis 4, 10: mean 7, sd sqrt(9 + 9) = 4.2426.
    assert t1.loc["PD", "years_since_diagnosis_mean"] == pytest.approx(7.0)
    assert t1.loc["PD", "years_since_diagnosis_sd"] == pytest.approx(math.sqrt(18))
    assert t1.loc["HC", "age_mean"] == 65.0 and math.isnan(t1.loc["HC", "age_sd"])
    assert math.isnan(t1.loc["HC", "years_since_diagnosis_mean"])
    # All: 60, 70, 65 -> mean 65, sd sqrt((25 + 25 + 0) / 2) = 5.
    assert t1.loc["all", "age_mean"] == pytest.approx(65.0)
    assert t1.loc["all", "age_sd"] == pytest.approx(5.0)
    assert t1.loc["all", "years_since_diagnosis_mean"] == pytest.approx(7.0)


def test_table1_without_participants_and_unknown_subject(tmp_path: Path) -> None:
    t1 = table1(_labels_frame()).set_index("cohort")
    assert t1.loc["all", "turns"] == 6 and np.isnan(t1.loc["all", "age_mean"])
    with pytest.raises(TurnbenchError, match="HC01"):
        table1(_labels_frame(), _participants(tmp_path, "PD01,PD,a,F,60,4\nPD02,PD,b,M,70,10\n"))


def test_table2_by_hand() -> None:
    t2 = table2(_labels_frame())
    assert t2.columns.tolist() == [90, 135, 180, 225, 270, 315, 360, "total"]
    assert t2.index.tolist() == ["scripted", "clinical", "free-living", "(none)", "total"]
    assert t2.loc["scripted"].tolist() == [2, 0, 1, 0, 0, 0, 0, 3]
    assert t2.loc["clinical"].tolist() == [0] * 8
    assert t2.loc["free-living"].tolist() == [0, 1, 0, 0, 0, 0, 1, 2]
    assert t2.loc["(none)"].tolist() == [1, 0, 0, 0, 0, 0, 0, 1]
    assert t2.loc["total"].tolist() == [3, 1, 1, 0, 0, 0, 1, 6]


def test_turns_per_location_by_hand() -> None:
    loc = turns_per_location(_labels_frame())
    # kitchen: PD01 x2, PD02, HC01 -> PD 3, HC 1; hallway PD 1; bedroom HC 1.
    assert loc.index.tolist() == ["kitchen", "bedroom", "hallway", "total"]
    assert loc.loc["kitchen"].tolist() == [3, 1, 4]
    assert loc.loc["bedroom"].tolist() == [0, 1, 1]
    assert loc.loc["hallway"].tolist() == [1, 0, 1]
    assert loc.loc["total"].tolist() == [4, 2, 6]


def test_stats_csv_is_long_and_complete() -> None:
    df = _labels_frame()
    text = stats_csv(table1(df), table2(df), turns_per_location(df))
    from io import StringIO

    long = pd.read_csv(StringIO(text), dtype=str, keep_default_na=False)
    assert long.columns.tolist() == ["table", "row", "column", "value"]
    cell = long.set_index(["table", "row", "column"])["value"]
    assert cell[("table2", "scripted", "90")] == "2"
    assert cell[("table2", "total", "total")] == "6"
    assert cell[("table1", "PD", "turns")] == "4"
    assert cell[("locations", "kitchen", "PD")] == "3"


def test_read_labels_errors(tmp_path: Path) -> None:
    good = "clip_id,subject,cohort,angle_deg,scenario,location\n"
    path = _csv(
        tmp_path, good + "a,P1,PD,90,scripted,kitchen\nb,P1,PD,ninety,scripted,x\n", "l.csv"
    )
    with pytest.raises(TurnbenchError, match=rf"{path}:3.*ninety"):
        read_labels(path)
    path = _csv(tmp_path, good + "a,P1,XX,90,scripted,kitchen\n", "l2.csv")
    with pytest.raises(TurnbenchError, match=rf"{path}:2.*XX"):
        read_labels(path)
    path = _csv(tmp_path, "clip_id,subject\n", "l3.csv")
    with pytest.raises(TurnbenchError, match="lack column"):
        read_labels(path)


def test_read_labels_is_the_one_user_table_reader(tmp_path: Path) -> None:
    # A semicolon-delimited spreadsheet export with a BOM, a blank line and padded cells is
    # read as a submission is; the bad cohort's line is the file's own (5, not 4).
    text = (
        "\ufeffclip_id;Subject;cohort;angle_deg;scenario;location\n"
        "a;P1;PD;90;scripted;kitchen\n"
        "b;P2; hc ;180;scripted;hall\n"
        "\n"
        "c;P3;XX;90;scripted;hall\n"
    )
    path = _csv(tmp_path, text, "l.csv")
    with pytest.raises(TurnbenchError, match=rf"{path}:5: cohort 'XX'"):
        read_labels(path)
    path = _csv(tmp_path, text.replace("XX", "PD"), "l2.csv")
    df = read_labels(path)
    assert df["subject"].tolist() == ["P1", "P2", "P3"]
    assert df["cohort"].tolist() == ["PD", "HC", "PD"]
    assert df["angle_deg"].tolist() == [90.0, 180.0, 90.0]


def test_participants_are_read_by_the_one_user_table_reader(tmp_path: Path) -> None:
    # A semicolon export (a spreadsheet in a European locale), as every user table is read.
    path = _csv(
        tmp_path,
        "subject;cohort;pair;sex;age;years_since_diagnosis\nP1;pd;a;F;60;3\nP2;HC;a;M;58;\n",
    )
    df = read_participants(path)
    assert df["subject"].tolist() == ["P1", "P2"] and df["cohort"].tolist() == ["PD", "HC"]
    assert df["age"].tolist() == [60.0, 58.0]
