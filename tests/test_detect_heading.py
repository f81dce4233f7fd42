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
