"""BVH motion capture: parser and forward kinematics into z-up world positions.

A BVH file has a ``HIERARCHY`` (a tree of joints, each with an ``OFFSET`` from its parent and
the ``CHANNELS`` it animates) and a ``MOTION`` block (``Frames: N``, ``Frame Time: dt``, then
one line of numbers per frame, one number per declared channel, in the order the channels are
declared walking the tree depth-first).

Conventions, as the format's authors (Biovision) and its main writers use them:

- Rotation channels are Euler angles in degrees, applied as *intrinsic* rotations in the
  order they are declared: ``Zrotation Yrotation Xrotation`` means ``R = Rz(a) @ Ry(b) @
  Rx(c)`` acting on column vectors, which is ``Rotation.from_euler("ZYX", [a, b, c])`` in
  SciPy (upper-case axes are intrinsic). Each joint's own order is honoured; it may differ
  from joint to joint.
- A joint's world rotation is its parent's world rotation times its local rotation; its
  world position is the parent's world position plus the parent's world rotation applied to
  the joint's offset.
- Position channels (the ROOT's ``Xposition Yposition Zposition``) give the joint's
  translation from its parent directly, in place of its ``OFFSET`` (as Blender's importer
  reads them); a joint without position channels sits at its ``OFFSET``.
- ``End Site`` blocks have an offset and no channels; their positions are computed too and
  named ``<parent>_end``.
- The world frame is y up (BVH's convention); :func:`read_bvh` converts it to the z-up frame
  of DESIGN.md with :func:`turn_datasets.skeleton.to_z_up`.

CMU's BVH conversion (B. Hahne, 2010), of which real examples are test inputs, writes a
T-pose as frame 0 that is not part of the capture: the capture starts at frame 1. Keeping it
matters for turning angles: the T-pose faces +z whatever way the subject faces at frame 1, so
it adds a spurious jump (a false 50° "turn" at the start of 69_01). By default frame 0 is
dropped when it *is* such a rest pose (:func:`first_frame_is_rest_pose`: root orientation
exactly zero, and a jump to frame 1 far larger than any later one).
``skip_first_frame=True`` always drops it, ``False`` always keeps it.

The joints the turning geometry needs are found by name: :data:`CMU_JOINT_MAP` maps our pair
names (``left_hip`` ...) to CMU's joint names and can be overridden per joint.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np
from scipy.spatial.transform import Rotation

from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap.checks import checked_positions
from turn_datasets.skeleton import Layout, MocapSequence, to_z_up

__all__ = [
    "CMU_JOINT_MAP",
    "BvhJoint",
    "BvhMotion",
    "BvhSequence",
    "parse_bvh",
    "forward_kinematics",
    "build_layout",
    "parse_joint_map",
    "read_bvh",
    "fps_from_frame_time",
    "read_bvh_source",
]

#: Our joint names -> CMU's BVH joint names (the 2010 MotionBuilder-friendly conversion).
#: CMU's ``LeftUpLeg``/``RightUpLeg`` are the hip joints (``LHipJoint``/``RHipJoint`` are
#: keyless pelvis links at the root), ``LeftLeg``/``RightLeg`` the knees, ``LeftArm``/
#: ``RightArm`` the shoulders (``LeftShoulder``/``RightShoulder`` are clavicles).
CMU_JOINT_MAP: Mapping[str, str] = MappingProxyType(
    {
        "pelvis": "Hips",
        "left_hip": "LeftUpLeg",
        "right_hip": "RightUpLeg",
        "left_knee": "LeftLeg",
        "right_knee": "RightLeg",
        "left_shoulder": "LeftArm",
        "right_shoulder": "RightArm",
        # the rest of Human3.6M's 17 joints, so that a BVH serves whatever reads that layout
        # by name (the detector's body size, its swap repair): aliased where the file has them
        "left_foot": "LeftFoot",
        "right_foot": "RightFoot",
        "spine": "Spine",
        "thorax": "Spine1",
        "neck": "Neck1",
        "head": "Head",
        "left_elbow": "LeftForeArm",
        "right_elbow": "RightForeArm",
        "left_wrist": "LeftHand",
        "right_wrist": "RightHand",
    }
)
#: Joints that must be found: without the hips there is no turning angle.
REQUIRED_JOINTS = ("left_hip", "right_hip")

_POSITION_CHANNELS = {"xposition": 0, "yposition": 1, "zposition": 2}
_ROTATION_CHANNELS = {"xrotation": "X", "yrotation": "Y", "zrotation": "Z"}


@dataclass
class BvhJoint:
    """One node of the hierarchy (a joint or an End Site)."""

    name: str
    parent: int  # index into BvhMotion.joints, -1 for the root
    offset: np.ndarray  # (3,)
    channels: tuple[str, ...] = ()
    channel_start: int = 0  # column of the first channel in the motion block
    is_end_site: bool = False


@dataclass
class BvhMotion:
    """A parsed BVH file: its hierarchy and its motion block, as stored (y up, file units)."""

    joints: list[BvhJoint]
    motion: np.ndarray  # (n_frames, n_channels)
    frame_time_s: float
    path: str = ""
    meta: dict = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return int(self.motion.shape[0])

    @property
    def fps(self) -> float:
        return fps_from_frame_time(self.frame_time_s)

    @property
    def names(self) -> list[str]:
        return [j.name for j in self.joints]


def fps_from_frame_time(frame_time_s: float) -> float:
    """Frames per second from ``Frame Time``, snapped to a whole number when that is meant.

    Writers print the frame time with a few digits (CMU: ``.0083333`` for 120 fps), so
    ``1 / frame_time`` is off by a few parts per million; within 1e-4 (relative) of a whole
    number it is rounded to it. 29.97 fps (1e-3 from 30) is kept as it is.
    """
    fps = 1.0 / frame_time_s
    nearest = round(fps)
    if nearest > 0 and abs(fps - nearest) <= 1e-4 * nearest:
        return float(nearest)
    return fps


class _Lines:
    """The file's lines as token lists, with their 1-based line numbers, for error messages."""

    def __init__(self, text: str, path: str) -> None:
        self.lines = text.splitlines()
        self.i = 0
        self.path = path

    def next_tokens(self, what: str) -> tuple[list[str], int]:
        while self.i < len(self.lines):
            self.i += 1
            tokens = self.lines[self.i - 1].split()
            if tokens:
                return tokens, self.i
        if not any(line.strip() for line in self.lines):
            raise TurnbenchError("the file is empty", file=self.path)
        raise TurnbenchError(
            f"file ends where {what} was expected (truncated?)", file=self.path, row=self.i
        )

    def fail(self, message: str, lineno: int) -> TurnbenchError:
        return TurnbenchError(message, file=self.path, row=lineno)


def _parse_offset(tokens: list[str], lineno: int, lines: _Lines) -> np.ndarray:
    if len(tokens) != 4 or tokens[0].upper() != "OFFSET":
        raise lines.fail(f"expected 'OFFSET x y z', got {' '.join(tokens)!r}", lineno)
    try:
        return np.array([float(t) for t in tokens[1:]])
    except ValueError:
        raise lines.fail(
            f"OFFSET values are not numbers: {' '.join(tokens[1:])!r}", lineno
        ) from None


def _parse_channels(tokens: list[str], lineno: int, lines: _Lines) -> tuple[str, ...]:
    if len(tokens) < 2 or tokens[0].upper() != "CHANNELS":
        raise lines.fail(f"expected 'CHANNELS n name...', got {' '.join(tokens)!r}", lineno)
    try:
        declared = int(tokens[1])
    except ValueError:
        raise lines.fail(f"channel count {tokens[1]!r} is not a whole number", lineno) from None
    names = tokens[2:]
    if declared != len(names):
        raise lines.fail(
            f"CHANNELS declares {declared} channels but names {len(names)}: {' '.join(names)}",
            lineno,
        )
    for name in names:
        if name.lower() not in _POSITION_CHANNELS and name.lower() not in _ROTATION_CHANNELS:
            raise lines.fail(
                f"unknown channel {name!r} (expected X/Y/Z position or rotation)", lineno
            )
    if len({n.lower() for n in names}) != len(names):
        raise lines.fail(f"a channel is declared twice: {' '.join(names)}", lineno)
    return tuple(names)


def _parse_joint(
    lines: _Lines, name: str, parent: int, joints: list[BvhJoint], n_channels: int, is_end: bool
) -> int:
    """Parse one ``{ ... }`` block (the name line already read); return the channel count."""
    tokens, lineno = lines.next_tokens("'{'")
    if tokens != ["{"]:
        raise lines.fail(f"expected '{{' after the joint name, got {' '.join(tokens)!r}", lineno)
    tokens, lineno = lines.next_tokens("OFFSET")
    offset = _parse_offset(tokens, lineno, lines)
    index = len(joints)
    joint = BvhJoint(name=name, parent=parent, offset=offset, is_end_site=is_end)
    joints.append(joint)
    if not is_end:
        tokens, lineno = lines.next_tokens("CHANNELS")
        joint.channels = _parse_channels(tokens, lineno, lines)
        joint.channel_start = n_channels
        n_channels += len(joint.channels)
    while True:
        tokens, lineno = lines.next_tokens("'}'")
        keyword = tokens[0].upper()
        if keyword == "}":
            return n_channels
        if is_end:
            raise lines.fail(f"an End Site holds only an OFFSET, got {' '.join(tokens)!r}", lineno)
        if keyword == "JOINT":
            if len(tokens) < 2:
                raise lines.fail("JOINT without a name", lineno)
            n_channels = _parse_joint(
                lines, " ".join(tokens[1:]), index, joints, n_channels, is_end=False
            )
        elif keyword == "END" and len(tokens) == 2 and tokens[1].upper() == "SITE":
            n_channels = _parse_joint(lines, f"{name}_end", index, joints, n_channels, is_end=True)
        else:
            raise lines.fail(
                f"expected JOINT, End Site or '}}' inside joint {name!r}, got {' '.join(tokens)!r}",
                lineno,
            )


def parse_bvh(path: str | os.PathLike[str]) -> BvhMotion:
    """Parse a BVH file into its hierarchy and motion block (no kinematics yet).

    Raises
    ------
    TurnbenchError
        Naming the file and the line: a missing section, a malformed ``OFFSET`` or
        ``CHANNELS`` line (a count that disagrees with the names, an unknown channel),
        unbalanced braces, a motion line with the wrong number of values or a value that is
        not a number, fewer or more motion lines than ``Frames:`` says, a frame time that is
        not positive, duplicate joint names.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise TurnbenchError(f"cannot read the file: {exc.strerror or exc}", file=p) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    lines = _Lines(text, str(p))
    tokens, lineno = lines.next_tokens("HIERARCHY")
    if tokens[0].upper() != "HIERARCHY":
        raise lines.fail(f"not a BVH file: expected 'HIERARCHY', got {' '.join(tokens)!r}", lineno)
    tokens, lineno = lines.next_tokens("ROOT")
    if tokens[0].upper() != "ROOT" or len(tokens) < 2:
        raise lines.fail(f"expected 'ROOT name', got {' '.join(tokens)!r}", lineno)
    joints: list[BvhJoint] = []
    n_channels = _parse_joint(lines, " ".join(tokens[1:]), -1, joints, 0, is_end=False)

    tokens, lineno = lines.next_tokens("MOTION")
    if tokens[0].upper() == "ROOT":
        raise lines.fail("more than one ROOT: only single-skeleton BVH files are read", lineno)
    if tokens[0].upper() != "MOTION":
        raise lines.fail(f"expected 'MOTION' after the hierarchy, got {' '.join(tokens)!r}", lineno)
    tokens, lineno = lines.next_tokens("'Frames: N'")
    if len(tokens) != 2 or tokens[0].lower() != "frames:":
        raise lines.fail(f"expected 'Frames: N', got {' '.join(tokens)!r}", lineno)
    try:
        n_frames = int(tokens[1])
    except ValueError:
        raise lines.fail(f"frame count {tokens[1]!r} is not a whole number", lineno) from None
    if n_frames < 1:
        raise lines.fail(f"frame count is {n_frames}: no motion", lineno)
    tokens, lineno = lines.next_tokens("'Frame Time: dt'")
    if len(tokens) != 3 or [t.lower() for t in tokens[:2]] != ["frame", "time:"]:
        raise lines.fail(f"expected 'Frame Time: seconds', got {' '.join(tokens)!r}", lineno)
    try:
        frame_time_s = float(tokens[2])
    except ValueError:
        raise lines.fail(f"frame time {tokens[2]!r} is not a number", lineno) from None
    if not (np.isfinite(frame_time_s) and frame_time_s > 0):
        raise lines.fail(f"frame time must be positive, got {tokens[2]}", lineno)

    names = [j.name for j in joints]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise TurnbenchError(f"joint names are not unique: {', '.join(dupes)}", file=p)

    motion = np.empty((n_frames, n_channels))
    frame = 0
    for lineno in range(lines.i + 1, len(lines.lines) + 1):
        values = lines.lines[lineno - 1].split()
        if not values:
            continue
        if frame == n_frames:
            raise lines.fail(f"more motion lines than 'Frames: {n_frames}' says", lineno)
        if len(values) != n_channels:
            raise lines.fail(
                f"motion line has {len(values)} values, the hierarchy declares {n_channels} "
                "channels (truncated or corrupt line?)",
                lineno,
            )
        try:
            motion[frame] = [float(v) for v in values]
        except ValueError:
            bad = next(v for v in values if not _is_float(v))
            raise lines.fail(f"motion value {bad!r} is not a number", lineno) from None
        frame += 1
    if frame < n_frames:
        raise TurnbenchError(
            f"only {frame} motion lines but 'Frames: {n_frames}' (truncated file?)",
            file=p,
            row=len(lines.lines),
        )
    if not np.isfinite(motion).all():
        raise TurnbenchError("motion block holds non-finite values (nan or inf)", file=p)
    return BvhMotion(joints=joints, motion=motion, frame_time_s=frame_time_s, path=str(p))


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def forward_kinematics(bvh: BvhMotion) -> np.ndarray:
    """World positions of every joint and End Site, ``(n_frames, n_nodes, 3)``, y up, file units.

    Vectorised over frames with :class:`scipy.spatial.transform.Rotation`; each joint's
    rotation channels form an intrinsic Euler sequence in their declared order (module
    docstring).
    """
    n = bvh.n_frames
    positions = np.empty((n, len(bvh.joints), 3))
    rotations: list[Rotation] = []
    for index, joint in enumerate(bvh.joints):
        local_t = np.broadcast_to(joint.offset, (n, 3)).copy()
        axes, columns = [], []
        has_position = False
        for k, channel in enumerate(joint.channels):
            column = bvh.motion[:, joint.channel_start + k]
            key = channel.lower()
            if key in _POSITION_CHANNELS:
                if not has_position:
                    # position channels replace the offset (module docstring)
                    local_t[:] = 0.0
                    has_position = True
                local_t[:, _POSITION_CHANNELS[key]] = column
            else:
                axes.append(_ROTATION_CHANNELS[key])
                columns.append(column)
        if axes:
            local_r = Rotation.from_euler("".join(axes), np.stack(columns, axis=1), degrees=True)
        else:
            local_r = Rotation.identity(n)
        if joint.parent < 0:
            positions[:, index] = local_t
            rotations.append(local_r)
        else:
            parent_r = rotations[joint.parent]
            positions[:, index] = positions[:, joint.parent] + parent_r.apply(local_t)
            rotations.append(parent_r * local_r)
    return positions


def parse_joint_map(text: str) -> dict[str, str]:
    """``"left_hip=LHip,right_hip=RHip"`` -> ``{"left_hip": "LHip", "right_hip": "RHip"}``.

    For a command-line option; keys are our joint names (those of :data:`CMU_JOINT_MAP`).
    """
    out: dict[str, str] = {}
    for item in text.split(","):
        if not item.strip():
            continue
        ours, sep, theirs = item.partition("=")
        if not sep or not ours.strip() or not theirs.strip():
            raise TurnbenchError(f"joint map entry {item.strip()!r} is not 'our_name=BvhJointName'")
        out[ours.strip()] = theirs.strip()
    return out


def build_layout(
    bvh: BvhMotion, *, joint_map: Mapping[str, str] | None = None, name: str = "bvh"
) -> Layout:
    """A :class:`Layout` over the BVH's nodes, plus our names (``left_hip`` ...) as aliases.

    Parameters
    ----------
    joint_map
        Our name -> BVH joint name; entries replace those of :data:`CMU_JOINT_MAP`. Every
        entry given here must name a joint of the file; of the built-in ones, the hips must
        be found (without them there is no turning angle), the knees and shoulders are
        aliased where the file has them.
    """
    index = {j.name: i for i, j in enumerate(bvh.joints)}
    user = dict(joint_map or {})
    unknown_ours = sorted(set(user) - set(CMU_JOINT_MAP))
    if unknown_ours:
        raise TurnbenchError(
            f"joint map names {unknown_ours}, which are not ours; use any of "
            f"{', '.join(CMU_JOINT_MAP)}",
            file=bvh.path or None,
        )
    joints: dict[str, int] = dict(index)
    for ours, default in CMU_JOINT_MAP.items():
        theirs = user.get(ours, default)
        if theirs in index:
            joints[ours] = index[theirs]
        elif ours in user or ours in REQUIRED_JOINTS:
            raise TurnbenchError(
                f"no joint {theirs!r} (for {ours}) in the BVH hierarchy; its joints are "
                f"{', '.join(j.name for j in bvh.joints if not j.is_end_site)}",
                file=bvh.path or None,
                hint=f"map it with a joint map such as {ours}=<joint name>",
            )
    return Layout(name, len(bvh.joints), MappingProxyType(joints))


def first_frame_is_rest_pose(bvh: BvhMotion, *, jump_ratio: float = 2.0) -> bool:
    """True when frame 0 is a rest pose added by a conversion, not captured motion.

    Two signs together: the ROOT's rotation channels are all exactly zero in frame 0 (a real
    capture never prints an exactly zero orientation on all three axes), and frame 0 is a
    discontinuity: its largest rotation change to frame 1 is more than ``jump_ratio`` times
    the 99th percentile of the later frame-to-frame changes. On CMU's five test captures the
    T-pose jump is 79.7 to 82.6 degrees against a later 99th percentile of 6.1 to 25.4
    degrees; a file that merely starts at zero orientation and moves smoothly is kept.
    """
    root = bvh.joints[0]
    root_cols = [
        root.channel_start + k
        for k, c in enumerate(root.channels)
        if c.lower().endswith("rotation")
    ]
    if bvh.n_frames < 3 or not root_cols or np.any(bvh.motion[0, root_cols] != 0.0):
        return False
    cols = [
        j.channel_start + k
        for j in bvh.joints
        for k, c in enumerate(j.channels)
        if c.lower().endswith("rotation")
    ]
    step = np.abs(np.diff(bvh.motion[:, cols], axis=0))
    step = np.minimum(step, 360.0 - step).max(axis=1)  # angles wrap at 360
    return bool(step[0] > jump_ratio * np.percentile(step[1:], 99))


@dataclass
class BvhSequence:
    """What :func:`read_bvh` returns: z-up positions and what is known about them."""

    positions: np.ndarray  # (n_frames, n_nodes, 3), z up, file units
    layout: Layout
    fps: float
    n_frames_in_file: int
    skipped_first_frame: bool


def read_bvh(
    path: str | os.PathLike[str],
    *,
    joint_map: Mapping[str, str] | None = None,
    skip_first_frame: bool | None = None,
) -> BvhSequence:
    """Parse a BVH file and return z-up world positions of every joint and End Site.

    Parameters
    ----------
    joint_map
        Overrides of :data:`CMU_JOINT_MAP` (our name -> BVH joint name).
    skip_first_frame
        Drop frame 0 (CMU's conversion writes a T-pose there; the capture starts at frame 1).
        ``None`` (default): drop it only if it is a rest pose (:func:`first_frame_is_rest_pose`).

    Returns
    -------
    BvhSequence
        Positions converted from BVH's y up to z up with :func:`to_z_up` (a proper rotation,
        so left stays left), fps from ``Frame Time``.
    """
    bvh = parse_bvh(path)
    layout = build_layout(bvh, joint_map=joint_map)
    if skip_first_frame is None:
        skip_first_frame = first_frame_is_rest_pose(bvh)
    if skip_first_frame and bvh.n_frames < 2:
        raise TurnbenchError("only one frame: nothing left after skipping frame 0", file=bvh.path)
    positions = to_z_up(forward_kinematics(bvh), "y")
    if skip_first_frame:
        positions = positions[1:]
    return BvhSequence(
        positions=np.ascontiguousarray(positions, dtype=np.float64),
        layout=layout,
        fps=bvh.fps,
        n_frames_in_file=bvh.n_frames,
        skipped_first_frame=skip_first_frame,
    )


def read_bvh_source(
    path: Path,
    *,
    units: str | None,
    joint_map: Mapping[str, str] | None,
    skip_first_frame: bool | None,
) -> Iterator[MocapSequence]:
    seq = read_bvh(path, joint_map=joint_map, skip_first_frame=skip_first_frame)
    yield MocapSequence(
        subject=path.absolute().parent.name,
        action=path.stem,
        subaction="",
        positions=checked_positions(seq.positions, seq.layout, path=path, item=None),
        layout=seq.layout,
        fps=seq.fps,
        # BVH does not state its unit: the label is the user's, or "bvh" (the file's own)
        units=units or "bvh",
        source=str(path),
        meta={
            "format": "bvh",
            "n_frames_in_file": seq.n_frames_in_file,
            "skipped_first_frame": seq.skipped_first_frame,
        },
    )
