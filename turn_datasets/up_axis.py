"""The vertical axis of a skeleton, stated or inferred (``--up-axis auto``).

Where a source does not state its axes (generic arrays, the REMAP Open release, whose 3D
axes and units are undocumented), the axis is read from the body itself:

1. **Which axis.** The trunk, pelvis to neck, is the body's longest segment that stays
   close to vertical while a person walks or turns. Its mean absolute component along each
   of the three axes is computed over the frames; the axis with the largest is the vertical
   one, provided it exceeds the next largest by ``min_dominance`` (1.5: a trunk leaning, on
   average, less than atan(1/1.5) = 33.7° from that axis towards another).
2. **Which way.** The head is above the feet: the sign of head minus the feet's midpoint
   along that axis, which must agree, together with neck minus pelvis, in at least
   ``min_agreement`` of the frames (0.9).

Anything else is refused, one line naming the clip: a trunk not clearly along one axis (a
person lying across the axes, a degenerate skeleton), a head on both sides of the feet, no
frame with the five joints seen, or 2D keypoints (nothing to infer: lift to 3D first).
Units do not matter: only ratios and signs are used. Shape alone cannot tell a person
standing in a frame turned by 90° from one lying along an axis; a clip of someone lying
still along one axis is read with that axis up, and the axis found is always said (stderr
and the output's manifest) so that the reader can see it.

The camera-frame convention of lifting networks (Strided Transformer, VideoPose3D,
MotionBERT, MediaPipe world: x right, y down) gives ``-y``; Human3.6M's world gives ``z``;
BVH gives ``y``.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.params import check_params, param
from turn_datasets.skeleton import AUTO, UP_AXES, Layout, to_z_up

__all__ = [
    "UpAxisParams",
    "UpAxisFound",
    "AxesFound",
    "infer_up_axis",
    "resolve_up_axis",
    "z_up_arrays",
]

_AXIS_NAMES = ("x", "y", "z")


@dataclass(frozen=True)
class UpAxisParams:
    """How clear the skeleton's answer must be for ``--up-axis auto``."""

    min_dominance: float = param(
        1.5,
        "The trunk's mean absolute extent along the vertical axis over its next largest "
        "(1.5: a mean lean below 33.7°).",
        min=1.0,
        min_open=True,
    )
    min_agreement: float = param(
        0.9,
        "Fraction of frames in which the head is above the feet (and the neck above the "
        "pelvis) along the axis found.",
        min=0.5,
        min_open=True,
    )

    def __post_init__(self) -> None:
        check_params(self)
        if self.min_agreement > 1:
            raise TurnbenchError(f"min_agreement must be at most 1, got {self.min_agreement}")


@dataclass(frozen=True)
class UpAxisFound:
    """The inferred vertical axis of one skeleton and the evidence for it.

    Attributes
    ----------
    axis
        ``x``, ``y``, ``z``, ``-x``, ``-y`` or ``-z``.
    dominance
        The trunk's mean absolute extent along ``axis`` over the next largest.
    agreement
        Fraction of the usable frames whose head is above the feet along ``axis``.
    n_frames
        Frames with the pelvis, neck, head and both feet seen.
    """

    axis: str
    dominance: float
    agreement: float
    n_frames: int


def _trunk_joints(layout: Layout) -> tuple[int, int, int, int, int]:
    neck = "neck" if "neck" in layout.joints else "thorax"
    return (
        layout.index("pelvis"),
        layout.index(neck),
        layout.index("head"),
        layout.index("left_foot"),
        layout.index("right_foot"),
    )


def infer_up_axis(
    positions: np.ndarray,
    layout: Layout,
    *,
    params: UpAxisParams | None = None,
    item: str | None = None,
) -> UpAxisFound:
    """The vertical axis of ``positions``, read from the trunk and the head above the feet.

    Parameters
    ----------
    positions
        ``(n_frames, n_joints, 3)`` in any unit; frames with a needed joint missing (NaN)
        are left out.
    layout
        The joint layout (it must name ``pelvis``, ``neck`` or ``thorax``, ``head`` and
        both feet: Human3.6M's 17 and 32 joints do).
    params
        The clarity thresholds (:class:`UpAxisParams`).
    item
        The clip's name, for the error.

    Raises
    ------
    TurnbenchError
        2D keypoints, no usable frame, a trunk not clearly along one axis, or a head not
        consistently on one side of the feet (the module docstring gives the rule).
    """
    prm = params or UpAxisParams()
    p = np.asarray(positions)
    if p.ndim == 3 and p.shape[-1] == 2:
        raise TurnbenchError(
            "2D keypoints have no vertical axis to infer", item=item, hint="lift to 3D first"
        )
    if p.ndim != 3 or p.shape[-1] != 3:
        raise TurnbenchError(
            f"positions have shape {p.shape}, expected (frames, joints, 3)", item=item
        )
    # only the five joints, widened to float64: a long stream is not copied whole
    pelvis, neck, head, lfoot, rfoot = (p[:, j].astype(np.float64) for j in _trunk_joints(layout))
    trunk = neck - pelvis
    head_over_feet = head - 0.5 * (lfoot + rfoot)
    usable = np.isfinite(trunk).all(axis=1) & np.isfinite(head_over_feet).all(axis=1)
    n = int(usable.sum())
    if n == 0:
        raise TurnbenchError(
            "no frame shows the pelvis, neck, head and both feet, so the vertical axis "
            "cannot be inferred",
            item=item,
            hint="state it with --up-axis",
        )
    extent = np.abs(trunk[usable]).mean(axis=0)
    order = np.argsort(extent)[::-1]
    top, second = extent[order[0]], extent[order[1]]
    dominance = float(top / second) if second > 0 else float("inf")
    if not top > 0 or dominance < prm.min_dominance:
        raise TurnbenchError(
            f"the trunk is not clearly along one axis (mean extent x {extent[0]:.3g}, "
            f"y {extent[1]:.3g}, z {extent[2]:.3g}; the largest must be "
            f"{prm.min_dominance:g} times the next), so the vertical axis is unclear",
            item=item,
            hint="a lying or bent-over person, or not a skeleton; state it with --up-axis",
        )
    k = int(order[0])
    up = (head_over_feet[usable, k] > 0) & (trunk[usable, k] > 0)
    down = (head_over_feet[usable, k] < 0) & (trunk[usable, k] < 0)
    frac_up, frac_down = float(up.mean()), float(down.mean())
    if max(frac_up, frac_down) < prm.min_agreement:
        raise TurnbenchError(
            f"the head is above the feet along +{_AXIS_NAMES[k]} in {frac_up:.0%} of the "
            f"frames and along -{_AXIS_NAMES[k]} in {frac_down:.0%} (needs "
            f"{prm.min_agreement:.0%}), so the vertical axis is unclear",
            item=item,
            hint="state it with --up-axis",
        )
    sign = "" if frac_up >= frac_down else "-"
    return UpAxisFound(
        axis=f"{sign}{_AXIS_NAMES[k]}",
        dominance=dominance,
        agreement=max(frac_up, frac_down),
        n_frames=n,
    )


@dataclass
class AxesFound:
    """Which vertical axis each array was read with, to say on stderr and in a manifest.

    ``option`` is what was asked (an axis, or ``auto``); :meth:`record` counts the axis used
    for each array, and the first array read with each.
    """

    option: str
    counts: Counter[str] = field(default_factory=Counter)
    first: dict[str, str] = field(default_factory=dict)

    def record(self, key: str, axis: str) -> None:
        self.counts[axis] += 1
        self.first.setdefault(axis, key)

    @property
    def inferred(self) -> bool:
        return self.option == AUTO

    def summary(self) -> str:
        """One line for stderr: the axes used and how many arrays each."""
        how = "inferred from the trunk (head above the feet)" if self.inferred else "stated"
        if not self.counts:
            return f"up axis {self.option}: no arrays read"
        parts = [
            f"{axis} for {n} array{'' if n == 1 else 's'}"
            for axis, n in sorted(self.counts.items())
        ]
        line = f"up axis {how}: {', '.join(parts)}"
        if len(self.counts) > 1:
            line += (
                " (first of each: "
                + ", ".join(f"{axis} {self.first[axis]}" for axis in sorted(self.first))
                + ")"
            )
        return line

    def manifest(self) -> dict:
        """The manifest's record: the option, each axis used with its count and first array."""
        return {
            "option": self.option,
            "inferred": self.inferred,
            "found": {axis: int(n) for axis, n in sorted(self.counts.items())},
            "first_array": dict(sorted(self.first.items())),
        }


def resolve_up_axis(
    positions: np.ndarray,
    layout: Layout,
    up_axis: str,
    *,
    params: UpAxisParams | None = None,
    item: str | None = None,
) -> str:
    """``up_axis`` itself, or with ``auto`` the axis :func:`infer_up_axis` finds."""
    if up_axis == AUTO:
        return infer_up_axis(positions, layout, params=params, item=item).axis
    if up_axis not in UP_AXES:
        raise TurnbenchError(
            f"unknown up axis {up_axis!r}; choose one of {', '.join(UP_AXES)} or {AUTO}"
        )
    return up_axis


def z_up_arrays(
    named: Iterable[tuple[str, np.ndarray]],
    *,
    layout: Layout,
    up_axis: str,
    found: AxesFound,
    params: UpAxisParams | None = None,
) -> Iterator[tuple[str, np.ndarray]]:
    """``(key, positions)`` pairs turned z up, each by its stated or inferred axis.

    One array at a time (a file's arrays are read lazily); the axis used for each is
    recorded in ``found``.
    """
    for key, array in named:
        axis = resolve_up_axis(array, layout, up_axis, params=params, item=str(key))
        found.record(str(key), axis)
        yield key, to_z_up(np.asarray(array), axis)
