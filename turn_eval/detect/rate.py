"""The frame rate a detection run uses: the one ``estimate``'s manifests record, or ``--fps``.

``turn-eval estimate`` writes beside each ``<stem>.npz`` a ``<stem>.manifest.json`` whose
``time.fps_hz`` is the rate of the arrays' regular time grid
(:mod:`turn_eval.estimate.timing`). A ``--fps`` that contradicts it shifts every turn's time
and scales every speed by the ratio of the two (``--fps 30`` on a 25 fps video: times 1/6
early, speeds 20% high), and nothing downstream can tell, so it is refused unless forced.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import manifest_path

__all__ = ["RATE_TOLERANCE", "StreamRate", "format_rate", "manifest_rate", "stream_rate"]

#: Relative difference under which a given rate agrees with a recorded one: a phone's
#: 31.249999... Hz and ``--fps 31.25`` are the same rate; 25 and 30 are not.
RATE_TOLERANCE = 1e-3


def format_rate(fps_hz: float) -> str:
    """A rate as people write it: at most three decimals, no trailing zeros (31.25, 29.97)."""
    return f"{round(float(fps_hz), 3):g}"


@dataclass(frozen=True)
class StreamRate:
    """The rate used, and where it came from (``manifest``, ``option`` or ``forced``)."""

    fps_hz: float
    origin: str
    #: The rate the manifests record (None where no manifest records one).
    recorded_hz: float | None = None

    def describe(self) -> str:
        """One line for stderr: the rate used and why."""
        used = f"frame rate {format_rate(self.fps_hz)} Hz"
        if self.origin == "manifest":
            return f"{used}, from the estimate manifests beside the streams"
        if self.origin == "forced":
            return (
                f"{used}, from --fps (forced over the manifests' "
                f"{format_rate(self.recorded_hz or math.nan)} Hz)"
            )
        return f"{used}, from --fps"


def manifest_rate(stream: str | Path) -> float | None:
    """``time.fps_hz`` of the estimate manifest beside ``stream``; None if there is none.

    Raises
    ------
    TurnbenchError
        A manifest that exists but cannot be read or records no positive rate.
    """
    path = manifest_path(stream)
    if not path.is_file():
        return None
    try:
        value = json.loads(path.read_text(encoding="utf-8"))["time"]["fps_hz"]
        rate = float(value)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise TurnbenchError(
            f"cannot read the frame rate (time.fps_hz): {exc}", file=path
        ) from None
    if not (math.isfinite(rate) and rate > 0):
        raise TurnbenchError(f"time.fps_hz is {value!r}, not a positive rate", file=path)
    return rate


def stream_rate(
    files: Sequence[str | Path],
    fps_hz: float | None,
    *,
    source_format: str,
    force: bool = False,
) -> StreamRate:
    """The one frame rate for detecting turns in ``files``.

    With ``--from turnbench`` the estimate manifests beside the files give it; a ``fps_hz``
    that disagrees with them (beyond :data:`RATE_TOLERANCE`) is refused unless ``force``.
    Other files say nothing of their rate, so ``fps_hz`` is needed.

    Raises
    ------
    TurnbenchError
        No rate at all; manifests that record different rates (run each rate alone); a
        given rate that contradicts the recorded one, unforced (one line, both values).
    """
    recorded: dict[float, Path] = {}
    missing: list[Path] = []
    if source_format == "turnbench":
        for f in files:
            rate = manifest_rate(f)
            if rate is None:
                missing.append(Path(f))
            else:
                recorded.setdefault(rate, Path(f))
    rates = sorted(recorded)
    if len(rates) > 1 and not math.isclose(rates[0], rates[-1], rel_tol=RATE_TOLERANCE):
        first, last = recorded[rates[0]], recorded[rates[-1]]
        raise TurnbenchError(
            f"the streams' manifests record different frame rates ({first}: "
            f"{format_rate(rates[0])} Hz, {last}: {format_rate(rates[-1])} Hz)",
            hint="detect the files of each rate in a run of their own",
        )
    if rates and missing and fps_hz is None:
        raise TurnbenchError(
            f"{len(missing)} stream(s) have no estimate manifest beside them (first: "
            f"{missing[0]}) and the others record {format_rate(rates[0])} Hz",
            hint="restore the manifests, or give --fps",
        )
    if not rates:
        if fps_hz is None:
            raise TurnbenchError(
                "--fps is needed: these streams do not record their frame rate",
                hint="give --fps (turn-eval estimate's npz record it in the manifest beside them)",
            )
        return StreamRate(float(fps_hz), "option")
    recorded_hz = rates[0]
    if fps_hz is None:
        return StreamRate(recorded_hz, "manifest", recorded_hz)
    if math.isclose(fps_hz, recorded_hz, rel_tol=RATE_TOLERANCE):
        return StreamRate(recorded_hz, "manifest", recorded_hz)
    if force:
        return StreamRate(float(fps_hz), "forced", recorded_hz)
    raise TurnbenchError(
        f"--fps {format_rate(fps_hz)} contradicts the {format_rate(recorded_hz)} Hz that "
        f"{recorded[recorded_hz]}'s manifest records",
        hint="drop --fps to use the recorded rate, or add --force-fps to override it",
    )
