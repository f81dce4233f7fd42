"""Careless or absurd input files: read right, or refused with a line that blames the right
thing (issue 10, #7, #13, #16)."""

from __future__ import annotations

import json
import unicodedata
from pathlib import Path

import pytest

from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT, run_group
from turn_datasets.errors import TurnbenchError
from turn_datasets.limits import MAX_ANGLE_DEG, MAX_SPEED_DEG_S
from turn_eval.cli import cli as eval_cli
from turn_eval.clips.submission import read_predictions, read_reference

REFERENCE = "clip_id,angle_deg,duration_s\na,90,1.0\nb,180,2.0\nc,45,0.5\nd,135,1.5\n"
PREDICTIONS = "clip_id,angle_deg\na,92.5\nb,170\nc,40\nd,100\n"


def _run(group, prog, args, capsys):
    code = run_group(group, prog, [str(a) for a in args])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


@pytest.fixture()
def ref(tmp_path: Path) -> Path:
    path = tmp_path / "ref.csv"
    path.write_text(REFERENCE)
    return path


def _pred(tmp_path: Path, data: bytes) -> Path:
    path = tmp_path / "pred.csv"
    path.write_bytes(data)
    return path


# -- #13 ---------------------------------------------------------------------------------


def test_cr_only_line_endings_are_read_like_newlines(tmp_path, ref):
    pred = _pred(tmp_path, PREDICTIONS.replace("\n", "\r").encode())
    joined = read_predictions(pred, ref)
    assert joined.table["pred_angle_deg"].tolist() == [92.5, 170.0, 40.0, 100.0]


def test_cr_only_file_with_a_bad_row_names_its_line(tmp_path, ref, capsys):
    pred = _pred(tmp_path, b"clip_id,angle_deg\ra,92.5\rb,x\rc,40\rd,100\r")
    code, out, err = _run(eval_cli, "turn-eval", ["score", pred, "-r", ref], capsys)
    assert code == EXIT_BAD_INPUT and out == "" and "Traceback" not in err
    assert f"{pred}:3: angle_deg 'x' is not a number" in err


# -- #16 ---------------------------------------------------------------------------------


def test_mixed_line_endings_count_lines_as_an_editor_does(tmp_path, ref):
    text = "clip_id,angle_deg\r\na,92.5\rb,170\nc,40\r\nd,100\n"
    joined = read_predictions(_pred(tmp_path, text.encode()), ref)
    assert joined.table["pred_angle_deg"].tolist() == [92.5, 170.0, 40.0, 100.0]
    bad = "clip_id,angle_deg\r\na,92.5\rb,170\nc,oops\r\nd,100\n"
    with pytest.raises(TurnbenchError, match=r"pred.csv:4: angle_deg 'oops' is not a number"):
        read_predictions(_pred(tmp_path, bad.encode()), ref)


def test_utf16_without_bom_is_called_not_utf8(tmp_path, ref):
    pred = _pred(tmp_path, PREDICTIONS.encode("utf-16-le"))
    with pytest.raises(TurnbenchError, match="not UTF-8 text.*UTF-16") as info:
        read_predictions(pred, ref)
    assert "fields" not in str(info.value)


def test_ids_in_nfd_match_a_reference_in_nfc(tmp_path):
    nfc = unicodedata.normalize("NFC", "S1_Café_1")
    nfd = unicodedata.normalize("NFD", "S1_Café_1")
    assert nfc != nfd
    ref = tmp_path / "ref.csv"
    ref.write_text(f"clip_id,angle_deg\n{nfc},90\nb,180\n", encoding="utf-8")
    pred = _pred(tmp_path, f"clip_id,angle_deg\n{nfd},80\nb,170\n".encode())
    joined = read_predictions(pred, ref)
    assert joined.table["clip_id"].tolist() == [nfc, "b"]
    assert joined.table["pred_angle_deg"].tolist() == [80.0, 170.0]


def test_output_over_an_input_names_the_option_the_user_gave(tmp_path, ref, capsys):
    pred = _pred(tmp_path, PREDICTIONS.encode())
    out_dir = tmp_path / "o"
    out_dir.mkdir()
    (out_dir / "scores.csv").symlink_to(pred)
    code, _, err = _run(
        eval_cli, "turn-eval", ["score", pred, "-r", ref, "--out-dir", out_dir], capsys
    )
    assert code == EXIT_BAD_INPUT
    assert "choose another --out-dir" in err and "--out\n" not in err


# -- #7 ----------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["1.7e308", "3600.5", "-1e6"])
def test_an_absurd_predicted_angle_is_refused_with_its_line(tmp_path, ref, capsys, value):
    pred = _pred(tmp_path, PREDICTIONS.replace("170", value).encode())
    code, out, err = _run(eval_cli, "turn-eval", ["score", pred, "-r", ref, "--abs"], capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    assert f"{pred}:3: angle_deg" in err and f"plausible {MAX_ANGLE_DEG:g}" in err


def test_an_angle_at_the_bound_is_scored(tmp_path, ref):
    pred = _pred(tmp_path, PREDICTIONS.replace("170", "3600").encode())
    assert read_predictions(pred, ref).table["pred_angle_deg"].max() == 3600.0


def test_an_absurd_speed_is_refused(tmp_path, ref):
    text = "clip_id,angle_deg,speed_deg_s\na,90,90\nb,170,1e5\nc,40,80\nd,100,66\n"
    with pytest.raises(
        TurnbenchError, match=f"speed_deg_s 100000 is beyond the plausible {MAX_SPEED_DEG_S:g}"
    ):
        read_predictions(_pred(tmp_path, text.encode()), ref)


def test_an_absurd_reference_angle_is_refused(tmp_path):
    ref = tmp_path / "ref.csv"
    ref.write_text("clip_id,angle_deg\na,90\nb,1e308\n")
    with pytest.raises(TurnbenchError, match=r"ref.csv:3: angle_deg 1e\+308 is beyond"):
        read_reference(ref)


def test_h36m_stats_refuses_an_absurd_index_angle_instead_of_a_negative_bin(tmp_path, capsys):
    index = tmp_path / "idx.csv"
    index.write_text(
        "clip_id,subject,action,angle_deg,duration_s,bin_deg\n"
        "x,S1,Walking,90,1.0,90\n"
        "y,S1,Walking,1e308,1.0,-9223372036854775808\n"
    )
    code, out, err = _run(datasets_cli, "turn-datasets", ["h36m", "stats", index], capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    assert f"{index}:3: angle_deg 1e+308 is beyond the plausible 3600" in err
    assert "-9223372036854775808" not in err


def test_remap_stats_refuses_an_absurd_label_angle(tmp_path, capsys):
    labels = tmp_path / "labels.csv"
    labels.write_text(
        "clip_id,session,subject,cohort,annotator,start_s,end_s,duration_s,angle_deg,"
        "scenario,location,double_annotated,source\n"
        "c,S01,PD01,PD,a,1,2,1,1e300,scripted,Lounge,False,S01.eaf\n"
    )
    code, out, err = _run(datasets_cli, "turn-datasets", ["remap", "stats", labels], capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    assert f"{labels}:2: angle_deg 1e+300 is beyond the plausible 3600" in err


def test_json_scores_never_null_an_angle_metric_from_a_huge_prediction(tmp_path, ref, capsys):
    # the bound is what keeps MAE a number: the largest accepted prediction gives a finite MAE
    pred = _pred(tmp_path, PREDICTIONS.replace("170", "3600").encode())
    code, out, err = _run(
        eval_cli,
        "turn-eval",
        ["score", pred, "-r", ref, "--format", "json", "--bootstrap", "0"],
        capsys,
    )
    assert code == 0, err
    assert json.loads(out)["overall"]["mae_deg"] == pytest.approx((2.5 + 3420 + 5 + 35) / 4)


def test_the_readme_error_section_states_the_declared_bounds():
    from turn_datasets import limits

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    section = readme.split("## Errors, exit codes and plausible bounds", 1)[1].split("\n## ", 1)[0]
    assert f"at most {limits.MAX_ANGLE_DEG:g}°" in section
    assert f"at most {limits.MAX_SPEED_DEG_S:g} °/s" in section
    assert f"at most {limits.MAX_FPS_HZ:g} Hz" in section
    assert f"{limits.MIN_FPS_HZ:g}-{limits.MAX_FPS_HZ:g} Hz" in section
    assert f"at most {limits.MAX_DURATION_S:g} s" in section
    assert f"at most {limits.MAX_BIN_WIDTH_DEG:g}°" in section
    assert f"at most {limits.MAX_RESAMPLES} resamples" in section
    assert "turn_datasets/limits.py" in section
