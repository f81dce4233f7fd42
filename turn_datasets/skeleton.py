"""Skeleton layouts, up-axis conversion, and the sequence every reader returns.

Joint indices are named here once, so no other module uses a bare index. Human3.6M's
32-joint layout and the usual 17-joint subset are built in; a reader of another source
(BVH, say) builds its own :class:`Layout` from the joint names it finds.

Every sequence is converted once, at the edge, to the convention of DESIGN.md: z up,
right-handed, so that ``left`` (counter-clockwise seen from above) is increasing yaw.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from turn_datasets.errors import TurnbenchError

__all__ = [
    "Layout",
    "H36M32",
    "H36M17",
    "LAYOUTS",
    "JOINT_PAIRS",
    "UP_AXES",
    "AUTO",
    "UP_AXIS_CHOICES",
    "MocapSequence",
    "get_layout",
    "to_z_up",
]


@dataclass(frozen=True)
class Layout:
    """A named joint layout: joint name -> index into the joint axis."""

    name: str
    n_joints: int
    joints: Mapping[str, int]

    def index(self, joint: str) -> int:
        try:
            return self.joints[joint]
        except KeyError:
            raise TurnbenchError(
                f"layout {self.name!r} has no joint {joint!r}; it has {sorted(self.joints)}"
            ) from None


# Human3.6M's 32-joint skeleton (as in the original release, 3d-pose-baseline and VideoPose3D).
_H36M32_JOINTS = {
    "pelvis": 0,
    "right_hip": 1,
    "right_knee": 2,
    "right_foot": 3,
    "left_hip": 6,
    "left_knee": 7,
    "left_foot": 8,
    "spine": 12,
    "thorax": 13,
    "neck": 14,
    "head": 15,
    "left_shoulder": 17,
    "left_elbow": 18,
    "left_wrist": 19,
    "right_shoulder": 25,
    "right_elbow": 26,
    "right_wrist": 27,
}
#: The 32-joint indices kept by the usual 17-joint subset, in its order.
H36M17_FROM_32 = (0, 1, 2, 3, 6, 7, 8, 12, 13, 14, 15, 17, 18, 19, 25, 26, 27)

H36M32 = Layout("h36m32", 32, MappingProxyType(dict(_H36M32_JOINTS)))
H36M17 = Layout(
    "h36m17",
    17,
    MappingProxyType({name: H36M17_FROM_32.index(i32) for name, i32 in _H36M32_JOINTS.items()}),
)
LAYOUTS: Mapping[str, Layout] = MappingProxyType({"h36m32": H36M32, "h36m17": H36M17})

#: The left/right joint pairs whose frontal vectors the paper uses (equations 1 and 2).
JOINT_PAIRS: Mapping[str, tuple[str, str]] = MappingProxyType(
    {
        "hip": ("left_hip", "right_hip"),
        "knee": ("left_knee", "right_knee"),
        "shoulder": ("left_shoulder", "right_shoulder"),
    }
)

#: The vertical axes a source may state (signed: ``-y`` is a camera's y pointing down).
UP_AXES = ("z", "y", "-y", "x", "-x", "-z")
#: ``--up-axis auto``: infer the axis from the skeleton
#: (:func:`turn_datasets.up_axis.infer_up_axis`), where the source states none.
AUTO = "auto"
#: What ``--up-axis`` accepts.
UP_AXIS_CHOICES = (*UP_AXES, AUTO)

# Each axis's rotation onto z up as (source coordinate, sign) per output coordinate. Only
# permutations and sign changes, so a NaN in one coordinate never spreads to the others and
# values are copied exactly; every one is a proper rotation (determinant +1).
_TO_Z_UP: Mapping[str, tuple[tuple[int, int], ...]] = MappingProxyType(
    {
        "z": ((0, 1), (1, 1), (2, 1)),
        "y": ((0, 1), (2, -1), (1, 1)),
        "-y": ((0, 1), (2, 1), (1, -1)),
        "x": ((2, -1), (1, 1), (0, 1)),
        "-x": ((2, 1), (1, 1), (0, -1)),
        "-z": ((0, 1), (1, -1), (2, -1)),
    }
)


def get_layout(name: str) -> Layout:
    """The built-in layout called ``name`` (``h36m32`` or ``h36m17``)."""
    try:
        return LAYOUTS[name]
    except KeyError:
        raise TurnbenchError(f"unknown layout {name!r}; choose one of {sorted(LAYOUTS)}") from None


def to_z_up(positions: np.ndarray, up_axis: str) -> np.ndarray:
    """Rotate positions ``(..., 3)`` so that ``up_axis`` becomes +z.

    ``z``: already z up (Human3.6M world). ``y``: y up (BVH, many estimators); rotated +90°
    about x, so (x, y, z) -> (x, -z, y). ``-y``: camera frames (x right, y down, z forward);
    rotated -90° about x, so (x, y, z) -> (x, z, -y). ``x``: (x, y, z) -> (-z, y, x) and
    ``-x``: (z, y, -x), rotations of -90° and +90° about y; ``-z``: (x, -y, -z), 180° about
    x. All are proper rotations (determinant +1), so handedness, and with it the meaning of
    left and right, is kept.
    """
    p = np.asarray(positions)
    if p.shape[-1] != 3:
        raise TurnbenchError(f"positions must end in an axis of 3 coordinates, got shape {p.shape}")
    if up_axis == "z":
        return p
    if up_axis not in _TO_Z_UP:
        raise TurnbenchError(f"unknown up axis {up_axis!r}; choose one of {list(UP_AXES)}")
    return np.stack([sign * p[..., src] for src, sign in _TO_Z_UP[up_axis]], axis=-1)


@dataclass
class MocapSequence:
    """One motion-capture sequence, as every reader returns it.

    ``positions`` is ``(n_frames, n_joints, 3)`` float, z up (already converted), in
    ``units`` (``mm`` or ``m``, or the source's own unit name). Frames may hold NaN
    (dropouts). ``subject``/``action``/``subaction`` follow Human3.6M's naming where known;
    other corpora put the file stem in ``action``.
    """

    subject: str
    action: str
    subaction: str
    positions: np.ndarray
    layout: Layout
    fps: float
    units: str = "mm"
    source: str = ""
    meta: dict = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return int(self.positions.shape[0])
