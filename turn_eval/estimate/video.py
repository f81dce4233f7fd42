"""Decoding a video with each frame's own presentation time (imageio-ffmpeg's ffmpeg).

The frames come out of ffmpeg as RGB on a pipe, one per *decoded* frame
(``-fps_mode passthrough``: ffmpeg's default for a raw pipe would duplicate and drop frames
to a constant rate, hiding a variable-frame-rate file), and ffmpeg's ``showinfo`` filter
reports each one's presentation time and size on stderr, read alongside (without the
checksums of every plane it computes by default: a quarter of ffmpeg's CPU at 1768x994).
Rotation metadata (phone videos) is applied by ffmpeg as usual, so people are upright in
the frames.

Only the named local file is opened: ffmpeg is given ``file:`` and the absolute path, with
``-protocol_whitelist file``. Given the bare name, ffmpeg reads a file called
``tcp:127.0.0.1:18999`` as a network address, ``concat:a.mp4|b.mp4`` as two other files and
``subfile,,start,0,end,0,,:a.mp4`` as a part of another: a video never leaves the machine,
and what is decoded is the file whose sha256 the manifest records. The ffmpeg binary is the
one inside the imageio-ffmpeg wheel.

A video must decode whole (:func:`check_complete`): a copy cut short (its container still
declaring the full duration) decodes, without an error from ffmpeg, to the frames before
the cut; a still image renamed ``.mp4`` decodes to one frame. Both are refused, naming what
was decoded against what the container declares, rather than giving a partial result.
"""

from __future__ import annotations

import os
import queue
import re
import subprocess
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from turn_datasets.errors import TurnbenchError

__all__ = [
    "TRUNCATION_TOLERANCE_S",
    "VideoStream",
    "check_complete",
    "expected_frames",
    "ffmpeg_input",
    "open_video",
]

#: A video whose decoded frames end earlier than its container's duration by more than this
#: is refused as truncated, seconds. An audio track may outlast the video by a few frames
#: (the container's duration is the longer of the two); a cut-off copy lacks seconds.
TRUNCATION_TOLERANCE_S = 1.0

_SHOWINFO = re.compile(
    r"\bn:\s*(\d+)\s+pts:\s*(-?\d+)\s+pts_time:\s*(-?[\d.eE+-]+).*?\bs:(\d+)x(\d+)"
)
_STREAM = re.compile(r"Stream #\d+:\d+.*?: Video: (\w+)")
_FPS = re.compile(r"([\d.]+)(k?) fps")
_TBR = re.compile(r"([\d.]+)(k?) tbr")
_DURATION = re.compile(r"Duration: (\d+):(\d+):([\d.]+)")
_END = object()


def ffmpeg_input(path: str | os.PathLike[str]) -> list[str]:
    """ffmpeg's input options for exactly the local file ``path`` (module docstring)."""
    return ["-protocol_whitelist", "file", "-i", "file:" + os.path.abspath(path)]


def check_complete(
    pts_s: list[float], *, duration_s: float | None, fps_hz: float | None, path: Path
) -> None:
    """Refuse a decode that is not the whole video (module docstring).

    The decoded span is from the first frame's time to one frame after the last (at the
    declared rate, else the frames' own); it must reach the container's duration less
    :data:`TRUNCATION_TOLERANCE_S`. One frame is a still image, not a video.
    """
    if len(pts_s) == 1:
        raise TurnbenchError(
            "one decoded frame: a still image, not a video",
            file=path,
            hint="turn-eval estimate takes video files (MP4, MOV, WebM, ...)",
        )
    if len(pts_s) < 2 or not duration_s:
        return
    step = 1.0 / fps_hz if fps_hz and fps_hz <= 240 else (pts_s[-1] - pts_s[0]) / (len(pts_s) - 1)
    span = pts_s[-1] - pts_s[0] + step
    if duration_s - span > TRUNCATION_TOLERANCE_S:
        raise TurnbenchError(
            f"truncated: {len(pts_s)} frames decode to {span:.2f} s of the {duration_s:.2f} s "
            "its container declares",
            file=path,
            hint="the file was cut short (an interrupted copy or download): copy it again",
        )


def _rate(match: re.Match[str] | None) -> float | None:
    if match is None:
        return None
    value = float(match.group(1)) * (1000.0 if match.group(2) else 1.0)
    return value if value > 0 else None


@dataclass
class VideoStream:
    """An open video: iterate for ``(rgb (H, W, 3) uint8, pts_s)``; header facts once read.

    ``declared_fps_hz`` is the container's rate (``fps``, else ``tbr``, as ffmpeg reports
    it), ``None`` if it states none; ``duration_s`` the container's duration.
    """

    path: Path
    process: subprocess.Popen[bytes]
    codec: str = ""
    declared_fps_hz: float | None = None
    duration_s: float | None = None
    _frames: queue.Queue = field(default_factory=queue.Queue)
    _log: list[str] = field(default_factory=list)

    def _read_stderr(self) -> None:
        assert self.process.stderr is not None
        for raw in iter(self.process.stderr.readline, b""):
            line = raw.decode("utf-8", "replace").rstrip()
            info = _SHOWINFO.search(line)
            if info is not None:
                self._frames.put((float(info.group(3)), int(info.group(4)), int(info.group(5))))
                continue
            self._log.append(line)
            stream = _STREAM.search(line)
            if stream is not None and not self.codec:
                self.codec = stream.group(1)
                self.declared_fps_hz = _rate(_FPS.search(line)) or _rate(_TBR.search(line))
            duration = _DURATION.search(line)
            if duration is not None and self.duration_s is None:
                h, m, s = duration.groups()
                self.duration_s = int(h) * 3600 + int(m) * 60 + float(s)
        self._frames.put(_END)

    def __iter__(self) -> Iterator[tuple[np.ndarray, float]]:
        assert self.process.stdout is not None
        times: list[float] = []
        while True:
            item = self._frames.get()
            if item is _END:
                break
            pts_s, width, height = item
            size = width * height * 3
            data = self.process.stdout.read(size)
            if len(data) < size:
                break
            times.append(pts_s)
            yield np.frombuffer(data, dtype=np.uint8).reshape(height, width, 3), pts_s
        self.close()
        if self.process.returncode not in (0, None):
            tail = next((ln for ln in reversed(self._log) if ln.strip()), "ffmpeg failed")
            raise TurnbenchError(f"cannot decode this video: {tail.strip()}", file=self.path)
        check_complete(
            times, duration_s=self.duration_s, fps_hz=self.declared_fps_hz, path=self.path
        )

    def close(self) -> None:
        if self.process.poll() is None:
            # stopped early (an error downstream): ffmpeg must not outlive the reader
            self.process.kill()
        self.process.wait()
        if self.process.stdout is not None:
            self.process.stdout.close()


def open_video(path: str | os.PathLike[str]) -> VideoStream:
    """Start decoding ``path``; iterate the result for frames (module docstring)."""
    import imageio_ffmpeg

    p = Path(path)
    if not p.is_file():
        raise TurnbenchError("no such video file", file=p)
    cmd = [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-nostdin",
        "-hide_banner",
        *ffmpeg_input(p),
        "-map",
        "0:v:0",
        "-vf",
        "showinfo=checksum=0",
        "-fps_mode",
        "passthrough",
        "-f",
        "rawvideo",
        "-pix_fmt",
        "rgb24",
        "-",
    ]
    process = subprocess.Popen(
        cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    stream = VideoStream(path=p, process=process)
    threading.Thread(target=stream._read_stderr, daemon=True).start()
    return stream


def expected_frames(path: str | os.PathLike[str]) -> int:
    """How many frames the container of ``path`` declares (duration times rate, from its
    header alone, without decoding; 0 when it states neither or cannot be read): the length
    of a progress bar over many videos."""
    import imageio_ffmpeg

    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-nostdin", "-hide_banner", *ffmpeg_input(path)]
    try:
        text = subprocess.run(cmd, capture_output=True, timeout=60).stderr.decode(
            "utf-8", "replace"
        )
    except (OSError, subprocess.TimeoutExpired):
        return 0
    duration = _DURATION.search(text)
    stream = next((ln for ln in text.splitlines() if _STREAM.search(ln)), "")
    rate = _rate(_FPS.search(stream)) or _rate(_TBR.search(stream))
    if duration is None or rate is None or rate > 240:
        return 0
    h, m, sec = duration.groups()
    return int(round((int(h) * 3600 + int(m) * 60 + float(sec)) * rate))
