"""`turn-datasets remap open`: the REMAP Open release's layout read into Turn-REMAP's contracts.

The trees are written here in the release's layout (turn_datasets.synthetic.remap_open),
with the spreadsheet as the release's .xls (xlwt), as .xlsx (openpyxl) and as a CSV export;
every value a test checks is the generator's truth, never read back through the reader.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import run_cli as run

from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.skeleton import to_z_up
from turn_datasets.synthetic.remap_open import (
    SHEET_RELATIVE,
    SKELETON_RELATIVE,
    write_remap_open,
)
from turn_eval.cli import cli as eval_cli

SHEET_COLUMNS = [
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
]


def datasets(args: list, capsys) -> tuple[int, str, str]:
    return run(datasets_cli, "turn-datasets", args, capsys)


def write_xls(table: pd.DataFrame, path: Path) -> Path:
    """The sheet as the release's .xls (BIFF8, xlwt): numbers as numbers, the rest as text."""
    import xlwt

    book = xlwt.Workbook()
    sheet = book.add_sheet("Sheet1")
    for j, name in enumerate(table.columns):
        sheet.write(0, j, name)
    for i, row in enumerate(table.itertuples(index=False), start=1):
        for j, value in enumerate(row):
            if isinstance(value, str):
                try:
                    value = float(value)
                except ValueError:
                    pass
            if isinstance(value, (int, float, np.integer, np.floating)):
                sheet.write(i, j, float(value))
            elif value is not None and value == value:
                sheet.write(i, j, str(value))
    book.save(str(path))
    return path


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    """A clean synthetic release (CSV sheet): 2 PD + 2 controls, 4 turns each."""
    root = tmp_path_factory.mktemp("release")
    synth = write_remap_open(root, n_pd=2, n_hc=2, turns_per_participant=4, seed=5)
    return synth


def copy_release(release, tmp_path: Path) -> Path:
    """A copy of the release's dataset folder to damage; returns the copy's dataset folder."""
    dst = tmp_path / "Open_dataset_REMAP"
    shutil.copytree(release.root, dst)
    return dst


def sheet_of(root: Path) -> Path:
    (found,) = (root.parent / SHEET_RELATIVE).glob("Turning_human_labels.*")
    return found


def turn_folder(root: Path, clip_id: str) -> Path:
    return root.parent / SKELETON_RELATIVE / clip_id


def read_sheet_csv(path: Path) -> pd.DataFrame:
    return pd.read_csv(path, dtype=str, keep_default_na=False)


def test_reads_the_release_into_the_contracts(release, tmp_path, capsys):
    out = tmp_path / "out"
    code, stdout, err = datasets(["remap", "open", release.root, "--out-dir", out], capsys)
    assert code == 0, err
    assert stdout == ""
    assert "up axis inferred from the trunk (head above the feet): -y for 16 arrays" in err
    assert err.strip().splitlines()[-1] == f"wrote 16 turns of 4 participants to {out}"
    truth = release.truth
    labels = pd.read_csv(out / "labels.csv", dtype=str, keep_default_na=False)
    assert list(labels.columns[:13]) == [
        "clip_id", "session", "subject", "cohort", "annotator", "start_s", "end_s",
        "duration_s", "angle_deg", "scenario", "location", "double_annotated", "source",
    ]  # fmt: skip
    assert list(labels.columns[13:]) == ["steps", "turn_type", "medication", "dbs"]
    assert labels["clip_id"].tolist() == truth["clip_id"].tolist()
    assert labels["clip_id"].iloc[0] == "Pt201_PD_n_350"  # Pt<id>_<PD|C>_n_<turn id>
    for col in ("subject", "cohort", "turn_type", "medication", "dbs", "scenario"):
        assert labels[col].tolist() == truth[col].tolist(), col
    assert labels["angle_deg"].astype(float).tolist() == truth["angle_deg"].tolist()
    assert labels["steps"].astype(int).tolist() == truth["steps"].tolist()
    np.testing.assert_allclose(labels["duration_s"].astype(float), truth["duration_s"], atol=0.005)
    # the spreadsheet relative to ROOT, and its row (row 1 is the header)
    assert labels["source"].iloc[2] == (
        "Turning/Data/turning_human_labels/Turning_human_labels.csv:4"
    )
    participants = pd.read_csv(out / "participants.csv", dtype=str, keep_default_na=False)
    assert participants[["subject", "cohort"]].values.tolist() == [
        ["Pt201", "PD"], ["Pt202", "PD"], ["Pt203", "HC"], ["Pt204", "HC"],
    ]  # fmt: skip
    with np.load(out / "skeletons.npz") as npz, np.load(out / "skeletons_2d.npz") as npz2:
        assert sorted(npz.files) == sorted(truth["clip_id"])
        for clip in truth.itertuples():
            k3, k2 = npz[clip.clip_id], npz2[clip.clip_id]
            assert k3.shape == (clip.n_frames, 17, 3) and k3.dtype == np.float32
            assert k2.shape == (clip.n_frames, 17, 2)
            # root-relative: the pelvis at the origin, as Strided Transformer writes it
            np.testing.assert_allclose(k3[:, 0], 0.0, atol=1e-6)
        # the values are the file's, row by row
        first = truth["clip_id"].iloc[0]
        raw = np.loadtxt(
            turn_folder(release.root, first) / "input_3D" / "keypoints.csv", delimiter=","
        )
        np.testing.assert_array_equal(npz[first], raw.reshape(-1, 17, 3).astype(np.float32))
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["n_clips"] == 16 and manifest["fps"] == 30.0
    assert manifest["counts"]["cohort"] == {"HC": 8, "PD": 8}
    assert manifest["counts"]["medication"] == truth["medication"].value_counts().to_dict()
    assert manifest["counts"]["angle_deg"] == {
        f"{a:g}": int(n) for a, n in truth["angle_deg"].value_counts().sort_index().items()
    }
    assert manifest["up_axis"]["found"] == {"-y": 16} and manifest["up_axis"]["inferred"]
    assert manifest["missing"] == {"folders_without_row": [], "rows_without_folder": []}
    by_path = {i["path"]: i["sha256"] for i in manifest["inputs"]}
    assert len(by_path) == 1 + 2 * 16
    sheet = sheet_of(release.root)
    rel = sheet.relative_to(release.root).as_posix()
    assert by_path[rel] == hashlib.sha256(sheet.read_bytes()).hexdigest()
    assert sorted(manifest["outputs"]) == sorted(p.name for p in out.iterdir())


def test_xls_xlsx_and_csv_sheets_give_the_same_labels(release, tmp_path, capsys):
    csv_sheet = sheet_of(release.root)
    table = read_sheet_csv(csv_sheet)
    outputs = {}
    for fmt in ("csv", "xlsx", "xls"):
        root = tmp_path / fmt
        shutil.copytree(release.root, root / "Open_dataset_REMAP")
        data = root / "Open_dataset_REMAP"
        sheet = sheet_of(data)
        if fmt != "csv":
            sheet.unlink()
            target = sheet.with_suffix(f".{fmt}")
            if fmt == "xlsx":
                # numbers as numbers, as a spreadsheet program saves them
                typed = table.map(lambda v: float(v) if v.replace(".", "", 1).isdigit() else v)
                typed.to_excel(target, index=False, engine="openpyxl")
            else:
                write_xls(table, target)
        out = tmp_path / f"out-{fmt}"
        code, _, err = datasets(["remap", "open", root, "--out-dir", out], capsys)
        assert code == 0, (fmt, err)
        labels = pd.read_csv(out / "labels.csv", dtype=str, keep_default_na=False)
        assert labels["source"].str.contains(f"Turning_human_labels.{fmt}:").all()
        outputs[fmt] = labels.drop(columns="source")
        assert (out / "skeletons.npz").read_bytes() == (
            tmp_path / "out-csv" / "skeletons.npz"
        ).read_bytes()
    pd.testing.assert_frame_equal(outputs["xlsx"], outputs["csv"])
    pd.testing.assert_frame_equal(outputs["xls"], outputs["csv"])


def test_angle_spellings_and_the_participant_prefix(release, tmp_path, capsys):
    root = copy_release(release, tmp_path)
    sheet = sheet_of(root)
    table = read_sheet_csv(sheet)
    table.loc[0, "turning_angle"] = "135 degrees"
    table.loc[1, "turning_angle"] = str(int(release.truth["angle_deg"].iloc[1]))
    table.loc[2, "Participant ID number"] = "Pt201"
    table.loc[3, "type_of_turn"] = "Step_Turn"
    table.to_csv(sheet, index=False)
    out = tmp_path / "out"
    code, _, err = datasets(["remap", "open", tmp_path, "--out-dir", out], capsys)
    assert code == 0, err
    labels = pd.read_csv(out / "labels.csv", keep_default_na=False)
    assert labels["angle_deg"].iloc[0] == 135.0
    assert labels["angle_deg"].iloc[1] == release.truth["angle_deg"].iloc[1]
    assert labels["subject"].iloc[2] == "Pt201" and labels["turn_type"].iloc[3] == "step"


@pytest.mark.parametrize("frame", ["y-down", "y-up", "z-up"])
def test_predictions_land_in_the_right_bin_and_direction_with_the_inferred_axis(
    release, tmp_path, capsys, frame
):
    out = tmp_path / "out"
    code, _, err = datasets(["remap", "open", release.root, "--out-dir", out], capsys)
    assert code == 0, err
    skeletons = out / "skeletons.npz"
    if frame != "y-down":
        # the same bodies written with y up or z up (rotations of the camera axes)
        axis = {"y-up": "y", "z-up": "z"}[frame]
        with np.load(skeletons) as npz:
            rotation = to_z_up(np.eye(3), "-y") @ to_z_up(np.eye(3), axis).T
            arrays = {k: npz[k] @ rotation for k in npz.files}
        skeletons = tmp_path / f"{frame}.npz"
        np.savez(skeletons, **arrays)
        found = {"y-up": "y", "z-up": "z"}[frame]
    else:
        found = "-y"
    pred = tmp_path / "pred.csv"
    args = ["predict", skeletons, "--layout", "h36m17", "--fps", "30", "--out", pred]
    code, _, err = run(eval_cli, "turn-eval", args, capsys)
    assert code == 0, err
    assert f"up axis inferred from the trunk (head above the feet): {found} for 16 arrays" in err
    table = pd.read_csv(pred).set_index("clip_id").loc[release.truth["clip_id"]]
    truth = release.truth.set_index("clip_id")
    bins = 45.0 * np.floor(table["angle_deg"] / 45.0 + 0.5)
    assert (bins == truth["angle_deg"]).all()
    assert (table["direction"] == truth["direction"]).all()
    # clean skeletons: the estimate (the net hip rotation) is the planted heading change but
    # for the pelvic sway at a walking turn's two ends (up to ±4° each) and the camera pitch
    np.testing.assert_allclose(table["angle_deg"], truth["heading_deg"].abs(), atol=10.0)
    # the same through h36m mine and its manifest
    index = tmp_path / "mined.csv"
    args = ["h36m", "mine", skeletons, "--layout", "h36m17", "--fps", "30", "--units", "m"]
    code, _, err = datasets([*args, "--out", index], capsys)
    assert code == 0, err
    assert f"inferred from the trunk: {found}" in err
    mined = json.loads(index.with_name("mined.manifest.json").read_text())
    assert mined["inputs"][0]["up_axes"] == [found]


def test_score_groups_by_every_label(release, tmp_path, capsys):
    out = tmp_path / "out"
    datasets(["remap", "open", release.root, "--out-dir", out], capsys)
    pred = tmp_path / "pred.csv"
    args = ["predict", out / "skeletons.npz", "--layout", "h36m17", "--fps", "30", "--out", pred]
    assert run(eval_cli, "turn-eval", args, capsys)[0] == 0
    by = [
        a
        for g in ("cohort", "medication", "dbs", "turn_type", "scenario", "steps")
        for a in ("--by", g)
    ]
    args = ["score", pred, "-r", out / "labels.csv", *by, "--bootstrap", "0", "--format", "json"]
    code, stdout, err = run(eval_cli, "turn-eval", args, capsys)
    assert code == 0, err
    scores = json.loads(stdout)
    truth = release.truth
    for col in ("medication", "dbs", "turn_type", "scenario", "steps"):
        groups = scores["by"][col]["groups"]
        expected = truth[col].astype(str).replace("", "(blank)").value_counts().to_dict()
        assert {g: v["n"] for g, v in groups.items()} == expected, col
    assert scores["overall"]["n"] == 16 and scores["overall"]["accuracy"] == 1.0


def test_same_inputs_give_the_same_bytes(release, tmp_path, capsys):
    for name in ("a", "b"):
        assert (
            datasets(["remap", "open", release.root, "--out-dir", tmp_path / name], capsys)[0] == 0
        )
    for file in ("labels.csv", "participants.csv", "skeletons.npz", "skeletons_2d.npz"):
        assert (tmp_path / "a" / file).read_bytes() == (tmp_path / "b" / file).read_bytes()
    a, b = (json.loads((tmp_path / n / "manifest.json").read_text()) for n in "ab")
    a.pop("created_utc"), b.pop("created_utc")
    a.pop("root"), b.pop("root")
    assert a == b


def test_help_has_the_example(tmp_path):
    exe = Path(sys.executable).parent / "turn-datasets"
    shown = subprocess.run([exe, "remap", "open", "--help"], capture_output=True, text=True)
    assert shown.returncode == 0
    lines = [line.strip() for line in shown.stdout.splitlines()]
    assert lines[lines.index("Example:") + 1].startswith("turn-datasets remap open ")


# ---- bad input: one line naming the file (and row), exit 2, nothing written ------------


def refused(args: list, capsys, out: Path) -> str:
    code, stdout, err = datasets(args, capsys)
    assert code == EXIT_BAD_INPUT, err
    assert stdout == ""
    lines = [line for line in err.splitlines() if line and line != "reading turns"]
    assert len(lines) == 1, err
    assert lines[0].startswith("turn-datasets: error: ")
    assert not out.exists()
    return lines[0]


def edit_sheet(root: Path, change) -> Path:
    sheet = sheet_of(root)
    table = read_sheet_csv(sheet)
    table = change(table)
    table.to_csv(sheet, index=False)
    return sheet


def test_folders_without_rows_and_rows_without_folders_are_listed(release, tmp_path, capsys):
    root = copy_release(release, tmp_path)
    first, last = release.truth["clip_id"].iloc[0], release.truth["clip_id"].iloc[-1]
    shutil.rmtree(turn_folder(root, last))  # a row with no folder
    shutil.copytree(turn_folder(root, first), turn_folder(root, "Pt201_PD_n_999"))  # no row
    out = tmp_path / "out"
    line = refused(["remap", "open", root, "--out-dir", out], capsys, out)
    sheet = sheet_of(root)
    assert line == (
        f"turn-datasets: error: {sheet}: 1 turn folder(s) with no spreadsheet row: "
        "Pt201_PD_n_999; 1 row(s) with no turn folder: row 17 (Turn ID 365) "
        "(hint: --allow-missing writes the rest and lists these)"
    )
    code, _, err = datasets(["remap", "open", root, "--out-dir", out, "--allow-missing"], capsys)
    assert code == 0, err
    assert "warning: left out 2 turns without a row or a folder" in err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["missing"]["folders_without_row"] == ["Pt201_PD_n_999"]
    assert manifest["missing"]["rows_without_folder"] == [
        "Turning/Data/turning_human_labels/Turning_human_labels.csv:17 (Turn ID 365)"
    ]
    assert manifest["n_clips"] == 15 and last not in np.load(out / "skeletons.npz").files


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda t: pd.concat([t, t.iloc[[2]]], ignore_index=True),
            ":18: Turn ID '352' is listed twice (first on row 4)",
        ),
        (
            lambda t: t.assign(**{"turning_angle": ["100_degrees"] + list(t["turning_angle"][1:])}),
            ":2: turning_angle '100_degrees' is not a positive multiple of 45 degrees",
        ),
        (
            lambda t: t.assign(**{"PD_or_C": ["HC"] + list(t["PD_or_C"][1:])}),
            ":2: PD_or_C 'HC' is not one of 'pd', 'c'",
        ),
        (
            lambda t: t.assign(
                **{
                    "On_or_Off_medication": list(t["On_or_Off_medication"][:3])
                    + ["Partly"]
                    + list(t["On_or_Off_medication"][4:])
                }
            ),
            ":5: On_or_Off_medication 'Partly' is not one of 'control', 'on medication'",
        ),
        (
            lambda t: t.assign(**{"DBS_state": ["Maybe"] + list(t["DBS_state"][1:])}),
            ":2: DBS_state 'Maybe' is not one of 'control', 'on dbs', 'off dbs', '-'",
        ),
        (
            lambda t: t.drop(columns="DBS_state"),
            ":1: the rater spreadsheet lacks column 'DBS_state'",
        ),
        (
            lambda t: t.assign(
                **{"number_of_turning_steps": ["2.5"] + list(t["number_of_turning_steps"][1:])}
            ),
            ":2: number_of_turning_steps '2.5' is not a whole number",
        ),
    ],
    ids=[
        "duplicate-turn-id",
        "angle-not-45",
        "pd-or-c",
        "medication",
        "dbs",
        "missing-column",
        "steps",
    ],
)
def test_bad_spreadsheet_values(release, tmp_path, capsys, change, message):
    root = copy_release(release, tmp_path)
    sheet = edit_sheet(root, change)
    out = tmp_path / "out"
    line = refused(["remap", "open", root, "--out-dir", out], capsys, out)
    assert line.startswith(f"turn-datasets: error: {sheet}{message}"), line


def test_a_folder_whose_participant_or_group_disagrees_with_its_row(release, tmp_path, capsys):
    for wrong, says in (("Pt299_PD_n_351", "Pt299 PD"), ("Pt201_C_n_351", "Pt201 C")):
        root = copy_release(release, tmp_path / wrong)
        turn_folder(root, "Pt201_PD_n_351").rename(turn_folder(root, wrong))
        out = tmp_path / wrong / "out"
        line = refused(["remap", "open", root, "--out-dir", out], capsys, out)
        assert line == (
            f"turn-datasets: error: {sheet_of(root)}:3: folder {wrong} says {says}, its row "
            "says Pt201 PD"
        )


def write_lines(path: Path, lines: list[str]) -> None:
    path.write_text("".join(f"{line}\n" for line in lines))


@pytest.mark.parametrize(
    "damage, message",
    [
        (
            lambda rows: rows[:4] + [",".join(rows[4].split(",")[:-1])] + rows[5:],
            ":5: 50 fields, expected 51 (17 joints x 3)",
        ),
        (
            lambda rows: rows[:2] + [rows[2].replace(rows[2].split(",")[7], "abc", 1)] + rows[3:],
            ":3: field 8 ('abc') is not a number",
        ),
        (
            lambda rows: rows[:6] + [rows[6].replace(rows[6].split(",")[0], "nan", 1)] + rows[7:],
            ":7: field 1 ('nan') is not a finite number",
        ),
        (
            lambda rows: rows[:6] + [rows[6].replace(rows[6].split(",")[3], "inf", 1)] + rows[7:],
            ":7: field 4 ('inf') is not a finite number",
        ),
        (lambda rows: [], ": the clip has no frame; a turn needs at least two"),
        (lambda rows: rows[:1], ":1: the clip has one frame; a turn needs at least two"),
    ],
    ids=["fields", "non-numeric", "nan", "inf", "empty", "one-frame"],
)
def test_bad_keypoints(release, tmp_path, capsys, damage, message):
    root = copy_release(release, tmp_path)
    path = turn_folder(root, "Pt202_PD_n_355") / "input_3D" / "keypoints.csv"
    write_lines(path, damage(path.read_text().splitlines()))
    out = tmp_path / "out"
    line = refused(["remap", "open", root, "--out-dir", out], capsys, out)
    assert line.startswith(f"turn-datasets: error: {path}{message}"), line


def test_a_2d_only_folder_is_refused_for_3d(release, tmp_path, capsys):
    root = copy_release(release, tmp_path)
    folder = turn_folder(root, "Pt203_C_n_358")
    shutil.rmtree(folder / "input_3D")
    out = tmp_path / "out"
    line = refused(["remap", "open", root, "--out-dir", out], capsys, out)
    assert line == (
        f"turn-datasets: error: {folder}: the folder has 2D keypoints only (no "
        "input_3D/keypoints.csv) (hint: lift to 3D first)"
    )


def test_two_spreadsheets_are_refused(release, tmp_path, capsys):
    root = copy_release(release, tmp_path)
    sheet = sheet_of(root)
    write_xls(read_sheet_csv(sheet), sheet.with_suffix(".xls"))
    out = tmp_path / "out"
    line = refused(["remap", "open", tmp_path, "--out-dir", out], capsys, out)
    assert line.startswith(
        f"turn-datasets: error: {tmp_path}: 2 rater spreadsheets under this folder: "
    )
    assert str(sheet) in line and str(sheet.with_suffix(".xls")) in line


def test_an_unclear_vertical_axis_is_refused(release, tmp_path, capsys):
    root = copy_release(release, tmp_path)
    path = turn_folder(root, "Pt204_C_n_362") / "input_3D" / "keypoints.csv"
    k = np.loadtxt(path, delimiter=",").reshape(-1, 17, 3)
    c = np.cos(np.deg2rad(45.0))
    lying = k @ np.array([[c, -c, 0.0], [c, c, 0.0], [0.0, 0.0, 1.0]])  # trunk between x and -y
    write_lines(path, [",".join(f"{v:.6f}" for v in row) for row in lying.reshape(len(k), -1)])
    out = tmp_path / "out"
    line = refused(["remap", "open", root, "--out-dir", out], capsys, out)
    assert line.startswith(f"turn-datasets: error: {path}: the trunk is not clearly along one axis")
    # stated, the axis is taken as stated
    code, _, err = datasets(["remap", "open", root, "--out-dir", out, "--up-axis", "-y"], capsys)
    assert code == 0, err
    assert json.loads((out / "manifest.json").read_text())["up_axis"]["found"] == {"-y": 16}


def test_no_release_under_the_folder(tmp_path, capsys):
    out = tmp_path / "out"
    (tmp_path / "empty").mkdir()
    line = refused(["remap", "open", tmp_path / "empty", "--out-dir", out], capsys, out)
    assert "no rater spreadsheet (Turning_human_labels.xls, .xlsx or .csv) under this" in line


def test_a_link_loop_above_the_release_ends(release, tmp_path, capsys):
    root = copy_release(release, tmp_path / "top")
    (root / "Turning" / "back").symlink_to(tmp_path / "top", target_is_directory=True)
    out = tmp_path / "out"
    code, _, err = datasets(["remap", "open", tmp_path / "top", "--out-dir", out], capsys)
    assert code == 0, err
    assert len(pd.read_csv(out / "labels.csv")) == 16


def test_the_2d_keypoints_are_refused_by_predict_with_what_to_do(release, tmp_path, capsys):
    out = tmp_path / "out"
    datasets(["remap", "open", release.root, "--out-dir", out], capsys)
    pred = tmp_path / "pred.csv"
    args = ["predict", out / "skeletons_2d.npz", "--layout", "h36m17", "--out", pred]
    code, _, err = run(eval_cli, "turn-eval", args, capsys)
    assert code == EXIT_BAD_INPUT and not pred.exists()
    (line,) = [x for x in err.splitlines() if x.startswith("turn-eval: error:")]
    n = int(release.truth["n_frames"].iloc[0])
    assert line.endswith(
        f"Pt201_PD_n_350: array has shape ({n}, 17, 2), expected (frames, joints, 3); these are "
        "2D keypoints (hint: lift them to 3D first)"
    ), line


def test_a_participant_in_two_groups_is_refused(release, tmp_path, capsys):
    root = copy_release(release, tmp_path)

    def regroup(t: pd.DataFrame) -> pd.DataFrame:
        t.loc[1, "PD_or_C"] = "C"  # Pt201's second turn: a control
        return t

    sheet = edit_sheet(root, regroup)
    out = tmp_path / "out"
    line = refused(["remap", "open", root, "--out-dir", out], capsys, out)
    assert line == f"turn-datasets: error: {sheet}:3: Pt201 is HC here and PD on row 2"


def test_empty_steps_duration_and_turn_type_are_blank_not_refused(release, tmp_path, capsys):
    from turn_datasets.remap.open_sheet import read_sheet

    root = copy_release(release, tmp_path)

    def blank(t: pd.DataFrame) -> pd.DataFrame:
        t.loc[0, ["number_of_turning_steps", "turning_duration", "type_of_turn"]] = ""
        return t

    sheet = edit_sheet(root, blank)
    first = read_sheet(sheet)[0]
    assert first.steps is None and np.isnan(first.duration_s) and first.turn_type == ""
    out = tmp_path / "out"
    code, _, err = datasets(["remap", "open", root, "--out-dir", out], capsys)
    assert code == 0, err
    row = pd.read_csv(out / "labels.csv", dtype=str, keep_default_na=False).iloc[0]
    assert (row["steps"], row["duration_s"], row["turn_type"], row["start_s"]) == ("", "", "", "")
    # an empty DBS state is not "no stimulator" ('-'): it is refused
    edit_sheet(root, lambda t: t.assign(DBS_state=[""] + list(t["DBS_state"][1:])))
    line = refused(
        ["remap", "open", root, "--out-dir", tmp_path / "out2"], capsys, tmp_path / "out2"
    )
    assert line.endswith(":2: DBS_state '' is not one of 'control', 'on dbs', 'off dbs', '-'")
