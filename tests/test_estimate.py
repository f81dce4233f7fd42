"""turn_eval.estimate without MediaPipe: joint mapping, time grid, VFR decoding, identity guard,
camera tilt, other estimators' files, and the CLI's refusal without the video extra."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_datasets
from conftest import run_turn_eval as run
from scipy.spatial.transform import Rotation
from test_predict import minus_y_up_copy, turning_skeleton

from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import frame_yaw_deg
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, to_z_up
from turn_datasets.synthetic.mocap import Segment, generate_sequence
from turn_eval.estimate import (
    IdentityGuardParams,
    blazepose_to_h36m17,
    identity_breaks,
    level,
    read_estimator_output,
    regular_grid,
    resample,
    skeletons_from_landmarks,
    tracks,
    write_estimate,
)
from turn_eval.estimate.blazepose import PoseParams
from turn_eval.estimate.video import open_video

# --- joints --------------------------------------------------------------------------------


def test_joint_mapping_by_hand():
    # landmark i sits at (i, 10 i, 100 i): every H17 joint's value says which landmarks made it
    lm = np.arange(33, dtype=float)[None, :, None] * np.array([1.0, 10.0, 100.0])
    out = blazepose_to_h36m17(lm)[0]
    j = H36M17.index
    assert out[j("pelvis"), 0] == 23.5  # mean of left_hip 23, right_hip 24
    assert out[j("right_hip"), 0] == 24 and out[j("left_hip"), 0] == 23
    assert out[j("right_foot"), 0] == 28 and out[j("left_foot"), 0] == 27  # ankles
    assert out[j("right_knee"), 0] == 26 and out[j("left_knee"), 0] == 25
    assert out[j("thorax"), 0] == 11.5
    assert out[j("spine"), 0] == (11 + 12 + 23 + 24) / 4
    assert out[j("neck"), 0] == 0  # the nose
    assert out[j("head"), 0] == 7.5  # mid-ears
    assert out[j("left_wrist"), 0] == 15 and out[j("right_wrist"), 0] == 16
    assert out[j("left_elbow"), 0] == 13 and out[j("right_shoulder"), 0] == 12
    assert np.array_equal(out[:, 1], 10 * out[:, 0]) and np.array_equal(out[:, 2], 100 * out[:, 0])
    nan = blazepose_to_h36m17(np.full((2, 33, 2), np.nan))
    assert nan.shape == (2, 17, 2) and np.isnan(nan).all()
    with pytest.raises(TurnbenchError, match="33"):
        blazepose_to_h36m17(np.zeros((3, 17, 3)))


def test_only_the_bundled_model_complexity_is_allowed():
    assert PoseParams().model_complexity == 1
    for complexity in (0, 2):
        with pytest.raises(TurnbenchError, match="download"):
            PoseParams(model_complexity=complexity)


# --- time grid -----------------------------------------------------------------------------


def test_constant_rate_is_left_as_it_is():
    t = np.arange(90) / 30.0
    grid = regular_grid(t, declared_fps_hz=30.0)
    assert grid.regular and grid.fps_hz == 30.0 and grid.n_frames == 90
    assert np.array_equal(grid.source_index, np.arange(90))
    assert grid.n_empty == grid.n_dropped == 0


def test_variable_rate_onto_the_nominal_grid():
    # 25 fps camera stamps (40 ms) with jitter, frames 3 and 4 lost, and a container that
    # declares 1000 fps (as WebM through OpenCV): the grid is 25 fps, 3 and 4 empty.
    k = np.array([0, 1, 2, 5, 6, 7, 8, 9])
    jitter = np.array([0.0, 0.004, -0.003, 0.002, 0.0, -0.004, 0.001, 0.0])
    grid = regular_grid(10.0 + k * 0.04 + jitter, declared_fps_hz=1000.0)
    assert grid.fps_hz == pytest.approx(25.0, rel=0.05)
    assert grid.n_frames == 10 and grid.start_s == 10.0
    assert grid.source_index.tolist() == [0, 1, 2, -1, -1, 3, 4, 5, 6, 7]
    assert not grid.regular and grid.n_empty == 2 and grid.n_dropped == 0
    values = np.arange(8, dtype=float)[:, None]
    out = resample(values, grid)
    assert np.isnan(out[[3, 4]]).all() and out[5, 0] == 3.0
    # --fps wins over both
    assert regular_grid(k * 0.04, fps_hz=50.0).n_frames == 19


def test_two_frames_on_one_point_keep_the_nearer():
    grid = regular_grid(np.array([0.0, 0.1, 0.19, 0.205, 0.3]), fps_hz=10.0)
    assert grid.source_index.tolist() == [0, 1, 3, 4]  # 0.205 is nearer to 0.2 than 0.19
    assert grid.n_dropped == 1 and not grid.regular


def test_bad_timestamps_are_refused():
    with pytest.raises(TurnbenchError, match="increase"):
        regular_grid(np.array([0.0, 0.1, 0.1]))
    with pytest.raises(TurnbenchError, match="no decodable frame"):
        regular_grid(np.array([]))
    with pytest.raises(TurnbenchError, match="--fps"):
        regular_grid(np.array([0.5]))


def _write_numbered_video(path: Path, n: int, fps: int = 30) -> None:
    """Frame k is uniformly grey at level 4 k (read back to tell frames apart)."""
    writer = imageio_ffmpeg.write_frames(
        str(path), (64, 48), fps=fps, codec="libx264", pix_fmt_out="yuv420p",
        output_params=["-crf", "0", "-g", "1"],
    )  # fmt: skip
    writer.send(None)
    for k in range(n):
        writer.send(np.full((48, 64, 3), 4 * k, dtype=np.uint8))
    writer.close()


def make_vfr_video(tmp_path: Path, dropped=(5, 6, 17), n: int = 40) -> Path:
    """A variable-frame-rate video: a 30 fps one with frames removed, the rest keeping their
    times (ffmpeg's select with -fps_mode passthrough), as a phone's dropped frames look."""
    cfr = tmp_path / "cfr.mp4"
    _write_numbered_video(cfr, n)
    vfr = tmp_path / "vfr.mkv"
    keep = "*".join(f"not(eq(n\\,{k}))" for k in dropped)
    subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-y", "-i", str(cfr),
         "-vf", f"select={keep}", "-fps_mode", "passthrough", "-c:v", "libx264",
         "-crf", "0", "-g", "1", str(vfr)],
        check=True,
    )  # fmt: skip
    return vfr


def test_decoding_keeps_each_frames_own_time_and_the_grid_puts_it_back(tmp_path):
    vfr = make_vfr_video(tmp_path)
    stream = open_video(vfr)
    frames, pts = zip(*((int(round(f.mean())), t) for f, t in stream), strict=True)
    assert len(frames) == 37  # no frame duplicated to fill the gaps
    grid = regular_grid(np.array(pts), declared_fps_hz=stream.declared_fps_hz)
    assert grid.fps_hz == pytest.approx(30.0, rel=1e-3)
    assert grid.n_frames == 40 and grid.n_empty == 3 and not grid.regular
    level_on_grid = resample(np.array(frames, dtype=float), grid)
    assert np.flatnonzero(np.isnan(level_on_grid)).tolist() == [5, 6, 17]
    seen = np.flatnonzero(np.isfinite(level_on_grid))
    # each grid slot holds the frame that was written there (grey level 4 k)
    assert np.allclose(level_on_grid[seen], 4 * seen, atol=1.0)


def test_decoding_a_broken_file_is_one_error(tmp_path):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video at all" * 10)
    with pytest.raises(TurnbenchError, match="cannot decode"):
        list(open_video(bad))


# --- identity guard ------------------------------------------------------------------------


def trunk_landmarks(centres_px: np.ndarray, torso_px: np.ndarray, size=(1000, 500)) -> np.ndarray:
    """(frames, 33, 2) normalised landmarks with only the trunk set: shoulders torso/2 above
    the centre, hips torso/2 below, 20 px apart sideways."""
    lm = np.full((len(centres_px), 33, 2), np.nan)
    for idx, dy, dx in ((11, -0.5, 10), (12, -0.5, -10), (23, 0.5, 10), (24, 0.5, -10)):
        lm[:, idx, 0] = centres_px[:, 0] + dx
        lm[:, idx, 1] = centres_px[:, 1] + dy * torso_px
    lm[..., 0] /= size[0]
    lm[..., 1] /= size[1]
    # the other landmarks: anywhere finite (the guard reads only the trunk)
    rest = [i for i in range(33) if i not in (11, 12, 23, 24)]
    lm[:, rest] = lm[:, [11]]
    return lm


def test_guard_is_quiet_on_walking_and_fires_on_a_jump_and_a_size_change():
    t = np.arange(120) / 30.0
    # a 100 px trunk walking 300 px/s (3 trunks/s) to the right
    centres = np.stack([100 + 300 * t, np.full_like(t, 250)], axis=1)
    torso = np.full_like(t, 100.0)
    lm = trunk_landmarks(centres, torso)
    assert identity_breaks(lm, t, width_px=1000, height_px=500) == []
    # frame 60 onward: someone 400 px further on (4 trunks in 1/30 s: 1.5 + 10/30 allowed)
    jumped = centres.copy()
    jumped[60:, 0] += 400
    breaks = identity_breaks(trunk_landmarks(jumped, torso), t, width_px=1000, height_px=500)
    assert [b.frame for b in breaks] == [60]
    assert breaks[0].time_s == pytest.approx(2.0)
    assert breaks[0].jump_torso == pytest.approx(np.hypot(400 + 10, 0) / 100, abs=1e-6)
    # frame 90 onward: a body 2.5 times the size at the same place (a nearer person)
    bigger = torso.copy()
    bigger[90:] = 250.0
    breaks = identity_breaks(trunk_landmarks(centres, bigger), t, width_px=1000, height_px=500)
    assert [b.frame for b in breaks] == [90] and breaks[0].scale_ratio == pytest.approx(2.5)


def test_guard_allows_for_time_across_undetected_frames():
    t = np.arange(60) / 30.0
    centres = np.stack([100 + 300 * t, np.full_like(t, 250)], axis=1)
    lm = trunk_landmarks(centres, np.full_like(t, 100.0))
    lm[10:40] = np.nan  # one second unseen: 3 trunks walked, within 1.5 + 10 * 1.03
    assert identity_breaks(lm, t, width_px=1000, height_px=500) == []
    strict = IdentityGuardParams(max_speed_torso_per_s=1.0)
    assert [
        b.frame for b in identity_breaks(lm, t, width_px=1000, height_px=500, params=strict)
    ] == [40]


def test_tracks_split_at_breaks_and_span_detections():
    detected = np.zeros(20, dtype=bool)
    detected[[2, 3, 4, 7, 8, 12, 13, 14]] = True
    t = np.arange(20) / 10.0
    centres = np.stack([np.full(20, 100.0), np.full(20, 100.0)], axis=1)
    centres[7:, 0] = 600.0
    centres[12:, 0] = 100.0
    lm = trunk_landmarks(centres, np.full(20, 50.0))
    lm[~detected] = np.nan
    breaks = identity_breaks(lm, t, width_px=1000, height_px=500)
    assert [b.frame for b in breaks] == [7, 12]
    assert tracks(detected, breaks) == [(2, 5), (7, 9), (12, 15)]
    assert tracks(np.zeros(5, dtype=bool), []) == []


# --- camera tilt ---------------------------------------------------------------------------


def camera_frame_walk(pitch_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """A synthetic walk with a 120° turn, as MediaPipe would give it from a camera pitched
    down by ``pitch_deg``: 17 joints, metres, origin between the hips, x right, y down, z away.
    Returns (positions, the true yaw of the hip vector in degrees)."""
    seq = generate_sequence(
        seed=3, segments=[Segment.walk(2.0), Segment.walking_turn(120.0, 2.0), Segment.walk(2.0)],
        noise_mm=0.0, fps_hz=30.0, start_heading_deg=20.0,
    )  # fmt: skip
    z_up = seq.positions[:, list(H36M17_FROM_32)] / 1000.0
    hips = (z_up[:, H36M17.index("left_hip")] + z_up[:, H36M17.index("right_hip")]) / 2
    cam = minus_y_up_copy(z_up - hips[:, None])  # z-up world -> camera axes, as MediaPipe's
    # pitching the camera down by theta turns the scene about the camera's x axis by -theta
    pitched = Rotation.from_euler("x", -pitch_deg, degrees=True).apply(cam.reshape(-1, 3))
    return pitched.reshape(cam.shape), seq.true_yaw_deg


def _yaw_error_deg(camera_positions: np.ndarray, true_yaw: np.ndarray) -> float:
    yaw = frame_yaw_deg(to_z_up(camera_positions, "-y"), H36M17)
    err = (yaw - true_yaw) - (yaw[0] - true_yaw[0])
    return float(np.max(np.abs(err)))


def test_levelling_removes_a_synthetic_camera_tilt():
    tilted, true_yaw = camera_frame_walk(25.0)
    # uncorrected, the 25° pitch leaks into the yaw (the docstring's formula: several degrees)
    assert _yaw_error_deg(tilted, true_yaw) > 3.0
    levelled, info = level(tilted, up_axis="-y")
    assert info.tilt_deg == pytest.approx(25.0, abs=3.0)
    assert info.upright_only and info.n_frames_used >= 10
    assert _yaw_error_deg(levelled, true_yaw) < 1.0
    # an untilted camera is left (nearly) alone
    straight, _ = camera_frame_walk(0.0)
    _, info0 = level(straight, up_axis="-y")
    assert info0.tilt_deg < 3.0
    # NaN frames stay NaN
    tilted[5] = np.nan
    assert np.isnan(level(tilted, up_axis="-y")[0][5]).all()


# --- the steps after decoding, and the files -----------------------------------------------


def _landmarks_walking(n: int, jump_at: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    world_h17 = minus_y_up_copy(turning_skeleton(np.linspace(0, 90, n)))
    world33 = np.zeros((n, 33, 3))
    for name, sources in (("left_hip", (23,)), ("right_hip", (24,)), ("left_knee", (25,)),
                          ("right_knee", (26,)), ("left_foot", (27,)), ("right_foot", (28,)),
                          ("left_shoulder", (11,)), ("right_shoulder", (12,))):  # fmt: skip
        world33[:, sources[0]] = world_h17[:, H36M17.index(name)]
    t = np.arange(n) / 30.0
    centres = np.stack([200 + 100 * t, np.full(n, 250.0)], axis=1)
    if jump_at is not None:
        centres[jump_at:, 0] += 500
    return world33, trunk_landmarks(centres, np.full(n, 100.0))


def test_skeletons_from_landmarks_tracks_manifest_and_bytes(tmp_path):
    world33, image33 = _landmarks_walking(60, jump_at=40)
    world33[[0, 1]] = np.nan
    image33[[0, 1]] = np.nan
    pts = np.arange(60) / 30.0
    result = skeletons_from_landmarks(
        world33, image33, pts, session="clinic_01", width_px=1000, height_px=500,
        declared_fps_hz=30.0,
    )  # fmt: skip
    assert sorted(result.arrays) == ["clinic_01.t1", "clinic_01.t2"]
    first, second = result.arrays["clinic_01.t1"], result.arrays["clinic_01.t2"]
    assert first.shape == second.shape == (60, 17, 3) and first.dtype == np.float32
    assert (
        np.isnan(first[:2]).all() and np.isfinite(first[2:40]).all() and np.isnan(first[40:]).all()
    )
    assert np.isnan(second[:40]).all() and np.isfinite(second[40:]).all()
    m = result.manifest
    assert m["detection"] == {"n_detected": 58, "rate": round(58 / 60, 6)}
    assert [b["frame"] for b in m["identity_breaks"]] == [40]
    assert m["time"]["regular"] and m["axes"]["up_axis"] == "-y" and m["axes"]["units"] == "m"
    one = skeletons_from_landmarks(
        world33[:40], image33[:40], pts[:40], session="s", width_px=1000, height_px=500
    )
    assert list(one.arrays) == ["s"]
    a = write_estimate(result, tmp_path / "a" / "clinic_01.npz")
    b = write_estimate(result, tmp_path / "b" / "clinic_01.npz")
    assert a[1].name == "clinic_01.manifest.json"
    assert a[0].read_bytes() == b[0].read_bytes() and a[1].read_bytes() == b[1].read_bytes()
    assert json.loads(a[1].read_text())["tracks"][1]["start_frame"] == 40
    # A phone file whose first frame is shown at 10 s: the break and the second track start
    # at frame 40, 40 / 30 s from the first frame, on one clock (time.start_s says 10 s).
    late = skeletons_from_landmarks(
        world33, image33, pts + 10.0, session="c", width_px=1000, height_px=500,
        declared_fps_hz=30.0,
    ).manifest  # fmt: skip
    assert late["time"]["start_s"] == pytest.approx(10.0)
    assert late["identity_breaks"][0]["time_s"] == pytest.approx(40 / 30, abs=1e-6)
    assert late["tracks"][1]["start_s"] == pytest.approx(40 / 30, abs=1e-6)


def test_estimate_files_feed_predict_and_mine_with_the_documented_options(tmp_path, capsys):
    world33, image33 = _landmarks_walking(90)
    result = skeletons_from_landmarks(
        world33, image33, np.arange(90) / 30.0, session="turn90", width_px=1000, height_px=500,
        params=None,
    )  # fmt: skip
    npz, _ = write_estimate(result, tmp_path / "turn90.npz")
    out = tmp_path / "pred.csv"
    code, _, err = run(
        ["predict", npz, "--layout", "h36m17", "--up-axis", "-y", "--out", out], capsys
    )
    assert code == 0, err
    pred = pd.read_csv(out)
    assert pred["clip_id"].tolist() == ["turn90"]
    assert pred["angle_deg"].iloc[0] == pytest.approx(90.0, abs=0.5)
    assert pred["direction"].iloc[0] == "left"
    code, _, err = run(["predict", npz, "--from", "turnbench", "--out", out], capsys)
    assert code == 0, err
    assert pd.read_csv(out)["angle_deg"].iloc[0] == pytest.approx(90.0, abs=0.5)
    index = tmp_path / "clips.csv"
    code, _, err = run_turn_datasets(["h36m", "mine", npz, "--layout", "h36m17", "--up-axis", "-y", "--fps", "30",
         "--units", "m", "--out", index],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    clips = pd.read_csv(index)
    assert len(clips) == 1 and clips["angle_deg"].iloc[0] == pytest.approx(90.0, abs=10.0)


# --- other estimators' files ---------------------------------------------------------------


def _turn_camera(angle_deg: float, n: int = 60) -> np.ndarray:
    return minus_y_up_copy(turning_skeleton(np.linspace(0.0, angle_deg, n)))


def test_each_named_format_reads_its_own_layout(tmp_path, capsys):
    strided = tmp_path / "walk_a" / "output_3D" / "output_keypoints_3d.npz"
    strided.parent.mkdir(parents=True)
    np.savez_compressed(strided, reconstruction=turning_skeleton(np.linspace(0, 90, 60))[None])
    videopose = tmp_path / "walk_b.npy"
    np.save(videopose, _turn_camera(-135.0).astype(np.float32))
    motionbert = tmp_path / "walk_c" / "X3D.npy"
    motionbert.parent.mkdir()
    np.save(motionbert, _turn_camera(180.0))
    spec, arrays = read_estimator_output(strided, "strided-transformer")
    assert spec.up_axis == "z" and [k for k, _ in arrays] == ["walk_a"]
    assert arrays[0][1].shape == (60, 17, 3) and arrays[0][1].dtype == np.float64
    assert read_estimator_output(motionbert, "motionbert")[1][0][0] == "walk_c"
    expected = {"walk_a": (90.0, "left"), "walk_b": (135.0, "right"), "walk_c": (180.0, "left")}
    for path, fmt in (
        (strided, "strided-transformer"),
        (videopose, "videopose3d"),
        (motionbert, "motionbert"),
    ):
        out = tmp_path / f"{fmt}.csv"
        code, _, err = run(["predict", path, "--from", fmt, "--out", out], capsys)
        assert code == 0, err
        row = pd.read_csv(out).iloc[0]
        angle, direction = expected[row["clip_id"]]
        assert row["angle_deg"] == pytest.approx(angle, abs=1e-4) and row["direction"] == direction


def test_two_d_files_and_alphapose_are_refused_with_the_lifter_advice(tmp_path, capsys):
    alphapose = tmp_path / "alphapose-results.json"
    alphapose.write_text(json.dumps([{"image_id": "0.jpg", "keypoints": [0.0] * 51}]))
    keypoints2d = tmp_path / "input_2D" / "keypoints.npz"
    keypoints2d.parent.mkdir()
    np.savez_compressed(keypoints2d, reconstruction=np.zeros((1, 50, 17, 2)))
    detectron = tmp_path / "clip.mp4.npz"
    np.savez_compressed(detectron, boxes=np.zeros(3), keypoints=np.zeros(3))
    for path, fmt in ((alphapose, "alphapose"), (alphapose, "arrays"), (keypoints2d, "strided-transformer"),
                      (detectron, "videopose3d")):  # fmt: skip
        code, out, err = run(["predict", path, "--from", fmt, "--out", tmp_path / "p.csv"], capsys)
        assert code == EXIT_BAD_INPUT and out == ""
        last = err.strip().splitlines()[-1]  # after the progress label: one error line
        assert last.startswith("turn-eval: error:") and "Traceback" not in err
        assert "2D" in last and "3D lifter" in last and path.name in last, err
    assert not (tmp_path / "p.csv").exists()
    wrong = tmp_path / "walk.npy"
    np.save(wrong, np.zeros((10, 32, 3)))
    code, _, err = run(
        ["predict", wrong, "--from", "motionbert", "--out", tmp_path / "p.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT and "(frames, 17, 3)" in err


def test_damaged_estimator_files_are_one_line_each(tmp_path, capsys):
    # A truncated zip, a damaged deflate stream and a text file named .npz: zipfile and zlib
    # raise BadZipFile and zlib.error, which went past the --from readers as a traceback.
    good = tmp_path / "good.npz"
    np.savez_compressed(good, reconstruction=np.random.default_rng(0).random((1, 40, 17, 3)))
    data = good.read_bytes()
    truncated = tmp_path / "truncated" / "clip.npz"
    damaged = tmp_path / "damaged" / "clip.npz"
    text = tmp_path / "text" / "clip.npz"
    for path in (truncated, damaged, text):
        path.parent.mkdir()
    truncated.write_bytes(data[: len(data) // 2])
    middle = len(data) // 3  # inside the member's compressed bytes
    damaged.write_bytes(data[:middle] + bytes(b ^ 0xFF for b in data[middle : middle + 64])
                        + data[middle + 64 :])  # fmt: skip
    text.write_text("not an archive\n")
    for path in (truncated, damaged, text):
        for args in (
            ["predict", path, "--from", "videopose3d", "--out", tmp_path / "p.csv"],
            ["detect", path.parent, "--from", "videopose3d", "--fps", "30",
             "--out", tmp_path / "d.csv"],
        ):  # fmt: skip
            code, out, err = run(args, capsys)
            assert code == EXIT_BAD_INPUT and out == "" and "Traceback" not in err, err
            last = err.strip().splitlines()[-1]
            assert last.startswith("turn-eval: error:") and str(path) in last, err
            assert "cannot read" in last or "cannot open" in last, err
    assert not (tmp_path / "p.csv").exists() and not (tmp_path / "d.csv").exists()
    # complex numbers are not positions (their imaginary part was dropped without a word)
    complex_npy = tmp_path / "X3D.npy"
    np.save(complex_npy, np.zeros((10, 17, 3), dtype=np.complex128))
    code, _, err = run(
        ["predict", complex_npy, "--from", "motionbert", "--out", tmp_path / "p.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT and "dtype complex128, expected numbers" in err


# --- the CLI without the extra -------------------------------------------------------------


def test_estimate_without_mediapipe_is_one_helpful_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "mediapipe", None)  # import fails, as without the extra
    video = tmp_path / "v.mp4"
    _write_numbered_video(video, 3)
    code, out, err = run(["estimate", video, "--out", tmp_path / "v.npz"], capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    assert err.count("\n") == 1 and "turnbench[video]" in err and "mediapipe==0.10.21" in err
    assert not (tmp_path / "v.npz").exists()


def test_estimate_help_has_an_example(capsys):
    code, out, _ = run(["estimate", "--help"], capsys)
    assert code == 0 and "Example:" in out and "turn-eval estimate" in out


def test_estimate_option_mistakes_are_one_line_before_any_work(tmp_path, capsys):
    a, b = tmp_path / "a" / "walk.mp4", tmp_path / "b" / "walk.mp4"
    for v in (a, b):
        v.parent.mkdir()
        _write_numbered_video(v, 2)
    cases = [
        ([a], "exactly one of --out"),
        ([a, "--out", tmp_path / "x.npz", "--out-dir", tmp_path], "exactly one of --out"),
        ([a, b, "--out", tmp_path / "x.npz"], "--out takes one video"),
        ([a, "--out", tmp_path / "x.csv"], "must end in .npz"),
        ([a, b, "--out-dir", tmp_path / "o"], "both write walk.npz"),
        ([tmp_path / "missing.mp4", "--out-dir", tmp_path / "o"], "no such video file"),
        ([a, "--out-dir", tmp_path / "o", "--fps", "nan"], "--fps"),
    ]
    for args, message in cases:
        code, out, err = run(["estimate", *args], capsys)
        assert code == EXIT_BAD_INPUT and out == "" and err.count("\n") == 1, err
        assert message in err, err
    assert not (tmp_path / "o").exists() and not (tmp_path / "x.npz").exists()


# --- detect reads the same files, through the same dispatch --------------------------------


def test_detect_reads_estimate_and_other_estimators_files_by_name(tmp_path, capsys):
    from test_detect import WALK_TURN_WALK, stream

    camera = minus_y_up_copy(stream(WALK_TURN_WALK))  # one planted 90° left turn at 8-10 s
    pelvis = (camera[:, H36M17.index("left_hip")] + camera[:, H36M17.index("right_hip")]) / 2
    # turn-eval estimate's file (root-relative, camera axes, key = the session's stem)
    (tmp_path / "est").mkdir()
    est_npz = tmp_path / "est" / "home01.npz"
    np.savez(est_npz, **{"home01": (camera - pelvis[:, None]).astype(np.float32)})
    (tmp_path / "mb" / "home02").mkdir(parents=True)
    np.save(tmp_path / "mb" / "home02" / "X3D.npy", camera)
    found = {}
    own_axis = {"turnbench": "-y", "motionbert": "-y"}  # each format's documented axes
    for source, fmt in ((tmp_path / "est", "turnbench"), (tmp_path / "mb", "motionbert")):
        out = tmp_path / f"{fmt}.csv"
        code, _, err = run(["detect", source, "--from", fmt, "--fps", "30", "--out", out], capsys)
        assert code == 0, err
        found[fmt] = pd.read_csv(out)
        manifest = json.loads(out.with_name(f"{fmt}.manifest.json").read_text())
        assert manifest["reading"]["from"] == fmt
        assert (
            manifest["reading"]["up_axis"] == own_axis[fmt]
        )  # the axis the streams were turned by
    assert found["turnbench"][["session", "subject"]].values.tolist() == [["home01", "home01"]]
    assert found["motionbert"][["session", "subject"]].values.tolist() == [["home02", "home02"]]
    for table in found.values():
        assert table["direction"].tolist() == ["left"]
        assert abs(table["angle_deg"].iloc[0] - 90.0) < 6.0
    # generic arrays still need the layout (their axis is inferred); a JSON is AlphaPose's 2D
    code, _, err = run(
        ["detect", tmp_path / "est", "--fps", "30", "--out", tmp_path / "x.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT and "generic arrays need --layout" in err
    alphapose = tmp_path / "alphapose-results.json"
    alphapose.write_text("[]")
    code, _, err = run(["detect", alphapose, "--fps", "30", "--out", tmp_path / "x.csv"], capsys)
    assert code == EXIT_BAD_INPUT and "3D lifter" in err and not (tmp_path / "x.csv").exists()


# --- the parameters' options (without MediaPipe: a stand-in pose model) --------------------


class _NobodyPose:
    """BlazePose's interface, finding nobody; records the settings it was built with."""

    built: list = []
    version = "stand-in"

    def __init__(self, params) -> None:
        type(self).built.append(params)

    def __enter__(self):
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def process(self, rgb):
        return np.full((33, 3), np.nan), np.full((33, 2), np.nan), np.full(33, np.nan)


@pytest.fixture()
def without_mediapipe(monkeypatch) -> list:
    import turn_eval.cli.estimate as estimate_cli
    import turn_eval.estimate.pipeline as pipeline

    monkeypatch.setattr(estimate_cli, "load_mediapipe", lambda: None)
    monkeypatch.setattr(pipeline, "BlazePose", _NobodyPose)
    monkeypatch.setattr(_NobodyPose, "built", [])
    return _NobodyPose.built


def test_estimate_help_lists_the_parameters_with_units_and_defaults(capsys):
    code, out, _ = run(["estimate", "--help"], capsys)
    assert code == 0
    text = " ".join(out.split())  # click wraps the help
    for option, unit, default in (
        ("--min-detection-confidence FLOAT", "0 to 1", "[default: 0.5]"),
        ("--min-tracking-confidence FLOAT", "0 to 1", "[default: 0.5]"),
        ("--min-jump-torso FLOAT", "trunk lengths", "[default: 1.5]"),
        ("--max-speed-torso-per-s FLOAT", "trunk lengths per second", "[default: 10.0]"),
        ("--max-scale-ratio FLOAT", "factor", "[default: 2.0]"),
        ("--min-knee-angle-deg FLOAT", "degrees", "[default: 150.0]"),
        ("--min-upright-frames INTEGER", "frames", "[default: 10]"),
    ):
        assert option in text, option
        help_text = text.split(option, 1)[1].split(" --", 1)[0]
        assert unit in help_text.lower() and help_text.endswith(default), (option, help_text)


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--min-detection-confidence", "1.5"),
        ("--min-tracking-confidence", "-0.1"),
        ("--max-scale-ratio", "1"),  # a ratio above 1 (open bound)
        ("--min-knee-angle-deg", "181"),
        ("--max-speed-torso-per-s", "1e6"),  # a unit mistake (trunk lengths per second)
        ("--min-upright-frames", "0"),
        ("--min-jump-torso", "nan"),
    ],
)
def test_estimate_parameter_bounds_are_one_line_naming_the_option(
    tmp_path, capsys, without_mediapipe, option, value
):
    video = tmp_path / "v.mp4"
    _write_numbered_video(video, 2)
    code, out, err = run(["estimate", video, "--out-dir", tmp_path / "o", option, value], capsys)
    assert code == EXIT_BAD_INPUT and out == "" and err.count("\n") == 1, err
    assert f"Invalid value for '{option}': {value}" in err or (
        value == "nan" and f"Invalid value for '{option}': must be a number" in err
    ), err
    assert not (tmp_path / "o").exists() and without_mediapipe == []


def test_estimate_parameters_are_recorded_and_a_change_defeats_resume(
    tmp_path, capsys, without_mediapipe
):
    video = tmp_path / "v.mp4"
    _write_numbered_video(video, 4)
    out = tmp_path / "o"

    def estimate(*extra) -> tuple[str, dict, dict]:
        code, _, err = run(["estimate", video, "--out-dir", out, *extra], capsys)
        assert code == 0, err
        manifest = json.loads((out / "estimate.manifest.json").read_text())
        video_manifest = json.loads((out / "v.manifest.json").read_text())
        return manifest["videos"][0]["status"], manifest["parameters"], video_manifest

    status, params, _ = estimate()
    assert status == "done"
    assert params["pose"]["min_detection_confidence"] == 0.5
    assert params["levelling"]["min_upright_frames"] == 10
    assert estimate("--resume")[0] == "resumed"
    assert len(without_mediapipe) == 1  # the resumed run built no pose model

    status, params, per_video = estimate("--resume", "--min-detection-confidence", "0.7")
    assert status == "done"
    assert params["pose"]["min_detection_confidence"] == 0.7
    assert per_video["parameters"]["pose"]["min_detection_confidence"] == 0.7
    assert without_mediapipe[-1].min_detection_confidence == 0.7  # the model was told
    assert estimate("--resume", "--min-detection-confidence", "0.7")[0] == "resumed"

    for option, value, block, name in (
        ("--max-speed-torso-per-s", "4", "guard", "max_speed_torso_per_s"),
        ("--min-upright-frames", "5", "levelling", "min_upright_frames"),
    ):
        status, params, per_video = estimate(
            "--resume", "--min-detection-confidence", "0.7", option, value
        )
        assert status == "done", option
        assert params[block][name] == float(value) == per_video["parameters"][block][name]
