"""``turn-eval predict``: every input format and up axis, errors naming file and key."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
from test_predict import minus_y_up_copy, turning_skeleton, y_up_copy

from turn_datasets.cli.common import EXIT_BAD_INPUT, run_group
from turn_datasets.skeleton import H36M32
from turn_eval.cli import cli
from turn_eval.clips import metrics
from turn_eval.clips import submission as predictions

CONVERT = {"z": lambda p: p, "y": y_up_copy, "-y": minus_y_up_copy}


def run(args: list[str], capsys) -> tuple[int, str, str]:
    code = run_group(cli, "turn-eval", [str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def write_skeletons(path: Path, clips: dict[str, np.ndarray]) -> Path:
    """Write clips in the format named by the suffix (.npy holds exactly one)."""
    if path.suffix == ".npy":
        ((name, array),) = clips.items()
        path = path.with_name(f"{name}.npy")
        np.save(path, array)
    elif path.suffix == ".npz":
        np.savez(path, **clips)
    else:
        with h5py.File(path, "w") as fh:
            for name, array in clips.items():
                fh.create_dataset(name, data=array)
    return path


@pytest.mark.parametrize("suffix", [".npy", ".npz", ".h5"])
@pytest.mark.parametrize("up_axis", ["z", "y", "-y"])
def test_known_turn_through_every_format_and_up_axis(tmp_path, capsys, suffix, up_axis):
    # A 120° right turn (yaw 10° -> -110°) written in the given convention and format.
    skeleton = CONVERT[up_axis](turning_skeleton(np.linspace(10.0, -110.0, 75)))
    src = write_skeletons(tmp_path / f"poses{suffix}", {"S9_turn": skeleton})
    out = tmp_path / "predictions.csv"
    code, stdout, stderr = run(
        ["predict", src, "--layout", "h36m17", "--up-axis", up_axis, "--out", out], capsys
    )
    assert code == 0, stderr
    assert stdout == ""  # the result is the file; stdout stays clean for pipes
    assert f"wrote predictions for 1 clip to {out}" in stderr
    table = pd.read_csv(out)
    assert list(table.columns) == ["clip_id", "angle_deg", "direction"]
    assert table["clip_id"].tolist() == ["S9_turn"]
    assert table["angle_deg"].iloc[0] == pytest.approx(120.0)
    assert table["direction"].iloc[0] == "right"


def test_methods_on_a_turn_back_and_speed(tmp_path, capsys):
    # 0 -> 180° then back to 90°: net 90°, equation 3 as printed 180 + 90 = 270°.
    # 121 frames at 50 Hz = 2.42 s, so speeds are 90 / 2.42 and 270 / 2.42 °/s.
    yaw = np.concatenate([np.linspace(0.0, 180.0, 61), np.linspace(180.0, 90.0, 61)[1:]])
    src = write_skeletons(tmp_path / "a.npz", {"back": turning_skeleton(yaw)})
    results = {}
    for method in ("net", "paper"):
        out = tmp_path / f"{method}.csv"
        args = ["predict", src, "--layout", "h36m17", "--method", method, "--fps", "50"]
        code, _, stderr = run([*args, "--out", out], capsys)
        assert code == 0, stderr
        results[method] = pd.read_csv(out).iloc[0]
    assert results["net"]["angle_deg"] == pytest.approx(90.0)
    assert results["paper"]["angle_deg"] == pytest.approx(270.0)
    assert results["net"]["speed_deg_s"] == pytest.approx(90.0 / 2.42)
    assert results["paper"]["speed_deg_s"] == pytest.approx(270.0 / 2.42)
    assert results["net"]["direction"] == results["paper"]["direction"] == "left"


def test_several_files_joints_option_and_h5_groups(tmp_path, capsys):
    n = 40
    knee_lag = turning_skeleton(np.linspace(0, 90, n), H36M32, knee_yaw_deg=np.linspace(0, 30, n))
    a = write_skeletons(tmp_path / "first.npz", {"c1": knee_lag})
    b = tmp_path / "second.h5"
    with h5py.File(b, "w") as fh:
        fh.create_dataset("S11/walk", data=turning_skeleton(np.linspace(0, 45, n), H36M32))
    out = tmp_path / "p.csv"
    args = ["predict", a, b, "--layout", "h36m32", "--joints", "hip,knee", "--out", out]
    code, _, stderr = run(args, capsys)
    assert code == 0, stderr
    table = pd.read_csv(out)
    assert table["clip_id"].tolist() == ["c1", "S11/walk"]  # files in the order given
    # (90 + 30) / 2 = 60° for the clip whose knees lag; 45° for the other.
    assert table["angle_deg"].tolist() == pytest.approx([60.0, 45.0])


def test_output_is_a_valid_predictions_file(tmp_path, capsys):
    src = write_skeletons(
        tmp_path / "s.npz",
        {
            "c1": turning_skeleton(np.linspace(0, 90, 30)),
            "c2": turning_skeleton(np.linspace(0, -180, 30)),
        },
    )
    out = tmp_path / "p.csv"
    code, _, stderr = run(
        ["predict", src, "--layout", "h36m17", "--fps", "50", "--out", out], capsys
    )
    assert code == 0, stderr
    ref = tmp_path / "ref.csv"
    ref.write_text("clip_id,angle_deg,duration_s\nc1,90,0.6\nc2,180,0.6\n", encoding="utf-8")
    joined = predictions.read_predictions(out, predictions.read_reference(ref)).table
    assert joined["clip_id"].tolist() == ["c1", "c2"]
    assert joined["pred_angle_deg"].tolist() == pytest.approx([90.0, 180.0])
    # 30 frames at 50 Hz = 0.6 s: 90 / 0.6 = 150 and 180 / 0.6 = 300 °/s, the reference's
    # own speeds over its durations, so the scored speed error is zero.
    assert joined["pred_speed_deg_s"].tolist() == pytest.approx([150.0, 300.0])
    scored = metrics.compute_metrics(
        joined["pred_angle_deg"],
        joined["ref_angle_deg"],
        ref_duration_s=joined["ref_duration_s"],
        pred_speed_deg_s=joined["pred_speed_deg_s"],
    )
    assert scored["accuracy"] == 1.0
    assert scored["mae_speed_deg_s"] == pytest.approx(0.0, abs=1e-9)


def test_same_inputs_give_byte_identical_output(tmp_path, capsys):
    src = write_skeletons(tmp_path / "s.npz", {"c1": turning_skeleton(np.linspace(0, 77.7, 33))})
    outs = [tmp_path / "one.csv", tmp_path / "two.csv"]
    for out in outs:
        code, _, _ = run(
            ["predict", src, "--layout", "h36m17", "--fps", "25", "--out", out], capsys
        )
        assert code == 0
    assert outs[0].read_bytes() == outs[1].read_bytes()


def test_duplicate_clip_across_files_names_both(tmp_path, capsys):
    a = write_skeletons(tmp_path / "a.npz", {"walk": turning_skeleton(np.linspace(0, 90, 20))})
    b = tmp_path / "b.h5"
    write_skeletons(b, {"walk": turning_skeleton(np.linspace(0, 45, 20))})
    out = tmp_path / "p.csv"
    code, stdout, stderr = run(["predict", a, b, "--layout", "h36m17", "--out", out], capsys)
    assert code == EXIT_BAD_INPUT
    assert stdout == ""
    error = [line for line in stderr.splitlines() if "error" in line]
    assert len(error) == 1
    assert str(a) in error[0] and str(b) in error[0] and "walk" in error[0]
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_wrong_joint_count_names_file_and_key(tmp_path, capsys):
    good = turning_skeleton(np.linspace(0, 90, 20))  # 17 joints
    src = write_skeletons(tmp_path / "mixed.npz", {"a_ok": good, "b_bad": good[:, :16]})
    out = tmp_path / "p.csv"
    code, _, stderr = run(["predict", src, "--layout", "h36m17", "--out", out], capsys)
    assert code == EXIT_BAD_INPUT
    assert f"{src}, b_bad: array has 16 joints but layout 'h36m17' has 17" in stderr
    assert not out.exists()


def test_unusable_clip_names_file_and_key(tmp_path, capsys):
    lost = turning_skeleton(np.linspace(0, 90, 20))
    lost[:, :, :] = np.nan
    src = write_skeletons(tmp_path / "x.npy", {"gone": lost})
    out = tmp_path / "p.csv"
    code, _, stderr = run(["predict", src, "--layout", "h36m17", "--out", out], capsys)
    assert code == EXIT_BAD_INPUT  # the default --up-axis auto has nothing to infer from
    assert f"{src}, gone: no frame shows the pelvis, neck, head and both feet" in stderr
    assert not out.exists()
    args = ["predict", src, "--layout", "h36m17", "--up-axis", "z", "--out", out]
    code, _, stderr = run(args, capsys)
    assert code == EXIT_BAD_INPUT
    assert f"{src}, gone: fewer than two usable frames" in stderr
    assert not out.exists()


def test_refuses_to_overwrite_an_input_and_bad_options(tmp_path, capsys):
    src = write_skeletons(tmp_path / "s.npz", {"c": turning_skeleton(np.linspace(0, 90, 20))})
    before = src.read_bytes()
    code, _, stderr = run(["predict", src, "--layout", "h36m17", "--out", src], capsys)
    assert code == EXIT_BAD_INPUT and "overwrite" in stderr
    assert src.read_bytes() == before
    out = tmp_path / "p.csv"
    for bad in (["--joints", "elbow"], ["--up-axis", "w"], ["--fps", "0"], ["--layout", "coco"]):
        args = ["predict", src, "--layout", "h36m17", *bad, "--out", out]
        code, _, stderr = run(args, capsys)
        assert code == EXIT_BAD_INPUT, bad
        assert not out.exists()


def test_help_has_an_example_and_console_script_exit_code(tmp_path):
    exe = Path(sys.executable).parent / "turn-eval"
    help_text = subprocess.run([exe, "predict", "--help"], capture_output=True, text=True)
    assert help_text.returncode == 0
    lines = [line.strip() for line in help_text.stdout.splitlines()]
    example = lines.index("Example:")
    assert lines[example + 1].startswith("turn-eval predict poses.npz --layout h36m17")
    missing = subprocess.run(
        [exe, "predict", tmp_path / "nope.npz", "--layout", "h36m17", "--out", tmp_path / "p.csv"],
        capture_output=True,
        text=True,
    )
    assert missing.returncode == EXIT_BAD_INPUT
    assert "Traceback" not in missing.stderr
    assert missing.stderr.strip().endswith("no such file")


# CMU's own descriptions of the captures (DESCRIPTIONS.txt): name -> (description, direction).
CMU_TRIALS = {
    "16_18": ("walk, 90-degree left turn", "left"),
    "69_25": ("walk forward 90 degree left turn", "left"),
    "69_20": ("walk forward 90 degree right turn", "right"),
    "16_21": ("walk", None),
    "69_01": ("walk forward", None),
}


def test_real_cmu_captures_through_predict(cmu_dir, tmp_path, capsys):
    # Real motion capture as a pose estimator's output would arrive: the joints the BVH
    # reader names (pelvis, hips, knees, shoulders) placed in Human3.6M's 32-joint order,
    # the rest NaN, y up, one .npz key per trial.
    from turn_datasets.mocap.readers import read_source

    clips = {}
    for trial in CMU_TRIALS:
        seq = next(read_source(cmu_dir / f"{trial}.bvh", skip_first_frame=True))
        positions = np.full((seq.n_frames, H36M32.n_joints, 3), np.nan)
        for name, index in H36M32.joints.items():
            if name in seq.layout.joints:
                positions[:, index] = seq.positions[:, seq.layout.index(name)]
        clips[trial] = y_up_copy(positions)
    src = write_skeletons(tmp_path / "cmu.npz", clips)
    tables = {}
    for method in ("net", "paper"):
        out = tmp_path / f"{method}.csv"
        args = ["predict", src, "--layout", "h36m32", "--up-axis", "y", "--method", method]
        code, _, stderr = run([*args, "--fps", "120", "--out", out], capsys)
        assert code == 0, stderr
        tables[method] = pd.read_csv(out).set_index("clip_id")
    net, paper = tables["net"], tables["paper"]
    for trial, (description, direction) in CMU_TRIALS.items():
        angle = net.loc[trial, "angle_deg"]
        if direction is None:
            # A straight walk: the hips end facing as they started, up to the gait's sway.
            assert angle < 15.0, (trial, description, angle)
        else:
            # "90 degree" as CMU describes it; the first and last frames catch the pelvis at
            # some phase of its gait rotation, so allow 30° either side.
            assert 60.0 < angle < 120.0, (trial, description, angle)
            assert net.loc[trial, "direction"] == direction, (trial, description)
        # Equation 3 as printed adds |step| where the net rotation adds signed steps, so it
        # can never be smaller (triangle inequality); on a real walk the sway adds up.
        assert paper.loc[trial, "angle_deg"] >= angle - 1e-9
    # On the straight walk the printed equation reports a sizeable "turn" made of sway alone.
    assert paper.loc["16_21", "angle_deg"] > 40.0


def test_an_out_file_that_cannot_be_written_is_one_line_exit_2(tmp_path, capsys):
    src = write_skeletons(tmp_path / "s.npz", {"c": turning_skeleton(np.linspace(0, 90, 20))})
    out = src / "p.csv"  # under a file: its folder cannot be made
    code, stdout, stderr = run(["predict", src, "--layout", "h36m17", "--out", out], capsys)
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert stderr.strip().splitlines()[-1] == (
        f"turn-eval: error: {out}: cannot write the predictions: {src}: File exists"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.npz"]
