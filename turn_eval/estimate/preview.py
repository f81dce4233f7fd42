"""QA preview: a small video per input with the tracked skeleton drawn on it.

So that a clinician can see where tracking failed, the preview shows each frame, shrunk to
at most :data:`PREVIEW_WIDTH_PX` wide, with the 17-joint skeleton MediaPipe found drawn in
the colour of its track (the colour changes at each identity break the guard finds, so a
jump to a bystander is visible), and a red border on frames where nobody was found. It is
the only image data turnbench writes; it is written only when asked (``--preview DIR``),
on the local disk, with the ffmpeg inside imageio-ffmpeg (H.264, yuv420p).

The preview is drawn while the video is decoded, so its colours come from the guard's rule
(:func:`turn_eval.estimate.guard.is_break`) run on the decoded frames as they come; the
manifest's tracks come from the frames put on the time grid. For a constant-rate video the
two agree; for a variable-rate one a break may show a frame earlier or later in the preview.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from turn_datasets.skeleton import H36M17
from turn_eval.estimate.guard import IdentityGuardParams, is_break, trunk
from turn_eval.estimate.joints import blazepose_to_h36m17

__all__ = ["PREVIEW_WIDTH_PX", "PreviewWriter"]

PREVIEW_WIDTH_PX = 640
_BONES = tuple(
    (H36M17.index(a), H36M17.index(b))
    for a, b in (
        ("pelvis", "right_hip"), ("right_hip", "right_knee"), ("right_knee", "right_foot"),
        ("pelvis", "left_hip"), ("left_hip", "left_knee"), ("left_knee", "left_foot"),
        ("pelvis", "spine"), ("spine", "thorax"), ("thorax", "neck"), ("neck", "head"),
        ("thorax", "left_shoulder"), ("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"),
        ("thorax", "right_shoulder"), ("right_shoulder", "right_elbow"),
        ("right_elbow", "right_wrist"),
    )
)  # fmt: skip
# One colour per track, cycling: green, cyan, magenta, yellow, orange.
_TRACK_RGB = ((40, 220, 60), (40, 200, 230), (230, 60, 220), (240, 230, 40), (250, 140, 30))
_MISSING_RGB = (230, 30, 30)


def _draw_line(img: np.ndarray, p0: np.ndarray, p1: np.ndarray, rgb: tuple[int, int, int]) -> None:
    n = int(max(abs(p1[0] - p0[0]), abs(p1[1] - p0[1]))) + 1
    xs = np.rint(np.linspace(p0[0], p1[0], n)).astype(int)
    ys = np.rint(np.linspace(p0[1], p1[1], n)).astype(int)
    h, w = img.shape[:2]
    for dx in (-1, 0, 1):  # three pixels thick
        for dy in (-1, 0, 1):
            x, y = xs + dx, ys + dy
            ok = (x >= 0) & (x < w) & (y >= 0) & (y < h)
            img[y[ok], x[ok]] = rgb


class PreviewWriter:
    """Write the preview of one video, frame by frame, as it is decoded."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        width_px: int,
        height_px: int,
        fps_hz: float,
        guard: IdentityGuardParams,
    ) -> None:
        import imageio_ffmpeg

        self.path = Path(path)
        self.step = max(1, math.ceil(width_px / PREVIEW_WIDTH_PX))
        # H.264 in yuv420p needs even sizes: crop the last row/column if odd
        self.out_w = (len(range(0, width_px, self.step))) // 2 * 2
        self.out_h = (len(range(0, height_px, self.step))) // 2 * 2
        self.size = (width_px, height_px)
        self.guard = guard
        self._track = 0
        self._last: tuple[np.ndarray, float, float] | None = None
        # `file:` and the absolute path: a name like `tcp:host:port` is a file here too; the
        # format is named, since the path may be a temporary one without `.mp4`
        self._writer = imageio_ffmpeg.write_frames(
            "file:" + os.path.abspath(self.path),
            (self.out_w, self.out_h),
            fps=fps_hz,
            codec="libx264",
            pix_fmt_out="yuv420p",
            macro_block_size=2,
            output_params=["-threads", "1", "-protocol_whitelist", "file", "-f", "mp4"],
        )
        self._writer.send(None)

    def add(self, rgb: np.ndarray, image_xy: np.ndarray, time_s: float) -> None:
        """One decoded frame and its ``(33, 2)`` image landmarks (NaN when nobody is found)."""
        # a copy: the decoded frame is read-only (and at most 640 wide, the frame itself)
        img = np.array(rgb[:: self.step, :: self.step][: self.out_h, : self.out_w], order="C")
        if not np.isfinite(image_xy).all():
            img[:6], img[-6:], img[:, :6], img[:, -6:] = (_MISSING_RGB,) * 4
        else:
            centre, length = trunk(image_xy, *self.size)
            if self._last is not None and length > 0:
                broken, _, _ = is_break(
                    self._last[0],
                    self._last[1],
                    centre,
                    float(length),
                    time_s - self._last[2],
                    self.guard,
                )
                self._track += int(broken)
            self._last = (centre, float(length), time_s)
            joints = blazepose_to_h36m17(image_xy[None])[0] * np.array(self.size) / self.step
            rgb_track = _TRACK_RGB[self._track % len(_TRACK_RGB)]
            for a, b in _BONES:
                _draw_line(img, joints[a], joints[b], rgb_track)
        self._writer.send(img)

    def close(self) -> None:
        self._writer.close()
