"""Degrade reference skeletons the way a monocular 3D pose estimator does.

The paper runs its turning-angle estimator on 3D skeletons lifted from one camera's video
(Fastpose for the 2D joints, Strided Transformer to lift them to 3D, on the Human3.6M videos
and on the REMAP home videos). Such skeletons differ from motion capture in three ways that
matter for a turning angle, and this module plants each of them, seeded, with its size as a
parameter:

Joint noise
    Every joint jitters independently from frame to frame: Gaussian, ``joint_noise_mm``
    standard deviation per coordinate. A lifting network that sees a window of frames
    (as Strided Transformer does) jitters little, half a millimetre by default. The paper's
    equation 3 (``--method paper``) adds up every wiggle of the hip vector, but at this size
    the jitter is not what inflates it: on the demo's Turn-H3.6M-like clips equation 3's MAE
    is 19.3° with the defaults, 19.1° without jitter and 10.9° without the depth error below
    (the rest is the captured gait sway); the net rotation's is 13.9°, 13.9° and 0.6°.
Depth error along the camera ray
    One camera cannot see depth; the estimator guesses it. Each joint is displaced along
    the ray from the camera to it by an error whose standard deviation grows linearly with
    the angle between the way the body faces and the direction of the camera (on the
    ground plane): ``depth_sd_facing_mm`` when the person faces the camera (0°),
    ``depth_sd_away_mm`` with the back to it (180°). When the body is turned, the hips
    are where the estimator is least sure: exactly where a turning angle is measured.
    The error drifts smoothly (a Gaussian filter of ``depth_smooth_s``), as a network's
    guesses do from one frame to the next, rescaled so its standard deviation stays the
    planted one. It is independent per joint, so it rotates the hip vector: with hips
    264 mm apart (Human3.6M) the defaults (20 mm facing, 80 mm away) turn it by about 6°
    and 23° (one standard deviation). On the demo corpus the net-rotation estimator then
    scores about 72% accuracy and 14° MAE on the Turn-H3.6M-like clips and 72% and 17° on
    the Turn-REMAP-like ones: errors of a monocular estimator's kind and size, not a model
    of any one network. (The paper reports 41.6% accuracy and 34.7° MAE on the real
    Turn-REMAP videos, whose clothing, lighting and occlusion no synthetic skeleton has.)
Occlusion dropouts
    Whole frames the estimator fails on (a person behind furniture, out of view) become
    NaN. Dropouts start at ``dropout_rate_per_s`` per second of video on average, each
    lasting ``dropout_mean_s`` on average (geometric in frames), never over the first or
    last frame so a clip keeps its boundaries.

The body's facing comes from the hip vector of the *reference* skeleton (geometry's
:func:`~turn_datasets.geometry.frame_yaw_deg`: facing is the left-minus-right yaw minus 90°).
Positions are ``(n_frames, n_joints, 3)``, z up, in millimetres unless ``mm_per_unit`` says
otherwise (VideoPose3D stores metres: ``mm_per_unit=1000``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import frame_yaw_deg
from turn_datasets.skeleton import H36M17_FROM_32, H36M32, Layout

__all__ = ["Degraded", "degrade_skeleton", "facing_to_camera_deg", "to_h36m17"]


@dataclass(frozen=True)
class Degraded:
    """The result of :func:`degrade_skeleton`.

    ``positions`` are the degraded skeletons (same shape and units as the input, NaN on
    dropped frames); ``facing_to_camera_deg`` the per-frame angle (0° to 180°) between the
    body's facing and the camera direction; ``depth_sd_mm`` the depth-error standard
    deviation planted on each frame; ``dropped`` the mask of frames set to NaN.
    """

    positions: np.ndarray
    facing_to_camera_deg: np.ndarray
    depth_sd_mm: np.ndarray
    dropped: np.ndarray


def to_h36m17(positions: np.ndarray) -> np.ndarray:
    """The usual 17-joint subset of a 32-joint Human3.6M skeleton (what estimators output)."""
    p = np.asarray(positions)
    if p.ndim != 3 or p.shape[1] != H36M32.n_joints:
        raise TurnbenchError(f"expected (frames, 32, 3) positions, got shape {p.shape}")
    return p[:, list(H36M17_FROM_32), :]


def facing_to_camera_deg(
    positions: np.ndarray,
    layout: Layout,
    *,
    camera_position_mm: Sequence[float],
    mm_per_unit: float = 1.0,
) -> np.ndarray:
    """Per-frame angle (degrees, 0 to 180) between the body's facing and the camera direction.

    Both directions are taken on the ground plane: the facing is the hip vector's yaw minus
    90° (left minus right points to the person's left; z up); the camera direction is from
    the pelvis (mid-hip) to the camera. Frames whose hips are missing take the facing of the
    nearest usable frames (linear in unwrapped yaw), so that a dropout in the reference does
    not stop the degradation.
    """
    p = np.asarray(positions, dtype=float)
    yaw = frame_yaw_deg(p, layout, ("hip",))
    ok = np.isfinite(yaw)
    if ok.sum() < 1:
        raise TurnbenchError("no frame has both hips: the facing cannot be known")
    frames = np.arange(p.shape[0])
    yaw = np.interp(frames, frames[ok], yaw[ok])
    facing = np.radians(yaw - 90.0)
    hips = p[:, [layout.index("left_hip"), layout.index("right_hip")], :2].mean(axis=1)
    hips = hips * mm_per_unit
    for axis in range(2):
        good = np.isfinite(hips[:, axis])
        hips[:, axis] = np.interp(frames, frames[good], hips[good, axis]) if good.any() else 0.0
    cam = np.asarray(camera_position_mm, dtype=float)
    to_cam = cam[:2][None, :] - hips
    cam_dir = np.arctan2(to_cam[:, 1], to_cam[:, 0])
    diff = np.angle(np.exp(1j * (cam_dir - facing)))
    return np.degrees(np.abs(diff))


def _unit_smooth_noise(
    rng: np.random.Generator, shape: tuple[int, ...], sigma_frames: float
) -> np.ndarray:
    """Standard normal noise smoothed along axis 0, rescaled to unit standard deviation.

    A Gaussian filter with weights ``w`` shrinks white noise's variance to ``sum(w**2)``;
    dividing by its square root restores unit variance while keeping the smoothness.
    """
    white = rng.standard_normal(shape)
    if sigma_frames <= 0:
        return white
    smooth = gaussian_filter1d(white, sigma_frames, axis=0, mode="reflect")
    radius = int(4.0 * sigma_frames + 0.5)
    x = np.arange(-radius, radius + 1)
    w = np.exp(-0.5 * (x / sigma_frames) ** 2)
    w /= w.sum()
    return smooth / np.sqrt(np.sum(w**2))


def _dropout_mask(
    rng: np.random.Generator,
    n_frames: int,
    *,
    fps: float,
    rate_per_s: float,
    mean_s: float,
    keep_frames: Sequence[int] | np.ndarray,
) -> np.ndarray:
    mask = np.zeros(n_frames, dtype=bool)
    if rate_per_s <= 0 or n_frames < 3:
        return mask
    p_start = min(1.0, rate_per_s / fps)
    mean_frames = max(1.0, mean_s * fps)
    starts = np.flatnonzero(rng.random(n_frames) < p_start)
    lengths = rng.geometric(1.0 / mean_frames, size=starts.size)
    for start, length in zip(starts, lengths, strict=True):
        mask[start : start + length] = True
    # The first and last frames stay: a clip's boundaries are where its angle is measured from.
    mask[0] = mask[-1] = False
    mask[np.asarray(keep_frames, dtype=np.int64)] = False
    return mask


def degrade_skeleton(
    positions: np.ndarray,
    layout: Layout,
    *,
    seed: int | np.random.Generator,
    fps: float = 50.0,
    camera_position_mm: Sequence[float] = (0.0, -4500.0, 1500.0),
    joint_noise_mm: float = 0.5,
    depth_sd_facing_mm: float = 20.0,
    depth_sd_away_mm: float = 80.0,
    depth_smooth_s: float = 0.3,
    white_depth_sd_mm: float = 0.0,
    dropout_rate_per_s: float = 0.05,
    dropout_mean_s: float = 0.2,
    mm_per_unit: float = 1.0,
    keep_frames: Sequence[int] = (),
) -> Degraded:
    """Degrade reference skeletons as a monocular estimator would (see the module docstring).

    Parameters
    ----------
    positions
        ``(n_frames, n_joints, 3)`` reference positions, z up; NaN frames stay NaN.
    layout
        Their joint layout (the hips give the facing).
    seed
        Seed or generator: the same seed gives the same degraded skeletons.
    fps
        Frame rate, for the dropout rate and the smoothing of the depth error.
    camera_position_mm
        Where the one camera is, in the positions' world frame (millimetres).
    joint_noise_mm
        Standard deviation of the independent per-joint, per-frame, per-coordinate noise.
    depth_sd_facing_mm, depth_sd_away_mm
        Standard deviation of the depth error along each joint's camera ray when the body
        faces the camera and when it faces away; linear in the angle in between.
    depth_smooth_s
        Standard deviation (seconds) of the Gaussian filter that makes the depth error drift.
    white_depth_sd_mm
        Standard deviation of a second depth error along each joint's ray, independent from
        joint to joint and frame to frame (white), facing the camera; twice that with the
        back to it. A single-frame lifter's error is 40-60 mm per joint on Human3.6M
        (MPJPE: Pavllo et al. 2019, VideoPose3D, 46.8 mm; Zheng et al. 2021, PoseFormer,
        44.3 mm), much of it along the camera ray and not smooth in time; 0 leaves it out
        (and draws no random numbers for it).
    dropout_rate_per_s, dropout_mean_s
        How often a dropout starts (per second) and how long it lasts on average (seconds).
    mm_per_unit
        Millimetres per unit of ``positions`` (1 for Human3.6M, 1000 for metres).
    keep_frames
        Frames never dropped: when one long sequence is degraded and then cut into clips,
        each clip's first and last frame, so no clip is lost whole (a clip without two
        usable frames has no angle at all).
    """
    p = np.asarray(positions, dtype=float)
    if p.ndim != 3 or p.shape[2] != 3 or p.shape[1] != layout.n_joints:
        raise TurnbenchError(
            f"positions must be (frames, {layout.n_joints}, 3) for layout {layout.name!r}, "
            f"got shape {p.shape}"
        )
    for name, value in (
        ("fps", fps),
        ("mm_per_unit", mm_per_unit),
    ):
        if not value > 0:
            raise TurnbenchError(f"{name} must be positive, got {value}")
    for name, value in (
        ("joint_noise_mm", joint_noise_mm),
        ("depth_sd_facing_mm", depth_sd_facing_mm),
        ("depth_sd_away_mm", depth_sd_away_mm),
        ("depth_smooth_s", depth_smooth_s),
        ("white_depth_sd_mm", white_depth_sd_mm),
        ("dropout_rate_per_s", dropout_rate_per_s),
        ("dropout_mean_s", dropout_mean_s),
    ):
        if not value >= 0:
            raise TurnbenchError(f"{name} must not be negative, got {value}")
    n_frames, n_joints, _ = p.shape
    keep = np.asarray(keep_frames, dtype=np.int64).reshape(-1)
    if keep.size and (keep.min() < 0 or keep.max() >= n_frames):
        raise TurnbenchError(f"keep_frames must lie in 0..{n_frames - 1}")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    theta = facing_to_camera_deg(
        p, layout, camera_position_mm=camera_position_mm, mm_per_unit=mm_per_unit
    )
    depth_sd = depth_sd_facing_mm + (depth_sd_away_mm - depth_sd_facing_mm) * theta / 180.0

    mm = p * mm_per_unit
    cam = np.asarray(camera_position_mm, dtype=float)
    rays = mm - cam[None, None, :]
    norms = np.linalg.norm(rays, axis=2, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        rays = rays / norms
    depth = _unit_smooth_noise(rng, (n_frames, n_joints), depth_smooth_s * fps) * depth_sd[:, None]
    jitter = rng.standard_normal((n_frames, n_joints, 3)) * joint_noise_mm
    if white_depth_sd_mm > 0:
        white_sd = white_depth_sd_mm * (1.0 + theta / 180.0)
        depth = depth + rng.standard_normal((n_frames, n_joints)) * white_sd[:, None]
    out_mm = mm + rays * depth[:, :, None] + jitter
    dropped = _dropout_mask(
        rng,
        n_frames,
        fps=fps,
        rate_per_s=dropout_rate_per_s,
        mean_s=dropout_mean_s,
        keep_frames=keep,
    )
    out_mm[dropped] = np.nan
    return Degraded(
        positions=out_mm / mm_per_unit,
        facing_to_camera_deg=theta,
        depth_sd_mm=depth_sd,
        dropped=dropped,
    )
