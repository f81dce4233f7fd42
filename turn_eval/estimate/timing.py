"""Frame times onto a regular grid: constant-frame-rate video as it is, variable-rate resampled.

The turning-angle equations (and the detector's filters) assume one frame every ``1/fps``
seconds. A constant-frame-rate file gives that directly. A variable-frame-rate file does not:
phone and WebM exports stamp each frame with its own time, and their containers often
declare a meaningless rate (1000 fps through OpenCV for WebM). So the rate is taken from the
frames' own presentation times: the container's declared rate when the frames agree with it,
else the rate of the median frame interval (the camera's nominal rate; dropped frames make
longer intervals, not shorter ones), unless the caller gives one.

Each decoded frame is then put on the grid point nearest to its time; a grid point no frame
falls on stays empty (NaN downstream), and when two frames fall on one point the one nearer
to it is kept. Nothing is interpolated: a pose estimate is never invented.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turn_datasets.errors import TurnbenchError

__all__ = ["TimeGrid", "nominal_rate_hz", "regular_grid", "resample"]

#: A declared rate within this fraction of the frames' median rate is taken as the rate.
RATE_AGREEMENT_FRACTION = 0.01
#: A frame further than this fraction of an interval from its grid point makes a file irregular.
IRREGULAR_FRACTION = 0.25


@dataclass(frozen=True)
class TimeGrid:
    """Where each grid frame comes from.

    Attributes
    ----------
    fps_hz
        The grid's rate.
    start_s
        Time of grid frame 0 (the first decoded frame's presentation time).
    source_index
        ``(n_frames,)`` int: the decoded frame on each grid point, -1 where none falls.
    regular
        True when every decoded frame sits on its own grid point (within a quarter of an
        interval) and none is missing: a constant-frame-rate file, left as it was.
    n_empty, n_dropped
        Grid points without a frame; decoded frames not kept (two on one point).
    """

    fps_hz: float
    start_s: float
    source_index: np.ndarray
    regular: bool
    n_empty: int
    n_dropped: int

    @property
    def n_frames(self) -> int:
        return int(self.source_index.shape[0])

    @property
    def times_s(self) -> np.ndarray:
        """Time of each grid frame in seconds, from the file's own clock."""
        return self.start_s + np.arange(self.n_frames) / self.fps_hz


def _checked_times(times_s: np.ndarray) -> np.ndarray:
    t = np.asarray(times_s, dtype=np.float64)
    if t.ndim != 1 or t.size == 0:
        raise TurnbenchError("no frame timestamps: the video has no decodable frame")
    if not np.all(np.isfinite(t)):
        raise TurnbenchError("a frame has no timestamp (NaN or infinite)")
    if t.size > 1 and np.any(np.diff(t) <= 0):
        first = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise TurnbenchError(
            f"frame timestamps do not increase (frame {first} at {t[first]:.6f} s)",
            hint="re-mux the file (ffmpeg -i in -c copy out.mp4) to repair its timestamps",
        )
    return t


def nominal_rate_hz(times_s: np.ndarray, declared_fps_hz: float | None = None) -> float:
    """The rate to put ``times_s`` on: ``declared_fps_hz`` if the frames agree, else theirs.

    The frames' rate is one over their median interval. With one frame, the declared rate
    is all there is.
    """
    t = _checked_times(times_s)
    declared = (
        float(declared_fps_hz)
        if declared_fps_hz is not None and np.isfinite(declared_fps_hz) and declared_fps_hz > 0
        else None
    )
    if t.size < 2:
        if declared is None:
            raise TurnbenchError("one frame and no declared frame rate: give --fps")
        return declared
    measured = 1.0 / float(np.median(np.diff(t)))
    if declared is not None and abs(declared - measured) <= RATE_AGREEMENT_FRACTION * measured:
        return declared
    return measured


def regular_grid(
    times_s: np.ndarray, *, fps_hz: float | None = None, declared_fps_hz: float | None = None
) -> TimeGrid:
    """Put frames with presentation times ``times_s`` on a regular grid (module docstring).

    Parameters
    ----------
    times_s
        Increasing presentation time of each decoded frame, seconds.
    fps_hz
        The grid's rate, if the caller knows it (``--fps``); else :func:`nominal_rate_hz`.
    declared_fps_hz
        The rate the container declares, used when the frames agree with it.
    """
    t = _checked_times(times_s)
    if fps_hz is not None and not (np.isfinite(fps_hz) and fps_hz > 0):
        raise TurnbenchError(f"the frame rate must be a positive number of Hz, got {fps_hz}")
    rate = float(fps_hz) if fps_hz is not None else nominal_rate_hz(t, declared_fps_hz)
    position = (t - t[0]) * rate
    slot = np.rint(position).astype(np.int64)
    offset = np.abs(position - slot)
    n = int(slot[-1]) + 1
    source = np.full(n, -1, dtype=np.int64)
    best = np.full(n, np.inf)
    for i in range(t.size):  # frames in time order, so a tie keeps the earlier frame
        k = slot[i]
        if offset[i] < best[k]:
            best[k] = offset[i]
            source[k] = i
    n_empty = int(np.count_nonzero(source < 0))
    n_dropped = int(t.size - np.count_nonzero(source >= 0))
    regular = n_empty == 0 and n_dropped == 0 and bool(np.all(offset <= IRREGULAR_FRACTION))
    return TimeGrid(
        fps_hz=rate,
        start_s=float(t[0]),
        source_index=source,
        regular=regular,
        n_empty=n_empty,
        n_dropped=n_dropped,
    )


def resample(values: np.ndarray, grid: TimeGrid) -> np.ndarray:
    """``values`` (one row per decoded frame) on the grid: float64, NaN on empty points."""
    v = np.asarray(values, dtype=np.float64)
    out = np.full((grid.n_frames, *v.shape[1:]), np.nan)
    have = grid.source_index >= 0
    out[have] = v[grid.source_index[have]]
    return out
