"""The one Markdown table writer of turnbench (scores, statistics, audits, comparisons)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

__all__ = ["markdown_cell", "markdown_table", "metric_table"]


def markdown_cell(value: Any) -> str:
    """A value as the text of one cell: a ``|`` would end the cell and a line break the row
    (names come from files), so the first is escaped and white space runs become one space;
    a ``<`` is written as ``&lt;`` so that a name like ``<script>`` is shown, not run, by a
    Markdown viewer that passes HTML through."""
    return " ".join(str(value).split()).replace("|", "\\|").replace("<", "&lt;")


def markdown_table(
    header: Sequence[Any],
    rows: Iterable[Sequence[Any]],
    *,
    align: str | None = None,
    padded_rule: bool = False,
) -> list[str]:
    """The lines of a GitHub-flavoured Markdown table (no trailing newline).

    Parameters
    ----------
    header, rows
        Cell values; each goes through :func:`markdown_cell`.
    align
        One letter per column, ``l`` (default) or ``r`` (numbers: ``---:``).
    padded_rule
        Write the rule row as ``| --- | ---: |`` rather than ``|---|---:|`` (scores.md's
        layout, kept so its bytes do not change).
    """
    align = align or "l" * len(header)
    if len(align) != len(header):
        raise ValueError(f"align has {len(align)} letters for {len(header)} columns")
    marks = ["---:" if a == "r" else "---" for a in align]
    rule = "|" + "|".join(f" {m} " if padded_rule else m for m in marks) + "|"
    lines = ["| " + " | ".join(markdown_cell(h) for h in header) + " |", rule]
    lines += ["| " + " | ".join(markdown_cell(c) for c in row) + " |" for row in rows]
    return lines


def metric_table(header: Sequence[Any], rows: Iterable[Sequence[Any]]) -> list[str]:
    """The harness's metric tables (scores.md, score-events' Markdown): the first column (a
    label) left-aligned, every other (a number) right-aligned, the rule padded."""
    return markdown_table(header, rows, align="l" + "r" * (len(header) - 1), padded_rule=True)
