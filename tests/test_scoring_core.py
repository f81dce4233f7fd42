"""The scoring core clips and events share: --by, the average row, the signature."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from conftest import run_turn_eval as run

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_eval.scoring.groups import average, check_groupings, split_by
from turn_eval.scoring.signature import Signature, signature_line

CLIP_REF = (
    "clip_id,angle_deg,duration_s,cohort,scenario\n"
    "a,90,1.0,PD,home\n"
    "b,180,2.0,HC,home\n"
    "c,45,0.5,PD,clinic\n"
    "d,135,1.5,HC,clinic\n"
)
CLIP_PRED = "clip_id,angle_deg\na,92.5\nb,170\nc,40\nd,100\n"
EVENT_REF = (
    "session,subject,start_s,end_s,angle_deg,cohort,scenario\n"
    "s1,P1,0,2,90,PD,scripted\n"
    "s1,P1,10,12,180,PD,free-living\n"
    "s2,P2,0,3,135,HC,scripted\n"
)
EVENT_DET = "session,subject,start_s,end_s,angle_deg\ns1,P1,0,2,80\ns2,P2,0.5,3,135\n"


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture()
def clips(tmp_path: Path) -> tuple[Path, Path]:
    folder = tmp_path / "clips"
    folder.mkdir()
    (folder / "ref.csv").write_text(CLIP_REF, encoding="utf-8")
    (folder / "pred.csv").write_text(CLIP_PRED, encoding="utf-8")
    return folder / "pred.csv", folder / "ref.csv"


@pytest.fixture()
def events(tmp_path: Path) -> tuple[Path, Path]:
    folder = tmp_path / "events"
    folder.mkdir()
    (folder / "ref.csv").write_text(EVENT_REF, encoding="utf-8")
    (folder / "det.csv").write_text(EVENT_DET, encoding="utf-8")
    return folder / "det.csv", folder / "ref.csv"


# --- --by -------------------------------------------------------------------------------------


def test_split_by_takes_repeats_and_commas_alike():
    assert (
        split_by(["cohort,scenario"])
        == split_by(["cohort", "scenario"])
        == [
            "cohort",
            "scenario",
        ]
    )
    assert split_by([" cohort , ", ",scenario"]) == ["cohort", "scenario"]
    assert split_by(None) == split_by([]) == split_by([","]) == []


def test_check_groupings_matches_case_dedupes_and_refuses_unknown_names():
    cols = ("cohort", "scenario", "bin_deg")
    assert check_groupings(["Cohort, scenario", "COHORT"], cols, default=()) == [
        "cohort",
        "scenario",
    ]
    assert check_groupings([], cols, default=("bin_deg",)) == ["bin_deg"]
    with pytest.raises(TurnbenchError, match=r"--by 'room'.*it has cohort, scenario, bin_deg"):
        check_groupings(["cohort,room"], cols, default=(), file="ref.csv")


def test_average_is_the_unweighted_mean_of_defined_values():
    groups = [{"n": 1, "mae": 10.0}, {"n": 3, "mae": None}, {"n": 2, "mae": 20.0}]
    # n: (1 + 3 + 2) / 3; mae: (10 + 20) / 2, the None left out; "wprec" defined nowhere
    assert average(groups, ("n", "mae", "wprec")) == {"n": 2.0, "mae": 15.0, "wprec": None}


@pytest.mark.parametrize("command", ["score", "score-events"])
def test_by_comma_separated_gives_the_groups_of_by_repeated(command, clips, events, capsys):
    first, ref = clips if command == "score" else events
    base = [command, first, "-r", ref, "--format", "json", "--bootstrap", "20"]
    code, comma, err = run([*base, "--by", "cohort,scenario"], capsys)
    assert code == 0, err
    code, repeated, err = run([*base, "--by", "cohort", "--by", "scenario"], capsys)
    assert code == 0, err
    a, b = json.loads(comma), json.loads(repeated)
    assert list(a["by"]) == ["cohort", "scenario"]
    assert a["by"] == b["by"] and a["overall"] == b["overall"]
    groups = {"cohort": ["HC", "PD"], "scenario": ["clinic", "home"]}
    if command == "score-events":
        groups["scenario"] = ["free-living", "scripted"]
    assert {k: sorted(v["groups"]) for k, v in a["by"].items()} == groups


# --- the signature ------------------------------------------------------------------------------


def test_signature_line_and_object_by_hand():
    sig = Signature(
        "score",
        (("by", "cohort,scenario"), ("seed", "0")),
        (("reference", "ab" * 32), ("predictions", "cd" * 32)),
        "1.2.3",
    )
    assert sig.line() == (
        "turnbench-score|by:cohort,scenario|seed:0|reference:abababababab"
        "|predictions:cdcdcdcdcdcd|version:1.2.3"
    )
    doc = sig.as_dict()
    assert doc == {
        "command": "score",
        "version": "1.2.3",
        "options": "by:cohort,scenario|seed:0",
        "reference_sha256": "ab" * 32,
        "predictions_sha256": "cd" * 32,
    }
    assert signature_line(doc) == sig.line()


def test_signature_of_hashes_the_files_and_prints_options(tmp_path: Path):
    f = tmp_path / "x.csv"
    f.write_bytes(b"clip_id,angle_deg\n")
    sig = Signature.of("score", [("abs", True), ("bin", 45.0), ("by", [])], {"reference": f})
    assert sig.options_text == "abs:yes|bin:45|by:-"
    assert sig.sha256 == (("reference", hashlib.sha256(b"clip_id,angle_deg\n").hexdigest()),)
    # a table built in memory has no file: left out, not an error
    assert Signature.of("score", [], {"reference": None}).sha256 == ()


def test_score_json_and_markdown_carry_the_signature(clips, capsys):
    pred, ref = clips
    args = ["score", pred, "-r", ref, "--by", "cohort", "--bootstrap", "30", "--seed", "4"]
    code, out, err = run([*args, "--format", "json"], capsys)
    assert code == 0, err
    sig = json.loads(out)["signature"]
    assert sig == {
        "command": "score",
        "version": __version__,
        "options": "by:cohort|bin:45|bootstrap:percentile-30|seed:4|abs:no|allow-missing:no",
        "reference_sha256": _sha(ref),
        "predictions_sha256": _sha(pred),
    }
    code, out, err = run([*args, "--format", "md"], capsys)
    assert code == 0, err
    assert out.splitlines()[-1] == (
        f"signature: turnbench-score|{sig['options']}|reference:{_sha(ref)[:12]}"
        f"|predictions:{_sha(pred)[:12]}|version:{__version__}"
    )


def test_score_events_json_and_markdown_carry_the_signature(events, capsys):
    det, ref = events
    args = ["score-events", det, "-r", ref, "--by", "cohort", "--bootstrap", "0"]
    code, out, err = run([*args, "--format", "json"], capsys)
    assert code == 0, err
    sig = json.loads(out)["signature"]
    assert sig["command"] == "score-events" and sig["version"] == __version__
    assert sig["options"] == (
        "iou:0.5|by:cohort|bin:45|bootstrap:cluster-percentile-0|seed:0|ignore-unknown:no"
    )
    assert (sig["reference_sha256"], sig["detections_sha256"]) == (_sha(ref), _sha(det))
    assert "context_sha256" not in sig  # not given
    code, out, err = run([*args, "--format", "md"], capsys)
    assert code == 0, err
    last = out.splitlines()[-1]
    assert last.startswith("signature: turnbench-score-events|iou:0.5|")
    assert f"|reference:{_sha(ref)[:12]}|detections:{_sha(det)[:12]}|" in last


def test_compare_takes_r_and_signs_both_submissions(clips, tmp_path: Path, capsys):
    pred, ref = clips
    other = tmp_path / "b.csv"
    other.write_text("clip_id,angle_deg\na,90\nb,180\nc,45\nd,140\n", encoding="utf-8")
    code, out, err = run(["compare", pred, other, "-r", ref, "--bootstrap", "20"], capsys)
    assert code == 0, err
    assert out.splitlines()[-1] == (
        "signature: turnbench-compare|n:4|bin:45deg|bootstrap:paired-percentile-20|seed:0"
        f"|p:shift-two-sided|mcnemar:exact|reference:{_sha(ref)[:12]}|a:{_sha(pred)[:12]}"
        f"|b:{_sha(other)[:12]}|version:{__version__}"
    )
    code, out, err = run(
        ["compare", pred, other, "-r", ref, "--bootstrap", "20", "--format", "json"], capsys
    )
    assert code == 0, err
    sig = json.loads(out)["signature"]
    assert (sig["reference_sha256"], sig["a_sha256"], sig["b_sha256"]) == (
        _sha(ref),
        _sha(pred),
        _sha(other),
    )


# --- the signature hashes the bytes the reader read ---------------------------------------


def test_the_reader_hashes_the_bytes_it_read(tmp_path: Path):
    from turn_datasets.usertable import read_table

    # A BOM, CRLF and semicolons: the sha256 is of the file's bytes, not of the text read.
    raw = b"\xef\xbb\xbfclip_id;angle_deg\r\na;90,5\r\nb;180\r\n"
    path = tmp_path / "ref.csv"
    path.write_bytes(raw)
    assert read_table(path, what="reference").sha256 == hashlib.sha256(raw).hexdigest()


@pytest.fixture()
def no_second_read(monkeypatch):
    """A signature that reads an input again fails the test."""
    import turn_eval.scoring.signature as signature

    def read_again(path, *args, **kwargs):
        pytest.fail(f"the signature read {path} again")

    monkeypatch.setattr(signature, "sha256_file", read_again)


def test_score_and_compare_sign_the_bytes_read_without_reading_again(
    clips, tmp_path: Path, capsys, no_second_read
):
    pred, ref = clips
    code, out, err = run(["score", pred, "-r", ref, "--format", "json"], capsys)
    assert code == 0, err
    sig = json.loads(out)["signature"]
    assert (sig["reference_sha256"], sig["predictions_sha256"]) == (_sha(ref), _sha(pred))
    other = tmp_path / "b.csv"
    other.write_bytes(b"\xef\xbb\xbfclip_id,angle_deg\r\na,90\r\nb,180\r\nc,45\r\nd,140\r\n")
    code, out, err = run(
        ["compare", pred, other, "-r", ref, "--bootstrap", "20", "--format", "json"], capsys
    )
    assert code == 0, err
    sig = json.loads(out)["signature"]
    assert (sig["reference_sha256"], sig["a_sha256"], sig["b_sha256"]) == (
        hashlib.sha256(CLIP_REF.encode()).hexdigest(),
        hashlib.sha256(CLIP_PRED.encode()).hexdigest(),
        hashlib.sha256(other.read_bytes()).hexdigest(),
    )


def test_score_events_signs_the_bytes_read_without_reading_again(
    events, tmp_path: Path, capsys, no_second_read
):
    det, ref = events
    sessions = tmp_path / "sessions.csv"
    sessions.write_bytes(b"\xef\xbb\xbfsession,subject,duration_s\r\ns1,P1,60\r\ns2,P2,30\r\n")
    args = ["score-events", det, "-r", ref, "--sessions", sessions, "--bootstrap", "0"]
    code, out, err = run([*args, "--format", "json"], capsys)
    assert code == 0, err
    sig = json.loads(out)["signature"]
    assert (sig["reference_sha256"], sig["detections_sha256"], sig["sessions_sha256"]) == (
        hashlib.sha256(EVENT_REF.encode()).hexdigest(),
        hashlib.sha256(EVENT_DET.encode()).hexdigest(),
        hashlib.sha256(sessions.read_bytes()).hexdigest(),
    )
