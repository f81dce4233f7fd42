"""Progress of a run over files, on stderr: a bar on a terminal, a line per file elsewhere.

click's bar prints only its label when stderr is not a terminal (a log file, CI, ``2>
run.log``), so a long run says nothing until it ends. And click's first time estimate
divides the time since the start by one file: on a Dask cluster that time is mostly the
cluster starting, so the first estimate is many times too long. Here the estimate counts
from the first file done: the rate of the files after it.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

__all__ = ["FileProgress", "format_duration"]


def format_duration(seconds: float) -> str:
    """``75`` -> ``1 min 15 s``; ``3700`` -> ``1 h 2 min``; ``8`` -> ``8 s``."""
    s = max(0, int(round(seconds)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60} s"
    return f"{s // 3600} h {(s % 3600) // 60} min"


class FileProgress:
    """Files done out of ``total``, with the time left once two files are done.

    Parameters
    ----------
    total
        How many files the run has.
    label
        What is being done (``detecting on 4 local workers``).
    stream
        Where to write (stderr).
    clock
        Seconds, monotonic (a test passes its own).
    """

    def __init__(
        self,
        total: int,
        label: str,
        *,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.total = int(total)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.clock = clock
        self.done = 0
        self._first_done: float | None = None
        isatty = getattr(self.stream, "isatty", None)
        self.terminal = bool(isatty()) if callable(isatty) else False

    def eta_s(self) -> float | None:
        """Seconds left: files left times the mean time per file after the first (None
        before two files are done, when the only time known includes the start-up)."""
        if self._first_done is None or self.done < 2:
            return None
        per_file = (self.clock() - self._first_done) / (self.done - 1)
        return per_file * (self.total - self.done)

    def line(self) -> str:
        eta = self.eta_s()
        left = (
            f", about {format_duration(eta)} left"
            if eta is not None and self.done < self.total
            else ""
        )
        return f"{self.label}: {self.done}/{self.total} files{left}"

    def update(self, n: int = 1) -> None:
        """``n`` more files done: the bar redrawn, or one more line."""
        self.done += n
        if self._first_done is None:
            self._first_done = self.clock()
        if self.terminal:
            end = "\n" if self.done >= self.total else ""
            self.stream.write("\r\x1b[K" + self.line() + end)
        else:
            self.stream.write(self.line() + "\n")
        self.stream.flush()

    def __enter__(self) -> FileProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.terminal and 0 < self.done < self.total:
            self.stream.write("\n")
            self.stream.flush()
