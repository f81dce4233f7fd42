"""--up-axis auto: the vertical axis read from the trunk, signed by the head above the feet."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_eval

from turn_datasets.errors import TurnbenchError
from turn_datasets.skeleton import H36M17, H36M32, UP_AXES, to_z_up
from turn_datasets.synthetic.degrade import to_h36m17
from turn_datasets.synthetic.mocap import Segment, generate_sequence
from turn_datasets.up_axis import (
    AxesFound,
    UpAxisParams,
    infer_up_axis,
    resolve_up_axis,
    z_up_arrays,
)


@pytest.fixture(scope="module")
def walker() -> np.ndarray:
    """A Human3.6M-like body (z up, mm) standing, walking and turning 90° left."""
    seq = generate_sequence(
        seed=3,
        segments=[Segment.stand(0.4), Segment.walking_turn(90.0, 1.2), Segment.walk(0.6)],
        fps_hz=30.0,
        noise_mm=5.0,
    )
    return to_h36m17(seq.positions)


def stated_as(z_up: np.ndarray, axis: str) -> np.ndarray:
    """The body written with ``axis`` vertical: the inverse of to_z_up (a rotation, so its
    transpose), so that to_z_up(stated_as(p, a), a) == p."""
    m = to_z_up(np.eye(3), axis)
    return z_up @ m.T


@pytest.mark.parametrize("axis", UP_AXES)
def test_each_signed_axis_is_found_whatever_the_unit(walker, axis):
    body = stated_as(walker, axis)
    found = infer_up_axis(body, H36M17)
    assert found.axis == axis
    assert found.agreement == 1.0 and found.n_frames == len(walker)
    # units do not matter: metres give the same answer and the same evidence
    in_m = infer_up_axis(body / 1000.0, H36M17)
    assert in_m.axis == axis and in_m.dominance == pytest.approx(found.dominance)
    np.testing.assert_allclose(to_z_up(body, found.axis), walker, atol=1e-9)


def test_camera_axes_pitched_down_are_still_minus_y(walker):
    # a Kinect on a shelf looks down by 20°: the trunk is 20° off -y, still clearly -y
    cam = stated_as(walker, "-y")
    a = np.deg2rad(20.0)
    y, z = cam[..., 1], cam[..., 2]
    pitched = np.stack(
        [cam[..., 0], np.cos(a) * y - np.sin(a) * z, np.sin(a) * y + np.cos(a) * z], -1
    )
    found = infer_up_axis(pitched, H36M17)
    assert found.axis == "-y"
    # the trunk's extent along -y over its extent along z is about cot(20°) = 2.7
    assert 2.0 < found.dominance < 3.5


def test_32_joint_layout_uses_the_neck(walker):
    seq = generate_sequence(seed=1, segments=[Segment.walk(1.0)], fps_hz=30.0, noise_mm=0.0)
    assert infer_up_axis(stated_as(seq.positions, "y"), H36M32).axis == "y"


def test_a_lying_person_across_the_axes_is_refused(walker):
    # lying on the floor (z up world), the body along the diagonal of x and y: the trunk is
    # as long along x as along y, so no axis is clearly vertical
    lying = stated_as(walker, "x")  # the body's up now points along +x
    c = np.cos(np.deg2rad(45.0))
    rot = np.array([[c, c, 0.0], [-c, c, 0.0], [0.0, 0.0, 1.0]])  # 45° about z
    diagonal = lying @ rot
    with pytest.raises(TurnbenchError, match="trunk is not clearly along one axis") as err:
        infer_up_axis(diagonal, H36M17, item="clip9")
    assert str(err.value).startswith("clip9: ")
    assert "--up-axis" in err.value.hint


def test_a_head_on_both_sides_of_the_feet_is_refused(walker):
    flipped = walker.copy()
    half = len(walker) // 2
    flipped[half:, :, 2] *= -1.0  # upside down for the second half
    with pytest.raises(TurnbenchError, match="head is above the feet along \\+z in"):
        infer_up_axis(flipped, H36M17)


def test_2d_keypoints_and_missing_joints_are_refused(walker):
    with pytest.raises(TurnbenchError, match="2D keypoints have no vertical axis") as err:
        infer_up_axis(walker[..., :2], H36M17)
    assert err.value.hint == "lift to 3D first"
    gone = walker.copy()
    gone[:, H36M17.index("head")] = np.nan
    with pytest.raises(TurnbenchError, match="no frame shows the pelvis, neck, head"):
        infer_up_axis(gone, H36M17)
    # a few frames missing: the rest decide
    some = walker.copy()
    some[:5] = np.nan
    assert infer_up_axis(some, H36M17).n_frames == len(walker) - 5


def test_thresholds_are_parameters(walker):
    cam = stated_as(walker, "-y")
    a = np.deg2rad(35.0)  # pitched 35°: cot(35°) = 1.43, below the default 1.5
    y, z = cam[..., 1], cam[..., 2]
    pitched = np.stack(
        [cam[..., 0], np.cos(a) * y - np.sin(a) * z, np.sin(a) * y + np.cos(a) * z], -1
    )
    with pytest.raises(TurnbenchError, match="not clearly along one axis"):
        infer_up_axis(pitched, H36M17)
    loose = infer_up_axis(pitched, H36M17, params=UpAxisParams(min_dominance=1.01))
    assert loose.axis == "-y" and 1.01 < loose.dominance < 1.5
    with pytest.raises(TurnbenchError, match="min_dominance"):
        UpAxisParams(min_dominance=1.0)
    with pytest.raises(TurnbenchError, match="min_agreement"):
        UpAxisParams(min_agreement=1.5)


def test_resolve_and_the_record_of_axes(walker):
    assert resolve_up_axis(walker, H36M17, "y") == "y"  # a stated axis is taken as stated
    assert resolve_up_axis(stated_as(walker, "-y"), H36M17, "auto") == "-y"
    with pytest.raises(TurnbenchError, match="unknown up axis 'up'"):
        resolve_up_axis(walker, H36M17, "up")
    found = AxesFound("auto")
    named = [("a", stated_as(walker, "-y")), ("b", stated_as(walker, "y")), ("c", walker)]
    out = list(z_up_arrays(named, layout=H36M17, up_axis="auto", found=found))
    for _, array in out:
        np.testing.assert_allclose(array, walker, atol=1e-9)
    assert dict(found.counts) == {"-y": 1, "y": 1, "z": 1}
    assert found.summary() == (
        "up axis inferred from the trunk (head above the feet): -y for 1 array, y for 1 array, "
        "z for 1 array (first of each: -y a, y b, z c)"
    )
    assert found.manifest() == {
        "option": "auto",
        "inferred": True,
        "found": {"-y": 1, "y": 1, "z": 1},
        "first_array": {"-y": "a", "y": "b", "z": "c"},
    }
    stated = AxesFound("z")
    list(z_up_arrays([("a", walker)], layout=H36M17, up_axis="z", found=stated))
    assert stated.summary() == "up axis stated: z for 1 array"


def test_detect_infers_each_streams_axis_and_records_it(tmp_path, capsys):
    import json

    seq = generate_sequence(
        seed=4,
        segments=[Segment.walk(3.0), Segment.walking_turn(-135.0, 1.5), Segment.walk(3.0)],
        fps_hz=30.0,
        noise_mm=2.0,
    )
    body = to_h36m17(seq.positions) / 1000.0
    np.savez(tmp_path / "home.npz", P01=stated_as(body, "-y"), P02=stated_as(body, "y"))
    found = {}
    for name, extra in (("auto", []), ("stated", ["--up-axis", "-y"])):
        out = tmp_path / f"{name}.csv"
        args = ["detect", tmp_path / "home.npz", "--layout", "h36m17", "--fps", "30", *extra]
        code, _, err = run_turn_eval([*args, "--out", out], capsys)
        assert code == 0, err
        found[name] = (
            pd.read_csv(out),
            json.loads(out.with_name(f"{name}.manifest.json").read_text()),
            err,
        )
    table, manifest, err = found["auto"]
    # each person's axis found on its own, said once, and recorded per stream
    assert (
        "up axis inferred from the trunk (head above the feet): -y for 1 array, y for 1 array"
        in err
    )
    assert [s["up_axis"] for s in manifest["inputs"][0]["streams"]] == ["-y", "y"]
    assert manifest["reading"]["up_axis"] == "auto"
    # the right turn, for both people, as with the axis stated for the camera-axes one
    assert table["direction"].tolist() == ["right", "right"]
    assert (45.0 * np.floor(table["angle_deg"] / 45.0 + 0.5) == 135.0).all()
    stated = found["stated"][0]
    pd.testing.assert_frame_equal(
        table[table["subject"] == "P01"], stated[stated["subject"] == "P01"]
    )
