"""The body's heading from its joint pairs, knowing that a monocular estimator misjudges depth.

A pose estimator that sees one camera places each joint well across the image and poorly
along the camera's ray: a lifter's 40-60 mm of error per joint on Human3.6M is mostly
depth. The estimator model the detector is measured against has 30 mm of depth error
against 10 mm across the ray, twice the depth with the back to the camera;
:mod:`turn_datasets.synthetic.untrimmed` plants that white depth error, a drifting one
beside it and 8 mm of jitter. A pair's frontal vector (left minus right joint, on the
ground) is then measured well across the ray and badly along it, and its direction, taken
as it is, turns with every depth error: with hips 260 mm apart, 60 mm of depth error on
each hip turns it by about 18° (one standard deviation).

What an estimator keeps nearly constant is a pair's length: the distance between the hips
is a body dimension, and between the shoulders nearly one. On the real video of
``../shared/data/video`` (MediaPipe, 166 frames with both pairs seen) the hip width varies
by 2.6% (the interquartile range over 1.35, of the median) and the shoulder width by 5.8%,
while the knees, which move in gait, vary by 40% (:data:`PAIR_LENGTH_CV`). Each frame's
heading ``e`` is therefore the one that best explains every pair's vector ``v_j`` as
``L_j e`` plus an error, where the length ``L_j`` varies about the pair's width ``W_j`` by
its share of :data:`PAIR_LENGTH_CV` and the error is ``ray_noise_ratio`` times larger along
the ray than across it (the maximum of the Gaussian likelihood, ``L_j`` profiled out):
where a pair's measured length disagrees with its width, the depth component gives way
before the lateral one does, as far as the pair's own length could vary.

Away from the ray this likelihood has two maxima, mirror images about it (the lateral
component alone cannot tell a body turned 30° one way from 30° the other): the heading is
looked for within ``search_deg`` of the plain direction (:func:`plain_direction`, every
error taken alike), so a noisy depth component can correct it, never throw it to its
mirror image.

The ray is the direction from the camera to the person on the ground: in a camera's own
axes (every monocular estimator's: x right, y down, z forward, ``--up-axis -y``) the camera
is the origin, so it is the mid-hip point's direction. A root-relative stream (mid-hip
point at the origin, as lifting networks and MediaPipe's world landmarks write) has lost
where the person stood, but its error still shows the ray (:func:`noise_rays`): white depth
error makes each joint's frame-to-frame jitter (its second difference, which a body's own
movement hardly moves: 1-2 mm a frame for the trunk turning at 150 °/s) an ellipse whose
long axis is the ray, read over :data:`NOISE_WINDOW_S` from the hips and shoulders. Where
the ellipse is too round to tell (its axes' ratio under :data:`MIN_NOISE_ANISOTROPY`, or
nothing seen), the person is taken as straight ahead. On the synthetic sessions, whose
people stand a median 26° off the camera's axis, the root-relative streams' detected angles
are off the heading planted by 4.7° on average with the ray read from their jitter and by
6.3° taken straight ahead (the positioned streams' by 3.7°). In a world frame (motion
capture) the origin is no camera and the ray means nothing, but the errors are millimetres:
the CMU captures' angles are within 0.9° of the plain direction's.

What the model is worth is measured by ``benchmarks/eval_movement.py``'s variants without it
(``no depth model``, ``no noise rays``), and tested in ``tests/test_detect.py``: on single
walking turns of 90° and 135° under the estimator model, the mean angle error is 2.7°,
positioned or root-relative, against 6.5° for the plain direction and 6.0° for the
root-relative streams taken straight ahead.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType

import numpy as np
from scipy.ndimage import uniform_filter1d

__all__ = [
    "PAIR_LENGTH_CV",
    "camera_rays",
    "noise_rays",
    "plain_direction",
    "ray_weighted_direction",
]

#: How much a pair's length varies in a pose estimator's output, as a share of its width
#: (module docstring: MediaPipe on the real video).
PAIR_LENGTH_CV: Mapping[str, float] = MappingProxyType(
    {"hip": 0.026, "shoulder": 0.058, "knee": 0.40}
)
#: A mid-hip point nearer the origin than this many hip widths is root-relative: its ray is
#: read from its jitter (a camera stands more than a metre from anyone it films whole).
ROOT_RELATIVE_WIDTHS = 2.0
#: Frames over which a root-relative stream's ray is read from its error (seconds), and the
#: share of that window's second differences a frame needs seen to read it. Over 1 s,
#: MediaPipe's nearly round jitter on the real video of ``../shared/data/video`` (its axes'
#: ratio is 1.1-2.0 over the whole clip) passes :data:`MIN_NOISE_ANISOTROPY` by chance in
#: 14% of the frames, and the ray's flicker made a false 50° turn; over 2 s, in 2%. The
#: synthetic sessions' scores are the same over 1 and 2 s, though a person walking 1 m/s
#: past a camera 3 m away moves the ray by up to 20° a second.
NOISE_WINDOW_S = 2.0
NOISE_MIN_SEEN = 0.5
#: The jitter's spread along the ray over its spread across it, under which the ray cannot be
#: told and the person is taken as straight ahead. The estimator model's depth error is 3-6
#: times its lateral one: at 4, a window of :data:`NOISE_WINDOW_S` never reads under 2.5 in
#: 6,000 frames of Gaussian jitter, at 3 it does in 7% of them.
MIN_NOISE_ANISOTROPY = 2.5
#: Newton's steps on the heading, at most, and the largest each may take (radians, 11°).
NEWTON_STEPS = 8
MAX_STEP_RAD = 0.2
#: A frame whose last step was smaller than this (radians, 0.006°) has arrived.
CONVERGED_RAD = 1e-4


def plain_direction(vectors: Sequence[np.ndarray], widths: Sequence[float]) -> np.ndarray:
    """The pairs' unit vectors summed with the square of each pair's width as weight
    (independent joint errors turn a pair by error / width), not normalised: ``(n, 2)``,
    NaN where any pair is. Its direction is the heading with every error taken alike."""
    total = np.zeros((vectors[0].shape[0], 2))
    for v, w in zip(vectors, widths, strict=True):
        length = np.hypot(v[:, 0], v[:, 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            total += w**2 * v / length[:, None]
    return total


def camera_rays(
    mid_hip: np.ndarray,
    hip_width: float,
    jitter_joints: np.ndarray | None = None,
    fps_hz: float = 30.0,
) -> np.ndarray:
    """Unit ground-plane directions ``(n, 2)`` from the camera (the origin) to the mid-hip
    point. Where the point is within :data:`ROOT_RELATIVE_WIDTHS` hip widths of the origin
    (root-relative) or unknown: read from the error of ``jitter_joints`` (``(n, k, 2)``, the
    ground-plane positions of joints that move little of their own accord) by
    :func:`noise_rays`, when given; straight ahead (``+y``, the camera's forward axis after
    ``--up-axis -y``) where that cannot tell."""
    r = np.hypot(mid_hip[:, 0], mid_hip[:, 1])
    far = r > ROOT_RELATIVE_WIDTHS * hip_width  # NaN compares False
    # (an unknown mid-hip point has no heading to correct: only seen frames need the jitter)
    if jitter_joints is not None and (r <= ROOT_RELATIVE_WIDTHS * hip_width).any():
        out = noise_rays(jitter_joints, fps_hz)
    else:
        out = np.zeros(mid_hip.shape, dtype=float)
        out[:, 1] = 1.0
    out[far] = mid_hip[far] / r[far, None]
    return out


def noise_rays(joints: np.ndarray, fps_hz: float) -> np.ndarray:
    """Unit ground-plane ray directions ``(n, 2)`` read from a stream's own error (module
    docstring): the long axis of the directions of the joints' second differences over
    :data:`NOISE_WINDOW_S` around each frame, pointing away from the camera (``+y``); ``+y``
    itself where that axis is not :data:`MIN_NOISE_ANISOTROPY` times the short one, or where
    under :data:`NOISE_MIN_SEEN` of the window's second differences are seen (the stream's
    first and last second, dropouts).

    ``joints`` is ``(n, k, 2)``; a NaN frame is left out of every second difference it
    touches. Each second difference counts by its direction alone (the axes of the sum of
    ``u u^T`` over unit vectors ``u``), so a glitch of a metre counts no more than a
    millimetre's jitter; for Gaussian jitter of spreads ``a > b`` the two axes of that sum
    are in the ratio ``a / b``.
    """
    n = joints.shape[0]
    # per frame, the sums over the joints of u_x^2, u_x u_y and the count of unit vectors u
    # (u_y^2 is the count less u_x^2); frames without a second difference count nothing
    sums = np.zeros((3, n))
    if n > 2:
        d2 = joints[2:] - 2.0 * joints[1:-1] + joints[:-2]
        d2 = np.nan_to_num(d2, nan=0.0, posinf=0.0, neginf=0.0, copy=False)
        x, y = d2[..., 0], d2[..., 1]
        r2 = x * x + y * y
        seen = r2 > 0.0  # NaN (set to 0 above) and an exact standstill say nothing
        with np.errstate(divide="ignore"):
            inv = np.where(seen, 1.0 / r2, 0.0)
        sums[0, 1:-1] = np.einsum("ij,ij,ij->i", x, x, inv)
        sums[1, 1:-1] = np.einsum("ij,ij,ij->i", x, y, inv)
        sums[2, 1:-1] = seen.sum(axis=1)
    window = max(int(round(NOISE_WINDOW_S * fps_hz)), 3)
    # the window's mean of u u^T per frame (the count cancels in the axes' ratio): its axes
    # are count/2 +- half_gap
    sxx, sxy, count = uniform_filter1d(sums, window, axis=1, mode="constant")
    diff = sxx - 0.5 * count  # (sxx - syy) / 2
    half_gap = np.hypot(diff, sxy)
    enough = count >= NOISE_MIN_SEEN * joints.shape[1]  # count: the window's mean
    clear = enough & (0.5 * count + half_gap >= MIN_NOISE_ANISOTROPY * (0.5 * count - half_gap))
    out = np.zeros((n, 2))
    out[:, 1] = 1.0
    theta = 0.5 * np.arctan2(sxy[clear], diff[clear])
    ray = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    ray[ray[:, 1] < 0] *= -1.0  # the camera looks along +y
    out[clear] = ray
    return out


def ray_weighted_direction(
    vectors: Sequence[np.ndarray],
    widths: Sequence[float],
    length_cv: Sequence[float],
    rays: np.ndarray,
    *,
    lateral_sd: float,
    ratio: float,
    search_deg: float,
) -> np.ndarray:
    """Unit headings ``(n, 2)`` (module docstring), NaN where any pair is NaN.

    Parameters
    ----------
    vectors
        Each pair's frontal vectors ``(n, 2)`` (swaps undone).
    widths
        Each pair's width (its median length), in the vectors' unit.
    length_cv
        How much each pair's length varies, as a share of its width
        (:data:`PAIR_LENGTH_CV`).
    rays
        Unit ground-plane directions from the camera to the person ``(n, 2)``
        (:func:`camera_rays`).
    lateral_sd
        The estimator's error across the ray, in the vectors' unit.
    ratio
        Its error along the ray over its error across it; 1 takes both alike.
    search_deg
        How far from :func:`plain_direction` the heading may move, degrees; 0 keeps it.

    In the ray's frame (``a`` across, ``b`` along it, in units of ``lateral_sd``), with
    ``q = 1 / ratio^2``, ``t^2`` the variance of the pair's length and ``e = (c, s)``, a
    pair's cost is ``a^2 + q b^2 + W^2/t^2 - (a c + q b s + W/t^2)^2 / (c^2 + q s^2 + 1/t^2)``
    (its squared error at the best length, plus the length's own). The pairs' sum is
    minimised from the plain direction by Newton's steps (:func:`_newton`).
    """
    plain = plain_direction(vectors, widths)
    lateral = np.stack([rays[:, 1], -rays[:, 0]], axis=1)
    phi0 = np.arctan2(np.einsum("ij,ij->i", plain, rays), np.einsum("ij,ij->i", plain, lateral))
    pairs = []
    ok = np.isfinite(phi0)
    unit = lateral_sd if lateral_sd > 0 else 1.0  # no lateral error: the plain direction
    for v, w, cv in zip(vectors, widths, length_cv, strict=True):
        a = np.einsum("ij,ij->i", v, lateral) / unit
        b = np.einsum("ij,ij->i", v, rays) / unit
        ok &= np.isfinite(a) & np.isfinite(b)
        width = w / unit
        pairs.append((a, b, width, max((width * cv) ** 2, 1e-12)))
    phi = np.full(phi0.shape, np.nan)
    phi[ok] = phi0[ok]
    if search_deg > 0 and lateral_sd > 0 and ok.any():
        found = [(a[ok], b[ok], w, t2) for a, b, w, t2 in pairs]
        phi[ok] = _newton(phi0[ok], found, 1.0 / ratio**2, np.radians(search_deg))
    return np.cos(phi)[:, None] * lateral + np.sin(phi)[:, None] * rays


def _newton(start: np.ndarray, pairs: list, q: float, search: float) -> np.ndarray:
    """The cost's minimum nearest ``start`` within ``search`` radians of it: Newton's steps
    on its analytic derivatives, at most :data:`MAX_STEP_RAD` each (a gradient step of that
    size where the cost curves down), at most :data:`NEWTON_STEPS` of them, each frame's until
    its step is under :data:`CONVERGED_RAD`.

    Per pair, with ``u = a c + q b s + W/t^2`` and ``v = c^2 + q s^2 + 1/t^2``, the cost is
    ``-u^2/v`` plus what does not depend on the heading; ``u'' = -(u - W/t^2)``,
    ``v' = -(1 - q) sin 2phi`` and ``v'' = -2 (1 - q) cos 2phi``.

    The frames still moving are kept packed (their pairs' values gathered once, when some
    arrive, not every step), and each step's sums are written into buffers of their own.
    """
    phi = start.copy()
    k = -2.0 * (1.0 - q)
    moving = None  # which frames ``at`` holds: all of them until one arrives
    at = start
    lo, hi = start - search, start + search
    a_s = [a for a, _, _, _ in pairs]
    qb_s = [q * b for _, b, _, _ in pairs]
    g_h = [(w / t2, 1.0 / t2) for _, _, w, t2 in pairs]
    for _ in range(NEWTON_STEPS):
        c, s = np.cos(at), np.sin(at)
        slope, bend = _slope_and_bend(c, s, a_s, qb_s, g_h, q, k)
        with np.errstate(invalid="ignore", divide="ignore"):
            step = np.where(bend > 0, slope / bend, np.sign(slope) * MAX_STEP_RAD)
        moved = np.clip(at - np.clip(step, -MAX_STEP_RAD, MAX_STEP_RAD), lo, hi)
        if moving is None:
            phi[:] = moved
        else:
            phi[moving] = moved
        going = np.abs(moved - at) > CONVERGED_RAD
        if going.all():
            at = moved
            continue
        if not going.any():
            break
        moving = np.flatnonzero(going) if moving is None else moving[going]
        at, lo, hi = moved[going], lo[going], hi[going]
        a_s = [a[going] for a in a_s]
        qb_s = [qb[going] for qb in qb_s]
    return phi


def _slope_and_bend(
    c: np.ndarray, s: np.ndarray, a_s: list, qb_s: list, g_h: list, q: float, k: float
) -> tuple[np.ndarray, np.ndarray]:
    """The cost's first and second derivatives at ``(c, s)``, summed over the pairs
    (:func:`_newton`), each term as ``slope += uv (uv v' - 2 u')`` and ``bend += -2 (u'^2 +
    u u'') / v + uv (4 u' v' + u v'') / v - 2 uv^2 v'^2 / v`` with ``uv = u / v``: the same
    operations in the same order, done in place."""
    n = c.shape[0]
    cc, ss = c * c, s * s
    dv = c * s
    dv *= k
    ddv = cc - ss
    ddv *= k
    base = ss * q
    base += cc
    slope, bend = np.zeros(n), np.zeros(n)
    u, du, v, uv, t1, t2, t3 = (np.empty(n) for _ in range(7))
    for a, qb, (g, h) in zip(a_s, qb_s, g_h, strict=True):
        np.multiply(a, c, out=u)
        u += np.multiply(qb, s, out=t1)
        u += g
        np.multiply(qb, c, out=du)
        du -= np.multiply(a, s, out=t1)
        np.add(base, h, out=v)
        np.divide(u, v, out=uv)
        np.multiply(uv, dv, out=t1)
        t1 -= np.multiply(du, 2.0, out=t2)
        t1 *= uv
        slope += t1
        np.subtract(g, u, out=t1)
        t1 *= u
        np.multiply(du, du, out=t2)
        t2 += t1
        t2 *= -2.0
        t2 /= v
        np.multiply(du, 4.0, out=t1)
        t1 *= dv
        t1 += np.multiply(u, ddv, out=t3)
        t1 *= uv
        t1 /= v
        t2 += t1
        np.multiply(uv, 2.0, out=t1)
        t1 *= uv
        t1 *= dv
        t1 *= dv
        t1 /= v
        t2 -= t1
        bend += t2
    return slope, bend
