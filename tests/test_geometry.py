"""The turning-angle geometry (paper equations 1 to 4), checked by hand and by properties."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import (
    SMALL_MEDIAN,
    angular_speed_deg_s,
    direction_of,
    frame_yaw_deg,
    frontal_lengths,
    frontal_vectors,
    median,
    parse_joints,
    quantise_deg,
    turning_angle,
    unwrap_rad,
    usable_frames,
    yaw_rate_deg_s,
)
from turn_datasets.skeleton import H36M17, H36M32, to_z_up

HIP_HALF_WIDTH = 0.13  # metres


def body(yaw_deg: np.ndarray, layout=H36M17, *, knee_offset_deg=0.0, shoulder_offset_deg=0.0):
    """A stick body whose left-minus-right hip vector points at ``yaw_deg`` (ground plane).

    Knees and shoulders get their own yaw (offset by a constant), heights 0.9 / 0.5 / 1.4 m.
    """
    yaw = np.radians(np.asarray(yaw_deg, dtype=float))
    p = np.zeros((yaw.size, layout.n_joints, 3))
    for pair, offset, height, half in (
        ("hip", 0.0, 0.9, HIP_HALF_WIDTH),
        ("knee", knee_offset_deg, 0.5, 0.1),
        ("shoulder", shoulder_offset_deg, 1.4, 0.18),
    ):
        a = yaw + math.radians(offset)
        left, right = f"left_{pair}", f"right_{pair}"
        p[:, layout.index(left), 0] = half * np.cos(a)
        p[:, layout.index(left), 1] = half * np.sin(a)
        p[:, layout.index(right), 0] = -half * np.cos(a)
        p[:, layout.index(right), 1] = -half * np.sin(a)
        p[:, layout.index(left), 2] = height
        p[:, layout.index(right), 2] = height
    return p


def test_layouts_name_the_documented_indices():
    assert [H36M32.index(j) for j in ("pelvis", "right_hip", "right_knee", "right_foot")] == [
        0,
        1,
        2,
        3,
    ]
    assert [H36M32.index(j) for j in ("left_hip", "left_knee", "left_foot")] == [6, 7, 8]
    assert H36M32.index("left_shoulder") == 17 and H36M32.index("right_shoulder") == 25
    # the 17-joint subset: right hip 1, right knee 2, left hip 4, left knee 5, shoulders 11 / 14
    assert [H36M17.index(j) for j in ("right_hip", "right_knee", "left_hip", "left_knee")] == [
        1,
        2,
        4,
        5,
    ]
    assert H36M17.index("left_shoulder") == 11 and H36M17.index("right_shoulder") == 14
    with pytest.raises(TurnbenchError, match="no joint"):
        H36M17.index("tail")


def test_frontal_vector_is_left_minus_right_on_the_ground():
    p = np.zeros((1, 17, 3))
    p[0, H36M17.index("left_hip")] = [1.0, 2.0, 5.0]
    p[0, H36M17.index("right_hip")] = [0.5, -1.0, 9.0]
    np.testing.assert_allclose(frontal_vectors(p, H36M17, "hip"), [[0.5, 3.0]])


def test_known_steps_give_the_known_angle_with_both_methods():
    # 9 steps of 10 degrees counter-clockwise: 90 degrees to the left
    p = body(np.arange(10) * 10.0)
    for method in ("paper", "net"):
        res = turning_angle(p, H36M17, method=method)
        assert res.angle_deg == pytest.approx(90.0)
        assert res.net_deg == pytest.approx(90.0)
        assert res.direction == "left"
    # clockwise 3 x 30 = 90 degrees right, on the 32-joint layout
    res = turning_angle(body(-np.arange(4) * 30.0, H36M32), H36M32, method="paper")
    assert res.angle_deg == pytest.approx(90.0) and res.direction == "right"


def test_turn_back_paper_sums_both_legs_net_takes_the_difference():
    # 120 degrees left in 12 steps, then 50 degrees back right in 5 steps
    yaw = np.concatenate([np.arange(13) * 10.0, 120.0 - np.arange(1, 6) * 10.0])
    paper = turning_angle(body(yaw), H36M17, method="paper")
    net = turning_angle(body(yaw), H36M17, method="net")
    assert paper.angle_deg == pytest.approx(120.0 + 50.0)
    assert net.angle_deg == pytest.approx(120.0 - 50.0)
    assert net.net_deg == pytest.approx(70.0) and paper.direction == "left"


def test_net_follows_a_full_turn_and_more():
    # 450 degrees in 5-degree steps: unwrapping keeps counting past 180 and 360
    res = turning_angle(body(np.arange(91) * 5.0), H36M17, method="net")
    assert res.angle_deg == pytest.approx(450.0)


def test_paper_cannot_see_more_than_90_degrees_between_two_frames():
    # one jump of 120 degrees: arcsin(|sin 120|) = 60 degrees; net sees 120
    p = body(np.array([0.0, 120.0]))
    assert turning_angle(p, H36M17, method="paper").angle_deg == pytest.approx(60.0)
    assert turning_angle(p, H36M17, method="net").angle_deg == pytest.approx(120.0)


def test_jitter_makes_paper_grow_with_frames_while_net_stays_near_zero():
    rng = np.random.default_rng(7)
    results = {}
    for n_frames in (50, 500):
        p = body(np.zeros(n_frames)) + rng.normal(0.0, 0.005, size=(n_frames, 17, 3))
        results[n_frames] = (
            turning_angle(p, H36M17, method="paper").angle_deg,
            turning_angle(p, H36M17, method="net").angle_deg,
        )
    # 5 mm jitter on each of two hips 0.26 m apart: per-frame angle noise of about
    # sqrt(4) * 0.005 / 0.26 rad = 2.2 degrees, so "paper" adds ~1.7 degrees a frame.
    assert results[500][0] > 5 * results[50][0] > 0
    assert results[500][0] > 300.0
    assert results[50][1] < 10.0 and results[500][1] < 10.0


def test_several_joint_pairs_are_averaged():
    # hips turn 90, knees follow 60 of it (they lag), shoulders 90; net averages 80
    yaw = np.arange(10) * 10.0
    p = body(yaw)
    knees = body(yaw * 60.0 / 90.0)
    for j in ("left_knee", "right_knee"):
        p[:, H36M17.index(j)] = knees[:, H36M17.index(j)]
    res = turning_angle(p, H36M17, joints="hip,knee,shoulder")
    assert res.angle_deg == pytest.approx((90 + 60 + 90) / 3)
    assert res.joints == ("hip", "knee", "shoulder")


def test_unusable_frames_are_skipped_bridged_and_counted():
    p = body(np.arange(10) * 10.0)
    p[3, H36M17.index("left_hip")] = np.nan  # dropout
    p[6, H36M17.index("left_hip")] = p[6, H36M17.index("right_hip")]  # coincident hips
    res = turning_angle(p, H36M17, method="paper")
    assert res.n_skipped_frames == 2
    assert res.angle_deg == pytest.approx(90.0)  # the gaps of 20 degrees are bridged
    assert usable_frames(p, H36M17).tolist() == [i not in (3, 6) for i in range(10)]
    yaw = frame_yaw_deg(p, H36M17)
    assert np.isnan(yaw[[3, 6]]).all()
    np.testing.assert_allclose(yaw[[0, 9]], [0.0, 90.0])


def test_fewer_than_two_usable_frames_is_an_error_not_nan():
    p = body(np.zeros(5))
    p[1:, H36M17.index("right_hip")] = np.nan
    with pytest.raises(TurnbenchError, match="fewer than two usable frames"):
        turning_angle(p, H36M17)


def test_bad_arguments_are_errors():
    with pytest.raises(TurnbenchError, match="unknown method"):
        turning_angle(body(np.zeros(3)), H36M17, method="sum")
    with pytest.raises(TurnbenchError, match="unknown joint pair"):
        parse_joints("hip,elbow")
    with pytest.raises(TurnbenchError, match="30 joints but layout .h36m17. has 17"):
        turning_angle(body(np.zeros(3), H36M32)[:, :30], H36M17)


def test_frame_yaw_of_several_pairs_stays_on_one_branch():
    # shoulders 350 degrees ahead of the hips = -10 degrees: the mean must not be ~170
    yaw = frame_yaw_deg(body(np.zeros(3), shoulder_offset_deg=350.0), H36M17, "hip,shoulder")
    np.testing.assert_allclose(yaw, [-5.0, -5.0, -5.0], atol=1e-9)


def test_yaw_rate_speed_direction_and_bins():
    np.testing.assert_allclose(yaw_rate_deg_s(np.arange(5) * 2.0, fps=50), np.full(5, 100.0))
    # equation 4: 180 degrees in 1.5 s
    assert angular_speed_deg_s(180.0, 1.5) == pytest.approx(120.0)
    assert np.isnan(angular_speed_deg_s(90.0, 0.0))
    assert (direction_of(3.0), direction_of(-0.1), direction_of(0.0)) == ("left", "right", "none")
    # nearest multiple of 45, halves up (DESIGN's floor formula)
    np.testing.assert_array_equal(
        quantise_deg([0, 22.4, 22.5, 67.4, 67.5, 112.6, 234.7, 45.2]),
        [0, 0, 45, 45, 90, 135, 225, 45],
    )
    assert quantise_deg(100.0, bin_width_deg=90) == 90.0


def test_to_z_up_by_hand():
    # y-up: a point 1 m up and 2 m "forward" (+z) lands at z = 1, y = -2
    np.testing.assert_allclose(to_z_up(np.array([0.5, 1.0, 2.0]), "y"), [0.5, -2.0, 1.0])
    # camera frame: y down, z forward -> up is -y, forward is +y
    np.testing.assert_allclose(to_z_up(np.array([0.5, 1.0, 2.0]), "-y"), [0.5, 2.0, -1.0])
    # x up: -90° about y, (x, y, z) -> (-z, y, x); -x up: +90° about y, (z, y, -x);
    # -z up: 180° about x, (x, -y, -z)
    np.testing.assert_allclose(to_z_up(np.array([0.5, 1.0, 2.0]), "x"), [-2.0, 1.0, 0.5])
    np.testing.assert_allclose(to_z_up(np.array([0.5, 1.0, 2.0]), "-x"), [2.0, 1.0, -0.5])
    np.testing.assert_allclose(to_z_up(np.array([0.5, 1.0, 2.0]), "-z"), [0.5, -1.0, -2.0])
    # every one is a proper rotation taking its axis to +z (handedness, so left/right, kept)
    for axis in ("z", "y", "-y", "x", "-x", "-z"):
        m = to_z_up(np.eye(3), axis)
        np.testing.assert_allclose(m @ m.T, np.eye(3))
        assert np.linalg.det(m) == pytest.approx(1.0)
        unit = {"x": 0, "y": 1, "z": 2}[axis[-1]]
        up = np.eye(3)[unit] * (-1.0 if axis.startswith("-") else 1.0)
        np.testing.assert_allclose(to_z_up(up, axis), [0.0, 0.0, 1.0])
    with pytest.raises(TurnbenchError, match="unknown up axis"):
        to_z_up(np.zeros(3), "w")


# ---- properties -------------------------------------------------------------------------

turns = st.lists(st.floats(-25.0, 25.0), min_size=2, max_size=40)


def _walk(steps):
    return body(np.concatenate([[0.0], np.cumsum(steps)]))


@settings(max_examples=60, deadline=None)
@given(
    steps=turns,
    shift=st.tuples(*[st.floats(-5e3, 5e3)] * 3),
    scale=st.floats(0.01, 1000.0),
    rot_deg=st.floats(-180.0, 180.0),
)
def test_angles_invariant_to_translation_scale_and_vertical_rotation(steps, shift, scale, rot_deg):
    p = _walk(steps)
    c, s = math.cos(math.radians(rot_deg)), math.sin(math.radians(rot_deg))
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    q = (p @ rz.T) * scale + np.asarray(shift)
    for method in ("paper", "net"):
        a, b = turning_angle(p, H36M17, method=method), turning_angle(q, H36M17, method=method)
        assert b.angle_deg == pytest.approx(a.angle_deg, abs=1e-6)
        assert b.net_deg == pytest.approx(a.net_deg, abs=1e-6)


@settings(max_examples=60, deadline=None)
@given(steps=turns)
def test_reversing_time_flips_the_direction(steps):
    p = _walk(steps)
    fwd, back = turning_angle(p, H36M17), turning_angle(p[::-1], H36M17)
    assert back.net_deg == pytest.approx(-fwd.net_deg, abs=1e-9)
    if abs(fwd.net_deg) > 1e-6:
        assert {fwd.direction, back.direction} == {"left", "right"}
    paper_f = turning_angle(p, H36M17, method="paper").angle_deg
    assert turning_angle(p[::-1], H36M17, method="paper").angle_deg == pytest.approx(paper_f)


@settings(max_examples=60, deadline=None)
@given(steps=turns)
def test_a_y_up_copy_converts_to_the_same_result(steps):
    p = _walk(steps)
    # build the y-up copy by hand: up (z) becomes y, and the ground's y becomes -z
    y_up = np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)
    # a camera copy: x right, y down, z forward (ground y is forward)
    cam = np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)
    want = turning_angle(p, H36M17)
    for copy, axis in ((y_up, "y"), (cam, "-y")):
        got = turning_angle(to_z_up(copy, axis), H36M17)
        assert got.net_deg == pytest.approx(want.net_deg, abs=1e-9)
        assert got.direction == want.direction


def test_infinite_joints_are_unusable_frames_without_a_warning():
    import warnings

    p = body(np.arange(5) * 10.0)
    p[:, H36M17.index("left_hip")] = np.inf
    p[:, H36M17.index("right_hip")] = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning would fail here
        assert not usable_frames(p, H36M17).any()
        with pytest.raises(TurnbenchError, match="fewer than two usable frames"):
            turning_angle(p, H36M17)


# --- heading change over strides (issue 11) ------------------------------------------------


def test_heading_change_removes_a_sway_of_one_stride_exactly() -> None:
    from turn_datasets.geometry import heading_change_deg, window_means

    # By hand: 20 frames a stride, the yaw 10° before frame 100 and 100° from frame 130, a
    # ramp between, plus a sway 4 sin(2 pi k / 20): over any 20 consecutive frames the sway
    # sums to zero (a whole period of a sampled sine), so the means are 10° and 100°
    # whatever the phase, and the change is 90°. The hip's net rotation from the first frame
    # to the last is 90° plus the sway's difference at the two frames.
    k = np.arange(200)
    heading = np.interp(k, [99, 130], [10.0, 100.0])
    yaw = heading + 4.0 * np.sin(2 * np.pi * k / 20)
    got = heading_change_deg(
        yaw, np.array([99, 95]), np.array([131, 140]), before_frames=20, after_frames=20
    )
    np.testing.assert_allclose(got, [90.0, 90.0], atol=1e-9)
    assert yaw[130] - yaw[99] == pytest.approx(
        90.0 + 4 * np.sin(2 * np.pi * 130 / 20) - 4 * np.sin(2 * np.pi * 99 / 20)
    )
    # windows cut at a neighbour: 5 frames before frame 99 (94..98) average the sway over a
    # quarter of it; the mean of 4 sin(2 pi k / 20) over k = 94..98 is worked out directly
    part = np.mean(4 * np.sin(2 * np.pi * np.arange(94, 99) / 20))
    got = heading_change_deg(yaw, 99, 131, before_frames=20, after_frames=20, lower=94)
    assert got == pytest.approx(100.0 - (10.0 + part), abs=1e-9)
    # nothing before (a turn from the first frame): the first frame's yaw
    got = heading_change_deg(yaw, 0, 131, before_frames=20, after_frames=20)
    assert got == pytest.approx(100.0 - yaw[0], abs=1e-9)
    np.testing.assert_allclose(window_means(k.astype(float), [0, 10], [4, 10]), [1.5, 10.0])


def test_median_is_numpys_median_bit_for_bit() -> None:
    # the hand-written small median stands in for np.median: the same number, odd or even
    # counts, ties, any scale, on either side of the size where it hands over to np.median
    rng = np.random.default_rng(0)
    sizes = [1, 2, 3, 4, 5, 150, 151, SMALL_MEDIAN - 1, SMALL_MEDIAN, SMALL_MEDIAN + 1, 4000]
    sizes += rng.integers(1, 2 * SMALL_MEDIAN, 300).tolist()
    for n in sizes:
        x = rng.random(n) * 10.0 ** rng.uniform(-4, 4)
        if rng.random() < 0.3:
            x = np.round(x, 1)  # ties
        got, want = median(x), np.median(x)
        assert got == want and type(got) is type(want), (n, got, want)
    assert median(np.array([3.0, 1.0, 2.0])) == 2.0
    assert median(np.array([4.0, 1.0, 3.0, 2.0])) == 2.5  # the two middle values' mean


def test_unwrap_rad_is_numpys_unwrap_bit_for_bit() -> None:
    # headings wrapped to (-pi, pi], slow and fast, with NaN, jumps of exactly pi either way
    # (np.unwrap's boundary rule) and of 2 pi and more; every length from none to a stream's
    rng = np.random.default_rng(0)
    for n in [0, 1, 2, 3, 4, 150, 18000, *rng.integers(2, 500, 200).tolist()]:
        walk = np.cumsum(rng.normal(0.0, rng.choice([0.02, 1.0, 4.0]), n))
        x = np.arctan2(np.sin(walk), np.cos(walk))
        if n > 6 and rng.random() < 0.5:
            x[rng.integers(0, n, 3)] = np.nan
        if n > 6 and rng.random() < 0.5:
            x[2], x[3], x[4] = x[1] + np.pi, x[1], x[1] - 3 * np.pi
        got, want = unwrap_rad(x), np.unwrap(x)
        assert got.tobytes() == want.tobytes(), n
    # by hand: a crossing of the branch cut is carried on; a jump of exactly pi is kept
    np.testing.assert_array_equal(
        unwrap_rad(np.array([3.0, -3.0, 0.0])), [3.0, -3.0 + 2 * np.pi, 2 * np.pi]
    )
    np.testing.assert_array_equal(unwrap_rad(np.array([0.0, np.pi])), [0.0, np.pi])
    np.testing.assert_array_equal(unwrap_rad(np.array([0.0, -np.pi])), [0.0, -np.pi])


def test_frontal_lengths_give_the_usable_frames_and_the_median_length() -> None:
    v = np.array([[3.0, 4.0], [0.0, 0.0], [np.nan, 1.0], [6.0, 8.0], [1e-4, 0.0]])
    got = frontal_lengths(v)
    np.testing.assert_array_equal(got.length, [5.0, 0.0, np.nan, 10.0, 1e-4])
    assert got.median == (1e-4 + 5.0) / 2  # the finite lengths 0, 1e-4, 5, 10: middle two
    # usable: finite and longer than a thousandth of that median (0.0025)
    assert got.usable.tolist() == [True, False, False, True, False]
