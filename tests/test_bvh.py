"""BVH: the rotation convention checked on hand-made files, the real CMU captures, bad files."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from turn_datasets import geometry
from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap import bvh

CMU_FILES = ("16_18", "16_21", "69_01", "69_20", "69_25")

# A root with a child one unit up (+y) and an End Site one unit further up. The root rotates
# Z, Y, X (CMU's order); the child declares X, Y, Z, so each joint's own order is exercised.
CONVENTION_BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Child
  {
    OFFSET 0 1 0
    CHANNELS 3 Xrotation Yrotation Zrotation
    End Site
    {
      OFFSET 0 1 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.02
0 0 0 0 0 0 0 0 0
10 20 30 90 0 90 90 0 90
"""


def _write(tmp_path: Path, text: str, name: str = "t.bvh") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_rotation_order_is_intrinsic_in_declared_order(tmp_path: Path) -> None:
    motion = bvh.parse_bvh(_write(tmp_path, CONVENTION_BVH))
    assert motion.names == ["Hips", "Child", "Child_end"]
    p = bvh.forward_kinematics(motion)  # y up, as stored
    # Frame 0: no rotation: the child at its offset, the end site one more unit up.
    np.testing.assert_allclose(p[0], [[0, 0, 0], [0, 1, 0], [0, 2, 0]], atol=1e-12)
    # Frame 1, by hand with Rz(90): (x, y, z) -> (-y, x, z) and Rx(90): (x, y, z) -> (x, -z, y).
    # Root at (10, 20, 30); R_root = Rz(90) Rx(90) (intrinsic Z then X).
    # Child = root + Rz(90) Rx(90) (0, 1, 0) = root + Rz(90) (0, 0, 1) = (10, 20, 31).
    # (The other order, Rx(90) Rz(90) (0, 1, 0) = (-1, 0, 0), would put it at (9, 20, 30).)
    # Child's own R = Rx(90) Rz(90) (declared X, Y, Z): R (0, 1, 0) = Rx(90) (-1, 0, 0) = (-1, 0, 0);
    # End = child + R_root (-1, 0, 0) = child + Rz(90) (-1, 0, 0) = child + (0, -1, 0) = (10, 19, 31).
    np.testing.assert_allclose(p[1], [[10, 20, 30], [10, 20, 31], [10, 19, 31]], atol=1e-9)


def test_position_channels_replace_the_offset(tmp_path: Path) -> None:
    text = CONVENTION_BVH.replace("OFFSET 0 0 0", "OFFSET 5 5 5", 1)
    p = bvh.forward_kinematics(bvh.parse_bvh(_write(tmp_path, text)))
    np.testing.assert_allclose(p[1, 0], [10, 20, 30])


def _hips_bvh(yaw_deg: np.ndarray, *, left: str = "LeftUpLeg", right: str = "RightUpLeg") -> str:
    """A pelvis with left hip at +x, right hip at -x (the T-pose faces +z), rotating about y."""
    lines = [
        "HIERARCHY",
        "ROOT Hips",
        "{",
        "  OFFSET 0 0 0",
        "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation",
    ]
    for name, x in ((left, 1.0), (right, -1.0)):
        lines += [
            f"  JOINT {name}",
            "  {",
            f"    OFFSET {x} 0 0",
            "    CHANNELS 3 Zrotation Yrotation Xrotation",
            "    End Site",
            "    {",
            "      OFFSET 0 -8 0",
            "    }",
            "  }",
        ]
    lines += ["}", "MOTION", f"Frames: {len(yaw_deg)}", "Frame Time: .0083333"]
    for k, yaw in enumerate(yaw_deg):
        lines.append(f"{0.01 * k} 9 0 0 {yaw} 0 0 0 0 0 0 0")
    return "\r\n".join(lines) + "\r\n"  # CRLF, as CMU's files


def test_positive_y_rotation_is_a_left_turn_in_z_up(tmp_path: Path) -> None:
    yaw = np.linspace(0.0, 90.0, 31)
    seq = bvh.read_bvh(_write(tmp_path, _hips_bvh(yaw)))
    assert seq.fps == 120.0  # 1 / .0083333 = 120.0005, snapped
    # Facing +z in y up is facing -y in z up ((x, y, z) -> (x, -z, y)); left hip at +x.
    lh = seq.layout.index("left_hip")
    np.testing.assert_allclose(seq.positions[0, lh], [1, 0, 9], atol=1e-12)
    # Ry(90) (1, 0, 0) = (0, 0, -1) in y up -> (0, 1, 0) in z up (plus the root at height 9):
    # the left hip swung from +x to +y, counter-clockwise seen from above: a left turn.
    np.testing.assert_allclose(seq.positions[-1, lh], [0.3, 1, 9], atol=1e-9)
    turn = geometry.turning_angle(seq.positions, seq.layout, method="net")
    assert turn.net_deg == pytest.approx(90.0, abs=1e-9)
    assert turn.direction == "left"


def test_joint_map_overrides_cmu_names(tmp_path: Path) -> None:
    path = _write(tmp_path, _hips_bvh(np.zeros(3), left="LHip", right="RHip"))
    with pytest.raises(TurnbenchError) as exc:
        bvh.read_bvh(path)
    assert "LeftUpLeg" in str(exc.value) and "t.bvh" in str(exc.value)
    seq = bvh.read_bvh(path, joint_map=bvh.parse_joint_map("left_hip=LHip, right_hip=RHip"))
    assert seq.layout.index("left_hip") == bvh.parse_bvh(path).names.index("LHip")
    with pytest.raises(TurnbenchError, match="Nope"):
        bvh.read_bvh(path, joint_map={"left_hip": "LHip", "right_hip": "RHip", "left_knee": "Nope"})
    with pytest.raises(TurnbenchError, match="not ours"):
        bvh.read_bvh(path, joint_map={"hip_left": "LHip"})
    with pytest.raises(TurnbenchError, match="our_name=BvhJointName"):
        bvh.parse_joint_map("left_hip:LHip")


@pytest.mark.parametrize(
    ("frame_time", "fps"), [(".0083333", 120.0), ("0.02", 50.0), ("0.0333667", 1 / 0.0333667)]
)
def test_fps_from_frame_time(frame_time: str, fps: float) -> None:
    assert bvh.fps_from_frame_time(float(frame_time)) == pytest.approx(fps, rel=1e-12)


# --- the real CMU captures ----------------------------------------------------------------


def _header_frames(path: Path) -> int:
    match = re.search(r"Frames:\s*(\d+)", path.read_text(encoding="latin-1"))
    assert match
    return int(match.group(1))


@pytest.mark.parametrize("name", CMU_FILES)
def test_cmu_files_parse_with_header_frame_count(cmu_dir: Path, name: str) -> None:
    path = cmu_dir / f"{name}.bvh"
    motion = bvh.parse_bvh(path)
    frames = _header_frames(path)
    assert motion.n_frames == frames
    # SOURCE.md: 31 joints and 96 channels (Hips 6 + 30 x 3), 120 fps
    assert sum(not j.is_end_site for j in motion.joints) == 31
    assert motion.motion.shape == (frames, 96)
    assert motion.fps == 120.0
    # Frame 0 is the T-pose the conversion added: the root neither turned nor tilted.
    np.testing.assert_array_equal(motion.motion[0, 3:6], 0.0)
    seq = bvh.read_bvh(path, skip_first_frame=False)
    n_end_sites = path.read_text(encoding="latin-1").count("End Site")  # 7 in CMU's files
    assert seq.positions.shape == (frames, 31 + n_end_sites, 3)
    assert bvh.read_bvh(path, skip_first_frame=True).positions.shape[0] == frames - 1
    # by default the T-pose is recognised as a rest pose and dropped
    assert bvh.first_frame_is_rest_pose(motion)
    assert bvh.read_bvh(path).positions.shape[0] == frames - 1


@pytest.mark.parametrize("name", CMU_FILES)
def test_cmu_forward_kinematics_keeps_bone_lengths(cmu_dir: Path, name: str) -> None:
    """FK is rigid: each bone keeps its OFFSET's length in every frame (a check independent
    of the rotation convention), and z up puts the hips about 17.8 units above y = 0's floor."""
    motion = bvh.parse_bvh(cmu_dir / f"{name}.bvh")
    p = bvh.forward_kinematics(motion)
    for i, joint in enumerate(motion.joints):
        if joint.parent < 0:
            continue
        length = np.linalg.norm(p[:, i] - p[:, joint.parent], axis=1)
        np.testing.assert_allclose(length, np.linalg.norm(joint.offset), atol=1e-9)
    seq = bvh.read_bvh(cmu_dir / f"{name}.bvh", skip_first_frame=False)
    # root height: Yposition channel in the file, z after conversion
    np.testing.assert_allclose(seq.positions[:, 0, 2], motion.motion[:, 1])


# CMU's descriptions (DESCRIPTIONS.txt / SOURCE.md): 69_20 "90 degree right turn", 69_25 and
# 16_18 "90-degree left turn", 16_21 and 69_01 straight walks. Left = counter-clockwise from
# above = positive. The whole capture is measured (frame 0, the T-pose, dropped): walking
# sways the pelvis by several degrees either way, and 69_20 ends with the subject starting to
# turn back a little, so its whole-capture net is smaller than the turn itself (measured
# -65.6 deg; the turn peaks at -98 deg, see the next test).
EXPECTED_TURN = {"69_20": -90.0, "69_25": 90.0, "16_18": 90.0, "16_21": 0.0, "69_01": 0.0}


@pytest.mark.parametrize("name", CMU_FILES)
def test_cmu_net_hip_rotation_matches_description(cmu_dir: Path, name: str) -> None:
    seq = bvh.read_bvh(cmu_dir / f"{name}.bvh", skip_first_frame=True)
    turn = geometry.turning_angle(seq.positions, seq.layout, method="net")
    expected = EXPECTED_TURN[name]
    if expected == 0.0:
        assert abs(turn.net_deg) < 15.0
    else:
        assert turn.direction == ("left" if expected > 0 else "right")
        assert turn.net_deg == pytest.approx(expected, abs=30.0)


@pytest.mark.parametrize("name", ["69_20", "69_25", "16_18"])
def test_cmu_turn_is_about_90_between_steady_ends(cmu_dir: Path, name: str) -> None:
    """Averaging the hip yaw over the first and last half second cancels the gait sway."""
    seq = bvh.read_bvh(cmu_dir / f"{name}.bvh", skip_first_frame=True)
    yaw = geometry.frame_yaw_deg(seq.positions, seq.layout)
    half_s = int(seq.fps / 2)
    change = yaw[-half_s:].mean() - yaw[:half_s].mean()
    assert change == pytest.approx(EXPECTED_TURN[name], abs=12.0)


def test_cmu_tpose_frame_is_not_part_of_the_capture(cmu_dir: Path) -> None:
    """69_01 walks facing about -50 deg from the T-pose's heading: keeping frame 0 adds a
    one-frame jump of that size, which is why it is dropped by default."""
    kept = bvh.read_bvh(cmu_dir / "69_01.bvh", skip_first_frame=False)
    yaw = geometry.frame_yaw_deg(kept.positions, kept.layout)
    assert abs(yaw[1] - yaw[0]) > 30.0
    assert abs(np.diff(yaw[1:])).max() < 5.0  # 120 fps: a few degrees per frame at most


# --- bad files ----------------------------------------------------------------------------


def _line_of(text: str, fragment: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if fragment in line)


def test_truncated_motion_line_names_file_and_line(tmp_path: Path) -> None:
    text = CONVENTION_BVH.replace("10 20 30 90 0 90 90 0 90", "10 20 30 90 0")
    path = _write(tmp_path, text)
    with pytest.raises(TurnbenchError) as exc:
        bvh.parse_bvh(path)
    assert exc.value.where.file == str(path)
    assert exc.value.where.row == _line_of(text, "10 20 30 90 0") == 20
    assert "5 values" in str(exc.value) and "9 channels" in str(exc.value)


def test_wrong_channel_count_names_file_and_line(tmp_path: Path) -> None:
    text = CONVENTION_BVH.replace(
        "CHANNELS 3 Xrotation Yrotation Zrotation", "CHANNELS 3 Xrotation Yrotation"
    )
    path = _write(tmp_path, text)
    with pytest.raises(TurnbenchError) as exc:
        bvh.parse_bvh(path)
    assert exc.value.where.file == str(path)
    assert exc.value.where.row == 9
    assert "declares 3 channels but names 2" in str(exc.value)


@pytest.mark.parametrize(
    ("old", "new", "row", "message"),
    [
        ("Frames: 2", "Frames: 3", 20, "only 2 motion lines"),
        ("Frames: 2", "Frames: 1", 20, "more motion lines"),
        ("90 90 0 90", "90 90 0 x9", 20, "'x9' is not a number"),
        ("Frame Time: 0.02", "Frame Time: 0", 18, "frame time must be positive"),
        (
            "CHANNELS 3 Xrotation Yrotation Zrotation",
            "CHANNELS 3 Xrotation Yrotation Wrotation",
            9,
            "unknown channel",
        ),
        ("OFFSET 0 1 0\n    CHANNELS", "OFFSET 0 one 0\n    CHANNELS", 8, "not numbers"),
        ("MOTION", "MOTON", 16, "expected 'MOTION'"),
        ("HIERARCHY", "HIERARCHIE", 1, "not a BVH file"),
    ],
)
def test_malformed_files(tmp_path: Path, old: str, new: str, row: int, message: str) -> None:
    text = CONVENTION_BVH.replace(old, new, 1)
    assert text != CONVENTION_BVH
    with pytest.raises(TurnbenchError, match=re.escape(message)) as exc:
        bvh.parse_bvh(_write(tmp_path, text))
    assert exc.value.where.row == row
    assert exc.value.where.file.endswith("t.bvh")


def test_file_cut_inside_the_hierarchy(tmp_path: Path) -> None:
    text = "\n".join(CONVENTION_BVH.splitlines()[:8])
    with pytest.raises(TurnbenchError, match="truncated"):
        bvh.parse_bvh(_write(tmp_path, text))


def test_duplicate_joint_names(tmp_path: Path) -> None:
    text = _hips_bvh(np.zeros(2), left="Leg", right="Leg")
    with pytest.raises(TurnbenchError, match="not unique: Leg"):
        bvh.parse_bvh(_write(tmp_path, text))


def test_empty_file(tmp_path: Path) -> None:
    path = _write(tmp_path, "\n  \n")
    with pytest.raises(TurnbenchError) as exc:
        bvh.parse_bvh(path)
    assert str(exc.value) == f"{path}: the file is empty"


def test_missing_file() -> None:
    with pytest.raises(TurnbenchError, match="cannot read"):
        bvh.parse_bvh("/nonexistent/x.bvh")


def test_a_smooth_start_at_zero_orientation_is_not_a_rest_pose(tmp_path: Path) -> None:
    # root yaw 0, 3, 6, ... degrees: zero at frame 0 but no jump, so every frame is kept
    path = _write(tmp_path, _hips_bvh(np.linspace(0.0, 90.0, 31)))
    assert not bvh.first_frame_is_rest_pose(bvh.parse_bvh(path))
    assert bvh.read_bvh(path).positions.shape[0] == 31
    # the same file with a T-pose-like first frame: zero root, then a 60-degree jump
    yaw = np.concatenate([[0.0], 60.0 + np.linspace(0.0, 30.0, 30)])
    path = _write(tmp_path, _hips_bvh(yaw), name="jump.bvh")
    assert bvh.first_frame_is_rest_pose(bvh.parse_bvh(path))
    assert bvh.read_bvh(path).positions.shape[0] == 30
    # channel names are matched without regard to case (some writers print "Zrotation",
    # others "ZRotation")
    path = _write(tmp_path, _hips_bvh(yaw).replace("rotation", "Rotation"), name="caps.bvh")
    assert bvh.first_frame_is_rest_pose(bvh.parse_bvh(path))
    # a jump without an exactly zero root orientation is motion, kept
    path = _write(tmp_path, _hips_bvh(yaw + 0.5), name="moving.bvh")
    assert not bvh.first_frame_is_rest_pose(bvh.parse_bvh(path))
