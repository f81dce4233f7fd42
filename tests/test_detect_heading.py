"""The depth-aware heading of ``turn_eval.detect.heading``: values from the likelihood written
out in the ground frame and minimised by scipy, by hand, and bounds that always hold."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from turn_eval.detect.heading import (
    PAIR_LENGTH_CV,
    camera_rays,
    noise_rays,
    plain_direction,
    ray_weighted_direction,
)


def unit(deg) -> np.ndarray:
    r = np.radians(np.atleast_1d(np.asarray(deg, dtype=float)))
    return np.stack([np.cos(r), np.sin(r)], axis=1)


def angle_deg(v: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(v[:, 1], v[:, 0]))


def turned_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| in degrees, wrapped to [0, 180]."""
    return np.degrees(np.abs(np.angle(np.exp(1j * np.radians(a - b)))))


def test_pairs_at_their_own_width_give_their_own_heading() -> None:
    rng = np.random.default_rng(0)
    truth = rng.uniform(-180, 180, 200)
    rays = unit(rng.uniform(0, 360, 200))
    vectors = [0.26 * unit(truth), 0.36 * unit(truth)]
    got = ray_weighted_direction(
        vectors, [0.26, 0.36], [0.026, 0.058], rays, lateral_sd=0.01, ratio=4.0, search_deg=20.0
    )
    assert turned_deg(angle_deg(got), truth).max() < 0.01
    np.testing.assert_allclose(np.hypot(got[:, 0], got[:, 1]), 1.0, atol=1e-12)


def likelihood_heading(vectors, widths, cvs, ray, lateral_sd, ratio, around, search) -> float:
    """The same likelihood written in the ground frame, each pair's length a free variable
    with its own Gaussian prior, minimised by scipy over heading and lengths together."""
    from scipy.optimize import minimize

    lateral = np.array([ray[1], -ray[0]])
    basis = np.stack([lateral, ray])  # rows: across, along the ray
    inv_cov = basis.T @ np.diag([1.0, 1.0 / ratio**2]) @ basis / lateral_sd**2

    def cost(x):
        e = np.array([np.cos(x[0]), np.sin(x[0])])
        total = 0.0
        for v, w, cv, length in zip(vectors, widths, cvs, x[1:], strict=True):
            r = v - length * e
            total += r @ inv_cov @ r + (length - w) ** 2 / (w * cv) ** 2
        return total

    def profile(phi):
        return minimize(lambda L: cost(np.r_[phi, L]), x0=np.asarray(widths), method="BFGS").fun

    lo, hi = np.radians(around - search), np.radians(around + search)
    return float(np.degrees(minimize_scalar(profile, bounds=(lo, hi), method="bounded").x))


@pytest.mark.parametrize(
    ("ray_deg", "heading_deg", "depth_error"),
    [(90.0, 30.0, 0.06), (90.0, -60.0, -0.05), (60.0, 170.0, 0.07), (120.0, 25.0, 0.04)],
)
def test_two_pairs_follow_the_likelihood_of_a_depth_error(
    ray_deg, heading_deg, depth_error
) -> None:
    ray = unit(ray_deg)[0]
    # each pair's far joint pushed along the ray by the depth error, the shoulders the other way
    hips = 0.26 * unit(heading_deg)[0] + depth_error * ray
    shoulders = 0.36 * unit(heading_deg)[0] - 0.5 * depth_error * ray
    widths, cvs = [0.26, 0.36], [PAIR_LENGTH_CV["hip"], PAIR_LENGTH_CV["shoulder"]]
    plain = angle_deg(plain_direction([hips[None], shoulders[None]], widths))[0]
    got = ray_weighted_direction(
        [hips[None], shoulders[None]],
        widths,
        cvs,
        ray[None],
        lateral_sd=0.01,
        ratio=4.0,
        search_deg=20.0,
    )
    want = likelihood_heading([hips, shoulders], widths, cvs, ray, 0.01, 4.0, plain, 20.0)
    assert angle_deg(got)[0] == pytest.approx(want, abs=0.05)
    # and it is nearer the truth than the plain direction
    assert turned_deg(angle_deg(got), heading_deg)[0] < turned_deg(plain, heading_deg)


def test_a_rigid_pair_with_depth_untrusted_is_read_from_its_lateral_component() -> None:
    # W = 1, the ray along +y: v = (cos 30°, sin 30° + 0.2) points at 38.94°; with the
    # length fixed and depth worth nothing, cos(phi) = 0.866 / 1: phi = 30°
    v = np.array([[np.cos(np.radians(30)), 0.5 + 0.2]])
    assert angle_deg(v)[0] == pytest.approx(38.94, abs=0.01)
    ray = np.array([[0.0, 1.0]])
    rigid = ray_weighted_direction(
        [v], [1.0], [1e-6], ray, lateral_sd=0.01, ratio=1000.0, search_deg=20.0
    )
    assert angle_deg(rigid)[0] == pytest.approx(30.0, abs=0.05)
    # taken alike (ratio 1), or with a length free to vary, the vector's own direction
    alike = ray_weighted_direction(
        [v], [1.0], [1e-6], ray, lateral_sd=0.01, ratio=1.0, search_deg=20.0
    )
    free = ray_weighted_direction(
        [v], [1.0], [1e4], ray, lateral_sd=0.01, ratio=1000.0, search_deg=20.0
    )
    assert angle_deg(alike)[0] == pytest.approx(38.94, abs=0.01)
    assert angle_deg(free)[0] == pytest.approx(38.94, abs=0.01)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-180, 180), min_size=1, max_size=8),
    st.floats(0.5, 2.0),
    st.floats(-0.6, 0.6),
    st.floats(0, 360),
    st.floats(1.0, 50.0),
    st.sampled_from([0.0, 5.0, 20.0, 45.0]),
)
def test_the_heading_never_leaves_the_plain_direction_by_more_than_the_search(
    headings, scale, error, ray_deg, ratio, search
) -> None:
    truth = np.asarray(headings)
    rays = np.repeat(unit(ray_deg), truth.size, axis=0)
    v = scale * unit(truth) + error * rays
    got = ray_weighted_direction(
        [v], [1.0], [0.03], rays, lateral_sd=0.04, ratio=ratio, search_deg=search
    )
    plain = plain_direction([v], [1.0])
    # a vector of no length has no direction, in either
    none = np.hypot(v[:, 0], v[:, 1]) == 0
    np.testing.assert_array_equal(np.isnan(got).any(axis=1), none)
    moved = turned_deg(angle_deg(got), angle_deg(plain))[~none]
    assert np.all(moved <= search + 1e-6)
    if search == 0.0:
        np.testing.assert_allclose(moved, 0.0, atol=1e-9)


def test_camera_rays_point_from_the_origin_or_straight_ahead() -> None:
    mid = np.array([[3.0, 4.0], [0.1, -0.2], [np.nan, 1.0], [-2.0, 0.0]])
    rays = camera_rays(mid, hip_width=0.26)
    np.testing.assert_allclose(rays, [[0.6, 0.8], [0.0, 1.0], [0.0, 1.0], [-1.0, 0.0]])


def jitter(rng, n: int, ray_deg, along: float, across: float, joints: int = 4) -> np.ndarray:
    """``(n, joints, 2)`` still joints with Gaussian jitter of ``along`` / ``across`` spread
    along and across a ray ``ray_deg`` degrees from +y (toward +x), per frame."""
    ray_deg = np.broadcast_to(np.asarray(ray_deg, dtype=float), (n,))
    r = np.radians(ray_deg)[:, None]
    ray = np.stack([np.sin(r), np.cos(r)], axis=-1)
    side = np.stack([np.cos(r), -np.sin(r)], axis=-1)
    e = along * rng.standard_normal((n, joints, 1)) * ray
    e += across * rng.standard_normal((n, joints, 1)) * side
    base = np.array([[0.13, 0.0], [-0.13, 0.0], [0.18, 0.05], [-0.18, 0.05]])[:joints]
    return base + e


def ray_deg(v: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(v[:, 0], v[:, 1]))


def test_noise_rays_find_the_axis_of_a_depth_error() -> None:
    """A depth error 4 times the lateral one (40 against 10 mm) along a ray 25° to one side
    for 100 s, then 35° to the other. A window of 2 s holds 4 x 60 second differences, so
    its axis is read to about 2° (root mean square): a window away from the change, the
    median error is under 2°, 99% of frames are within 6°, and under 0.5% fall back to
    straight ahead. A metre's glitch in one joint moves no frame by more than 2° (summed as
    squares rather than as directions, it would turn the ray toward itself)."""
    rng = np.random.default_rng(3)
    n = 6000
    truth = np.where(np.arange(n) < n // 2, 25.0, -35.0)
    joints = jitter(rng, n, truth, 0.04, 0.01)
    got = noise_rays(joints, fps_hz=30.0)
    far = np.abs(np.arange(n) - n // 2) > 60
    far[:2] = far[-2:] = False
    fell_back = (got[:, 0] == 0.0) & far
    error = np.abs(ray_deg(got) - truth)[far & ~fell_back]
    assert np.median(error) < 2.0 and np.quantile(error, 0.99) < 6.0
    assert fell_back.mean() < 0.005
    assert np.all(got[:, 1] > 0)  # pointing away from the camera
    glitched = joints.copy()
    glitched[1500, 2] += [1.0, 0.0]  # across the first ray
    moved = np.abs(ray_deg(noise_rays(glitched, 30.0)) - ray_deg(got))[1440:1560]
    assert moved.max() < 2.0


def test_noise_rays_are_straight_ahead_where_the_error_is_round_or_unseen() -> None:
    """Under the anisotropy bound (1.5 here against 2.5) the ray cannot be told: straight
    ahead; likewise where a window sees no second difference at all."""
    rng = np.random.default_rng(4)
    round_ = noise_rays(jitter(rng, 300, 40.0, 0.015, 0.01), fps_hz=30.0)
    np.testing.assert_array_equal(round_, np.tile([0.0, 1.0], (300, 1)))
    joints = jitter(rng, 300, 40.0, 0.05, 0.01)
    joints[100:200] = np.nan
    got = noise_rays(joints, fps_hz=30.0)
    np.testing.assert_array_equal(got[130:170], np.tile([0.0, 1.0], (40, 1)))
    assert np.median(np.abs(ray_deg(got[:80]) - 40.0)) < 4.0


def test_directions_of_gaussian_jitter_have_axes_in_the_ratio_of_its_spreads() -> None:
    """The docstring's reading of the bound: for jitter of spreads a > b, the sum of u u^T
    over the unit directions u has eigenvalues in the ratio a / b (numpy's eigh on 400,000
    draws): the bound :data:`MIN_NOISE_ANISOTROPY` is a ratio of spreads, depth over lateral."""
    rng = np.random.default_rng(5)
    for a, b in ((3.0, 1.0), (4.0, 1.5)):
        d = rng.standard_normal((400_000, 2)) * [a, b]
        u = d / np.hypot(d[:, 0], d[:, 1])[:, None]
        lo, hi = np.linalg.eigh(u.T @ u)[0]
        assert hi / lo == pytest.approx(a / b, rel=0.02)


def test_camera_rays_of_a_root_relative_stream_come_from_its_error() -> None:
    """Positioned frames point at the mid-hip point; root-relative ones (within two hip
    widths of the origin) take the ray of their jitter when the joints are given."""
    rng = np.random.default_rng(6)
    joints = jitter(rng, 90, -30.0, 0.05, 0.01)
    mid = np.zeros((90, 2))
    mid[:10] = [3.0, 4.0]
    rays = camera_rays(mid, 0.26, joints, fps_hz=30.0)
    np.testing.assert_allclose(rays[:10], np.tile([0.6, 0.8], (10, 1)))
    assert np.abs(ray_deg(rays[40:50]) + 30.0).max() < 5.0
    np.testing.assert_array_equal(camera_rays(mid, 0.26)[10:], np.tile([0.0, 1.0], (80, 1)))
