"""``turn_datasets.synthetic.degrade``: the statistics planted are the statistics measured.

Skeletons here are built by hand: a body standing at the origin, its hips 100 mm either side
of the pelvis, turned so that it faces a camera on the +x axis (0°), is side-on (90°) or has
its back to it (180°). Expected values come from the parameters and from probability worked
out in the comments, never from the module's own output.
"""

from __future__ import annotations

import numpy as np
import pytest

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import turning_angle
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, H36M32
from turn_datasets.synthetic.degrade import degrade_skeleton, facing_to_camera_deg, to_h36m17

CAMERA = (6000.0, 0.0, 1500.0)  # on the +x axis, 6 m away, at head height


def _body(layout, facing_deg: float, n_frames: int) -> np.ndarray:
    """A still body facing ``facing_deg`` (0 = +x) with every joint at a distinct place.

    Facing +x with z up, the person's left is +y, so the left hip sits at +y (rotated with
    the facing); the other joints sit on a fixed spiral so none coincide.
    """
    rng = np.random.default_rng(123)
    local = rng.uniform(-300, 300, size=(layout.n_joints, 3))
    local[:, 2] = rng.uniform(0, 1700, size=layout.n_joints)
    local[layout.index("left_hip")] = (0.0, 100.0, 900.0)
    local[layout.index("right_hip")] = (0.0, -100.0, 900.0)
    a = np.radians(facing_deg)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    pose = local @ rot.T
    return np.repeat(pose[None], n_frames, axis=0)


@pytest.mark.parametrize(
    ("facing", "expected"), [(0, 0), (90, 90), (180, 180), (-90, 90), (45, 45)]
)
def test_facing_to_camera(facing: float, expected: float) -> None:
    theta = facing_to_camera_deg(_body(H36M32, facing, 5), H36M32, camera_position_mm=CAMERA)
    np.testing.assert_allclose(theta, expected, atol=1e-9)


def _only(**kw):
    base = dict(
        joint_noise_mm=0.0,
        depth_sd_facing_mm=0.0,
        depth_sd_away_mm=0.0,
        dropout_rate_per_s=0.0,
        camera_position_mm=CAMERA,
    )
    base.update(kw)
    return base


def test_joint_noise_has_the_planted_sd() -> None:
    ref = _body(H36M32, 30, 2000)
    out = degrade_skeleton(ref, H36M32, seed=1, **_only(joint_noise_mm=15.0))
    residual = out.positions - ref
    # 192,000 normal draws: the sample sd is within 0.2% of 15 mm (standard error sd/sqrt(2n))
    assert residual.std() == pytest.approx(15.0, rel=0.01)
    assert abs(residual.mean()) < 0.1
    assert not out.dropped.any()


@pytest.mark.parametrize(("facing", "sd"), [(0, 20.0), (90, 55.0), (180, 90.0)])
def test_depth_error_lies_on_the_camera_ray_and_grows_with_the_angle(facing, sd) -> None:
    # linear between 20 mm facing the camera and 90 mm away from it: 20 + 70 * 90/180 = 55 side-on
    ref = _body(H36M32, facing, 3000)
    out = degrade_skeleton(
        ref, H36M32, seed=2, **_only(depth_sd_facing_mm=20.0, depth_sd_away_mm=90.0)
    )
    residual = out.positions - ref
    rays = ref - np.asarray(CAMERA)
    rays /= np.linalg.norm(rays, axis=2, keepdims=True)
    along = np.sum(residual * rays, axis=2)
    across = residual - along[..., None] * rays
    assert np.abs(across).max() < 1e-6  # nothing off the ray
    np.testing.assert_allclose(out.depth_sd_mm, sd)
    # smoothed over 5 frames, 3000 frames x 32 joints still give thousands of independent
    # draws: the sd is within a few percent of the planted one
    assert along.std() == pytest.approx(sd, rel=0.06)
    # ... and it drifts: neighbouring frames are strongly correlated (white noise would be ~0)
    lag1 = np.corrcoef(along[:-1].ravel(), along[1:].ravel())[0, 1]
    assert lag1 > 0.9


def test_depth_error_disturbs_the_hip_vector_more_with_the_back_to_the_camera() -> None:
    spread = {}
    for facing in (0, 180):
        ref = _body(H36M32, facing, 1500)
        out = degrade_skeleton(
            ref, H36M32, seed=3, **_only(depth_sd_facing_mm=20.0, depth_sd_away_mm=90.0)
        )
        left = out.positions[:, H36M32.index("left_hip"), :2]
        right = out.positions[:, H36M32.index("right_hip"), :2]
        v = left - right
        spread[facing] = np.degrees(np.arctan2(v[:, 1], v[:, 0])).std()
    # the camera ray is along x, the hip vector along y: depth error rotates it, by an
    # amount proportional to the depth sd (90 / 20 = 4.5 times), so clearly more
    assert spread[180] / spread[0] == pytest.approx(4.5, rel=0.2)


def test_dropouts_are_whole_nan_frames_at_the_planted_rate() -> None:
    n = 60_000
    ref = _body(H36M17, 0, n)
    out = degrade_skeleton(
        ref, H36M17, seed=4, fps=50.0, **_only(dropout_rate_per_s=1.0, dropout_mean_s=0.2)
    )
    nan_frames = np.isnan(out.positions).any(axis=(1, 2))
    assert np.array_equal(nan_frames, out.dropped)
    assert np.isnan(out.positions[out.dropped]).all()  # whole frames, every joint
    assert not out.dropped[0] and not out.dropped[-1]
    # a dropout starts with probability p = 1/50 per frame and lasts L ~ geometric with mean
    # 10 frames; a frame is covered unless no earlier start reaches it:
    # P(free) = prod_k (1 - p P(L > k)) ~ exp(-p * E[L]) = exp(-0.2), so 18.1% are dropped
    assert out.dropped.mean() == pytest.approx(1 - np.exp(-0.2), rel=0.1)
    starts = np.flatnonzero(np.diff(out.dropped.astype(int)) == 1)
    # runs merge when they overlap, so there are a little fewer than n * p = 1200 of them
    assert 900 < starts.size < 1250


def test_keep_frames_are_never_dropped() -> None:
    ref = _body(H36M17, 0, 2000)
    keep = [10, 11, 500, 1999]
    # a dropout starts on every other frame and lasts a second: nearly everything goes ...
    out = degrade_skeleton(
        ref, H36M17, seed=9, keep_frames=keep, dropout_rate_per_s=25.0, dropout_mean_s=1.0
    )
    assert out.dropped.mean() > 0.9
    # ... except the frames asked for
    assert not out.dropped[keep].any()
    assert np.isfinite(out.positions[keep]).all()
    with pytest.raises(TurnbenchError, match="keep_frames"):
        degrade_skeleton(ref, H36M17, seed=9, keep_frames=[2000])


def test_seeded_and_leaves_its_input_alone() -> None:
    ref = _body(H36M32, 60, 400)
    before = ref.copy()
    a = degrade_skeleton(ref, H36M32, seed=7, dropout_rate_per_s=2.0)
    b = degrade_skeleton(ref, H36M32, seed=7, dropout_rate_per_s=2.0)
    c = degrade_skeleton(ref, H36M32, seed=8, dropout_rate_per_s=2.0)
    assert np.array_equal(ref, before)
    np.testing.assert_array_equal(a.positions, b.positions)
    assert not np.array_equal(np.nan_to_num(a.positions), np.nan_to_num(c.positions))


def test_metres_are_degraded_by_the_same_millimetres() -> None:
    ref_mm = _body(H36M32, 120, 300)
    a = degrade_skeleton(ref_mm, H36M32, seed=5)
    b = degrade_skeleton(ref_mm / 1000.0, H36M32, seed=5, mm_per_unit=1000.0)
    np.testing.assert_allclose(b.positions * 1000.0, a.positions, atol=1e-6)


def test_a_planted_turn_survives_degradation_with_a_bounded_error() -> None:
    # a 90° left turn in place over 2 s at 50 Hz, as the mined clips are
    n = 100
    yaw = np.linspace(0.0, 90.0, n)
    ref = np.stack([_body(H36M32, y, 1)[0] for y in yaw])
    truth = turning_angle(ref, H36M32, method="net").angle_deg
    assert truth == pytest.approx(90.0, abs=1e-9)
    errors = []
    for seed in range(40):
        out = degrade_skeleton(ref, H36M32, seed=seed, camera_position_mm=CAMERA)
        errors.append(turning_angle(out.positions, H36M32, method="net").angle_deg - 90.0)
    # Worked by hand for the defaults: at the start the body faces the camera, the 20 mm depth
    # sd of each hip acts across the 200 mm hip vector: atan(sqrt(2) * 20 / 200) = 8.0°; at the
    # end it is side-on, the ray runs along the hip vector and only changes its length; the
    # 0.5 mm joint noise adds atan(sqrt(2) * 0.5 / 200) = 0.2° at each end. The error is
    # normal with sd 8.0°, so its mean magnitude is sqrt(2 / pi) * 8.0 = 6.4°, known to
    # within about 0.75 * 8.0 / sqrt(40) = 0.95° from 40 draws.
    assert 4.0 < np.mean(np.abs(errors)) < 8.8


def test_to_h36m17_keeps_the_named_joints() -> None:
    ref = _body(H36M32, 0, 3)
    sub = to_h36m17(ref)
    assert sub.shape == (3, 17, 3)
    for name in ("left_hip", "right_hip", "left_shoulder", "right_knee", "head"):
        np.testing.assert_array_equal(sub[:, H36M17.index(name)], ref[:, H36M32.index(name)])
    assert H36M17_FROM_32[H36M17.index("left_hip")] == 6


def test_bad_input_is_a_turnbench_error() -> None:
    with pytest.raises(TurnbenchError, match=r"\(frames, 32, 3\)"):
        degrade_skeleton(np.zeros((5, 17, 3)), H36M32, seed=0)
    with pytest.raises(TurnbenchError, match="joint_noise_mm must not be negative"):
        degrade_skeleton(_body(H36M32, 0, 5), H36M32, seed=0, joint_noise_mm=-1.0)
    with pytest.raises(TurnbenchError, match="no frame has both hips"):
        degrade_skeleton(np.full((5, 32, 3), np.nan), H36M32, seed=0)
    with pytest.raises(TurnbenchError):
        to_h36m17(np.zeros((4, 17, 3)))
