"""The identity-break guard: where a single-person tracker starts following someone else.

MediaPipe Pose tracks one person. When that person leaves, is hidden, or a second person is
more salient, it silently jumps to another body, with no drop in its confidence (seen on
real clinic clips, and at 5.7 s and 6.7 s of ``sports2d_demo.mp4``). A turning angle
integrated across such a jump measures two people.

No walking body moves its trunk's centre several trunk lengths between two frames, nor
doubles its size on the image between them: both are what a change of person looks like.
Between two consecutive detections ``a`` and ``b`` (with ``dt`` seconds between them, longer
across undetected frames) the guard measures, in the image's pixels,

- ``jump``: the distance between the trunk centres (mean of both shoulders and hips), in
  trunk lengths (shoulder midpoint to hip midpoint, the mean of the two frames);
- ``scale_ratio``: the larger trunk length over the smaller,

and declares a break at ``b`` when ``jump > min_jump_torso + max_speed_torso_per_s * dt`` or
``scale_ratio > max_scale_ratio``. The defaults leave a wide margin on real video: over the
3.3 s of people walking, jumping on a box and walking out in ``sports2d_demo.mp4`` the
largest ``jump - 10 dt`` between one person's frames is below 0.3 trunk lengths and the
largest scale ratio below 1.3, while the two changes of person measure 4.7 and 9.2.
A person running across the image at 5 m/s covers about 10 trunk lengths a second, the
speed allowance.

The frames between two breaks are one *track*; the caller writes each track as its own
array, so no array holds two people.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.params import param

__all__ = ["IdentityBreak", "IdentityGuardParams", "identity_breaks", "is_break", "trunk", "tracks"]

# BlazePose landmark indices of the trunk (see :mod:`turn_eval.estimate.joints`).
_SHOULDERS = (11, 12)
_HIPS = (23, 24)


@dataclass(frozen=True)
class IdentityGuardParams:
    """Thresholds of the identity-break guard (module docstring), in trunk lengths."""

    min_jump_torso: float = param(
        1.5,
        "A trunk centre jump of at least this many trunk lengths can be a break.",
        min=0.0,
        max=100.0,
        min_open=True,
    )
    max_speed_torso_per_s: float = param(
        10.0,
        "Trunk lengths per second a person can move; a faster jump is a break.",
        min=0.0,
        max=1000.0,
    )
    max_scale_ratio: float = param(
        2.0,
        "A trunk length changing by more than this factor between frames is a break.",
        min=1.0,
        max=100.0,
        min_open=True,
    )

    def __post_init__(self) -> None:
        if not (self.min_jump_torso > 0 and self.max_speed_torso_per_s >= 0):
            raise TurnbenchError("the guard's jump thresholds must be positive")
        if not self.max_scale_ratio > 1:
            raise TurnbenchError("the guard's scale ratio must be above 1")


@dataclass(frozen=True)
class IdentityBreak:
    """One change of tracked person: the first frame of the new one, and what was measured."""

    frame: int
    time_s: float
    jump_torso: float
    scale_ratio: float
    centre_before: tuple[float, float]
    centre_after: tuple[float, float]

    def to_dict(self) -> dict:
        return asdict(self)


def trunk(image_xy: np.ndarray, width_px: int, height_px: int) -> tuple[np.ndarray, np.ndarray]:
    """Trunk centre (pixels, ``(..., 2)``) and trunk length (pixels) of ``(..., 33, 2)`` landmarks."""
    px = np.asarray(image_xy, dtype=np.float64) * np.array([width_px, height_px], dtype=float)
    shoulders = px[..., list(_SHOULDERS), :].mean(axis=-2)
    hips = px[..., list(_HIPS), :].mean(axis=-2)
    centre = (shoulders + hips) / 2.0
    length = np.linalg.norm(shoulders - hips, axis=-1)
    return centre, length


def is_break(
    centre_a: np.ndarray,
    length_a: float,
    centre_b: np.ndarray,
    length_b: float,
    dt_s: float,
    params: IdentityGuardParams,
) -> tuple[bool, float, float]:
    """The guard's rule for two consecutive detections: (break?, jump in trunks, scale ratio)."""
    jump = float(np.linalg.norm(centre_b - centre_a) / ((length_a + length_b) / 2.0))
    ratio = float(max(length_a, length_b) / min(length_a, length_b))
    limit = params.min_jump_torso + params.max_speed_torso_per_s * dt_s
    return (jump > limit or ratio > params.max_scale_ratio), jump, ratio


def identity_breaks(
    image_xy: np.ndarray,
    times_s: np.ndarray,
    *,
    width_px: int,
    height_px: int,
    params: IdentityGuardParams | None = None,
) -> list[IdentityBreak]:
    """Breaks between consecutive detections (module docstring), in time order.

    Parameters
    ----------
    image_xy
        ``(frames, 33, 2)`` BlazePose image landmarks, x and y as fractions of the image's
        width and height (MediaPipe's normalised coordinates); NaN where nobody is detected.
    times_s
        ``(frames,)`` time of each frame.
    width_px, height_px
        The image's size, so that distances are measured in pixels, not in fractions of
        two different lengths.
    """
    p = params or IdentityGuardParams()
    xy = np.asarray(image_xy, dtype=np.float64)
    t = np.asarray(times_s, dtype=np.float64)
    if xy.ndim != 3 or xy.shape[1:] != (33, 2) or t.shape != (xy.shape[0],):
        raise TurnbenchError(
            f"image landmarks must be (frames, 33, 2) with one time per frame, got "
            f"{tuple(xy.shape)} and {tuple(t.shape)}"
        )
    centre, length = trunk(xy, width_px, height_px)
    seen = np.flatnonzero(np.isfinite(centre).all(axis=1) & np.isfinite(length) & (length > 0))
    breaks: list[IdentityBreak] = []
    size = np.array([width_px, height_px], dtype=float)
    for a, b in zip(seen[:-1], seen[1:], strict=True):
        broken, jump, ratio = is_break(
            centre[a], float(length[a]), centre[b], float(length[b]), float(t[b] - t[a]), p
        )
        if broken:
            breaks.append(
                IdentityBreak(
                    frame=int(b),
                    time_s=round(float(t[b]), 6),
                    jump_torso=round(jump, 6),
                    scale_ratio=round(ratio, 6),
                    centre_before=tuple(np.round(centre[a] / size, 6).tolist()),
                    centre_after=tuple(np.round(centre[b] / size, 6).tolist()),
                )
            )
    return breaks


def tracks(detected: np.ndarray, breaks: list[IdentityBreak]) -> list[tuple[int, int]]:
    """``(start, end)`` frame ranges (end exclusive) of the tracks the breaks separate.

    A track runs from its first detected frame to its last; frames before the first
    detection and after the last are in none. No detection at all gives no track.
    """
    seen = np.flatnonzero(np.asarray(detected, dtype=bool))
    if seen.size == 0:
        return []
    cuts = [int(seen[0])] + [b.frame for b in breaks] + [int(seen[-1]) + 1]
    out = []
    for start, stop in zip(cuts[:-1], cuts[1:], strict=True):
        inside = seen[(seen >= start) & (seen < stop)]
        if inside.size:
            out.append((int(inside[0]), int(inside[-1]) + 1))
    return out
