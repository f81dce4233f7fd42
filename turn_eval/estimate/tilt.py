"""Camera tilt: rotate a camera-frame skeleton so that its vertical axis is gravity's.

A pose estimator's 3D output is in the camera's frame: MediaPipe's world landmarks have y
pointing down the image, not down to the floor. From a camera that looks down on the room
(a high corner camera at home), the floor's normal leans away from the image's vertical by
the camera's pitch, and the ground-plane projection of the paper's equations 1 and 2 then
mixes in vertical motion: a hip vector at heading phi, pitched by theta, reads a yaw of
``atan2(sin(phi) cos(theta), cos(phi))`` instead of phi, an error of up to ~4 degrees at
theta = 25 degrees that changes along a turn.

The floor's normal is estimated from the body itself: people stand and walk upright, so the
mean direction of the body's long axis, from the midpoint of the ankles to the thorax, over
the frames where both knees are nearly straight (standing, and mid-stance in walking) points
away from the floor. The skeleton is then rotated by the smallest rotation that takes that
direction onto the file's up axis (scipy's ``Rotation.align_vectors``): a rotation about a
horizontal axis, which adds no yaw of its own. Forward lean while walking biases the
estimate by a few degrees in the walking direction; it cancels over walking back and forth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from turn_datasets.errors import TurnbenchError
from turn_datasets.params import param
from turn_datasets.skeleton import H36M17

__all__ = ["LevelParams", "Levelling", "estimate_up", "level"]

_UP_VECTORS = {
    "z": np.array([0.0, 0.0, 1.0]),
    "y": np.array([0.0, 1.0, 0.0]),
    "-y": np.array([0.0, -1.0, 0.0]),
}


@dataclass(frozen=True)
class LevelParams:
    """Which frames say where the floor is (module docstring)."""

    min_knee_angle_deg: float = param(
        150.0,
        "A frame counts as upright when both knees (hip-knee-ankle angle) are straighter "
        "than this, degrees.",
        min=0.0,
        max=180.0,
    )
    min_upright_frames: int = param(
        10,
        "Fewer upright frames than this and every frame with a body is used instead.",
        min=1,
        max=100_000,
    )


@dataclass(frozen=True)
class Levelling:
    """The rotation applied and how it was found (for the manifest)."""

    tilt_deg: float
    up_estimate: tuple[float, float, float]
    rotvec: tuple[float, float, float]
    n_frames_used: int
    upright_only: bool


def _angle_deg(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    u, v = a - b, c - b
    cos = np.sum(u * v, axis=-1) / (np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def estimate_up(
    positions: np.ndarray, params: LevelParams | None = None
) -> tuple[np.ndarray, int, bool]:
    """Unit "up" of the floor in the skeletons' own frame; frames used; upright frames only?

    ``positions`` is ``(frames, 17, 3)`` in Human3.6M's 17-joint order, NaN where unseen.
    """
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 3 or p.shape[1:] != (H36M17.n_joints, 3):
        raise TurnbenchError(f"skeletons must be (frames, 17, 3), got {tuple(p.shape)}")
    prm = params or LevelParams()
    j = H36M17.index
    axis = p[:, j("thorax")] - (p[:, j("left_foot")] + p[:, j("right_foot")]) / 2.0
    norm = np.linalg.norm(axis, axis=1)
    seen = np.isfinite(norm) & (norm > 0)
    if not seen.any():
        raise TurnbenchError("no frame with a body: the floor cannot be found")
    with np.errstate(invalid="ignore"):
        knees = np.minimum(
            _angle_deg(p[:, j("left_hip")], p[:, j("left_knee")], p[:, j("left_foot")]),
            _angle_deg(p[:, j("right_hip")], p[:, j("right_knee")], p[:, j("right_foot")]),
        )
    upright = seen & (knees > prm.min_knee_angle_deg)
    use = upright if np.count_nonzero(upright) >= prm.min_upright_frames else seen
    mean = (axis[use] / norm[use, None]).mean(axis=0)
    return mean / np.linalg.norm(mean), int(np.count_nonzero(use)), use is upright


def level(
    positions: np.ndarray, *, up_axis: str = "-y", params: LevelParams | None = None
) -> tuple[np.ndarray, Levelling]:
    """``positions`` rotated so that the floor's normal is ``up_axis``, and the rotation.

    Positions rotate about the origin (MediaPipe's: between the hips), so a root-relative
    skeleton stays root-relative; NaN frames stay NaN.
    """
    if up_axis not in _UP_VECTORS:
        raise TurnbenchError(f"unknown up axis {up_axis!r}; choose one of {list(_UP_VECTORS)}")
    up, n_used, upright = estimate_up(positions, params)
    target = _UP_VECTORS[up_axis]
    rotation, _ = Rotation.align_vectors(target[None, :], up[None, :])
    p = np.asarray(positions, dtype=np.float64)
    out = rotation.apply(p.reshape(-1, 3)).reshape(p.shape)
    tilt = float(np.degrees(np.arccos(np.clip(np.dot(up, target), -1.0, 1.0))))
    info = Levelling(
        tilt_deg=round(tilt, 6),
        up_estimate=tuple(np.round(up, 9).tolist()),
        rotvec=tuple(np.round(rotation.as_rotvec(), 9).tolist()),
        n_frames_used=n_used,
        upright_only=upright,
    )
    return out, info
