"""The one exception type of turnbench, and the gate failure.

A user's mistake (a bad file, a bad row, a bad option value) raises :class:`TurnbenchError`
with *where* it happened; the command line turns it into one line on stderr and exit code 2.
A failed quality gate (for example a kappa below ``--min-kappa``) raises :class:`GateFailed`,
exit code 3. Anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from os import PathLike

__all__ = ["TurnbenchError", "GateFailed", "Where", "require_columns"]


@dataclass(frozen=True)
class Where:
    """Where a problem is: a file and, as far as known, a row, a tier, a time or an item."""

    file: str | None = None
    row: int | None = None
    tier: str | None = None
    time_s: float | None = None
    item: str | None = None

    def __str__(self) -> str:
        parts: list[str] = []
        if self.file is not None:
            parts.append(self.file if self.row is None else f"{self.file}:{self.row}")
        elif self.row is not None:
            parts.append(f"row {self.row}")
        if self.item is not None:
            parts.append(self.item)
        if self.tier is not None:
            parts.append(f"tier {self.tier!r}")
        if self.time_s is not None:
            parts.append(f"at {self.time_s:.3f} s")
        return ", ".join(parts)


class TurnbenchError(Exception):
    """A problem with the user's input, reported with where it is.

    Parameters
    ----------
    message
        What is wrong, in one sentence, without the location.
    file, row, tier, time_s, item
        Where it is: ``row`` is the file's own line number (1 = header for a CSV),
        ``item`` a sequence, clip or session name.
    hint
        Optional advice on how to fix it.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | PathLike[str] | None = None,
        row: int | None = None,
        tier: str | None = None,
        time_s: float | None = None,
        item: str | None = None,
        hint: str | None = None,
    ) -> None:
        self.message = message
        self.where = Where(
            file=None if file is None else str(file), row=row, tier=tier, time_s=time_s, item=item
        )
        self.hint = hint
        super().__init__(str(self))

    def __str__(self) -> str:
        where = str(self.where)
        text = f"{where}: {self.message}" if where else self.message
        if self.hint:
            text += f" (hint: {self.hint})"
        return text


def require_columns(
    have: Iterable[object],
    required: Iterable[str],
    *,
    what: str,
    file: str | PathLike[str] | None = None,
    row: int | None = 1,
    note: str = "",
) -> None:
    """Raise the one "lacks columns" error of every table turnbench reads.

    Parameters
    ----------
    have
        The table's column names (its header), in order.
    required
        The columns it must have.
    what
        The table, as the message names it ("the detections file").
    file, row
        Where the header is (row 1 unless a preamble precedes it).
    note
        Appended to the message, e.g. how names were matched.

    Raises
    ------
    TurnbenchError
        ``<what> lacks column(s) 'a', 'b'; its header has 'x', 'y'<note>``, when any is absent.
    """
    header = [str(c) for c in have]
    missing = [c for c in required if c not in header]
    if missing:
        raise TurnbenchError(
            f"{what} lacks column{'s' if len(missing) > 1 else ''} "
            f"{', '.join(repr(c) for c in missing)}; its header has "
            f"{', '.join(repr(c) for c in header)}{note}",
            file=file,
            row=row,
        )


class GateFailed(Exception):
    """A quality gate was not met (exit code 3): the result was computed and reported."""
