"""The figures of ``turn-eval score-events --plots``, as PNG.

- ``timelines/NNNN_<session>_<subject>.png`` (:func:`timeline_name`), one per (session,
  subject): the reference turns
  above the time axis, the detections below, true positives green (a line joins the two
  sides of a pair), false positives orange, false negatives red; each turn's angle written
  on it.
- ``f1_by_group.png``: F1 per group of every grouping, with its cluster-bootstrap 95%
  interval, and the groups' average.
- ``pr_curve.png`` (detections with ``score``): precision against recall down the ranking,
  at each IoU threshold of the AP table, with the AP in the legend.

Drawn and saved as every figure of the harness (:func:`turn_eval.scoring.figures.save_figure`:
matplotlib's object API on the Agg canvas, no software tag), so the same scores give the same bytes. matplotlib is imported only when a
figure is drawn: the command line takes the file names from here without it.
"""

from __future__ import annotations

import hashlib
import re
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from turn_eval.scoring.figures import save_figure

__all__ = ["EVENT_PLOT_FILES", "TIMELINE_DIR", "timeline_name", "write_event_plots"]

#: The summary figures, in the order :func:`write_event_plots` writes them.
EVENT_PLOT_FILES = ("f1_by_group.png", "pr_curve.png")
#: The folder of the per-(session, subject) timelines.
TIMELINE_DIR = "timelines"
_COLOURS = {"TP": "#2ca02c", "FP": "#ff7f0e", "FN": "#d62728"}
_MAX_INCHES = 24.0
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


#: The longest timeline file name stem (characters, ASCII): far below the 255 bytes most
#: file systems allow, so a long session name still gives a file that can be written.
_MAX_STEM = 120
#: Characters of the sha256 that keep a shortened name unique.
_HASH_CHARS = 12
#: matplotlib's warning for a character its font cannot draw ("Glyph 20250 (...) missing
#: from font(s) DejaVu Sans."), one per character and figure.
_MISSING_GLYPH = re.compile(r"Glyph (\d+) .*missing from font\(s\) (.+?)\.?$")


def _safe(name: str) -> str:
    return _UNSAFE.sub("-", name).strip("-") or "x"


def timeline_name(unit: int, session: str, subject: str) -> str:
    """The timeline's file name: ``NNNN_<session>_<subject>.png``, the names reduced to
    letters, digits, ``.``, ``_`` and ``-``; a stem longer than :data:`_MAX_STEM` is cut and
    ends in the first hex digits of the sha256 of both names, so it stays unique."""
    stem = f"{unit:04d}_{_safe(session)}_{_safe(subject)}"
    if len(stem) > _MAX_STEM:
        digest = hashlib.sha256(f"{session}\0{subject}".encode()).hexdigest()[:_HASH_CHARS]
        stem = f"{stem[: _MAX_STEM - _HASH_CHARS - 1]}-{digest}"
    return stem + ".png"


def _figure(**kwargs):
    from matplotlib.figure import Figure

    return Figure(**kwargs)


def _timeline(unit_events, path: Path, session: str, subject: str) -> Path:
    """One (session, subject): reference turns at y=1, detections at y=0."""
    t0 = float(np.nanmin(unit_events[["ref_start_s", "det_start_s"]].to_numpy()))
    t1 = float(np.nanmax(unit_events[["ref_end_s", "det_end_s"]].to_numpy()))
    span = max(t1 - t0, 1.0)
    fig = _figure(figsize=(min(4.0 + span / 10.0, _MAX_INCHES), 2.6))
    ax = fig.add_subplot()
    for row in unit_events.itertuples(index=False):
        colour = _COLOURS[row.kind]
        for y, start, end, angle in (
            (1.0, row.ref_start_s, row.ref_end_s, row.ref_angle_deg),
            (0.0, row.det_start_s, row.det_end_s, row.det_angle_deg),
        ):
            if not np.isfinite(start):
                continue
            ax.add_patch(
                _bar(start, end, y, colour),
            )
            ax.text((start + end) / 2, y + 0.3, f"{angle:g}°", ha="center", fontsize=7)
        if row.kind == "TP":
            mid_ref = (row.ref_start_s + row.ref_end_s) / 2
            mid_det = (row.det_start_s + row.det_end_s) / 2
            ax.plot([mid_ref, mid_det], [0.8, 0.2], color=colour, linewidth=0.8)
    ax.set_xlim(t0 - 0.02 * span, t1 + 0.02 * span)
    ax.set_ylim(-0.5, 1.7)
    ax.set_yticks([0.0, 1.0], ["detected", "reference"])
    ax.set_xlabel("time (s)")
    ax.set_title(f"session {session}, subject {subject}", fontsize=9)
    handles = [_bar(0, 0, 0, c) for c in _COLOURS.values()]
    ax.legend(handles, list(_COLOURS), loc="upper right", fontsize=7, ncols=3)
    fig.tight_layout()
    return save_figure(fig, path)


def _bar(start: float, end: float, y: float, colour: str):
    from matplotlib.patches import Rectangle

    return Rectangle((start, y - 0.2), end - start, 0.4, facecolor=colour, edgecolor="none")


def _f1_by_group(doc: Mapping[str, Any], path: Path) -> Path:
    blocks = list(doc.get("by", {}).items())
    fig = _figure(figsize=(8.0, 1.0 + 2.6 * max(len(blocks), 1)))
    if not blocks:
        ax = fig.add_subplot()
        ax.text(0.5, 0.5, "no groupings", ha="center", va="center")
        ax.set_axis_off()
        return save_figure(fig, path)
    for k, (col, block) in enumerate(blocks, start=1):
        ax = fig.add_subplot(len(blocks), 1, k)
        entries = [*block["groups"].items(), ("Avg.", block["avg"])]
        names = [name for name, _ in entries]
        f1 = np.array([np.nan if e["f1"] is None else e["f1"] for _, e in entries]) * 100
        low = np.full(len(entries), np.nan)
        high = np.full(len(entries), np.nan)
        for i, (_, e) in enumerate(entries):
            bounds = (e.get("ci95") or {}).get("f1")
            if bounds is not None:
                low[i], high[i] = 100 * bounds[0], 100 * bounds[1]
        x = np.arange(len(entries))
        colours = ["#1f77b4"] * (len(entries) - 1) + ["#7f7f7f"]
        ax.bar(x, np.nan_to_num(f1), color=colours)
        has = np.isfinite(low) & np.isfinite(f1)
        ax.errorbar(
            x[has],
            f1[has],
            yerr=[f1[has] - low[has], high[has] - f1[has]],
            fmt="none",
            ecolor="black",
            capsize=3,
        )
        ax.set_xticks(x, names, rotation=30 if len(names) > 6 else 0, fontsize=8)
        ax.set_ylim(0, 105)
        ax.set_ylabel("F1 (%)")
        ax.set_title(f"by {col}", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)


def _pr_curve(curves: Mapping[str, Mapping[str, np.ndarray]], ap: Mapping, path: Path) -> Path:
    fig = _figure(figsize=(5.5, 4.5))
    ax = fig.add_subplot()
    for key, curve in curves.items():
        value = ap["by_iou"].get(key)
        label = f"tIoU {key}" + ("" if value is None else f" (AP {100 * value:.1f}%)")
        ax.plot(curve["recall"], curve["precision"], linewidth=1.2, label=label)
    ax.set_xlim(0, 1.02)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("recall")
    ax.set_ylabel("precision")
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def write_event_plots(
    scores, out_dir: str | Path, *, warn: Callable[[str], None] | None = None
) -> list[Path]:
    """Write the figures of an :class:`turn_eval.events.EventScores` into ``out_dir``.

    matplotlib's warnings of characters its font cannot draw (names in a script the font
    lacks) are gathered into one line for ``warn``, instead of one raw warning per
    character and figure with matplotlib's source path.

    Returns the paths written: the timelines, ``f1_by_group.png`` and, with scores,
    ``pr_curve.png``.
    """
    out = Path(out_dir)
    written: list[Path] = []
    events = scores.events
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if events.shape[0]:
            (out / TIMELINE_DIR).mkdir(parents=True, exist_ok=True)
            for unit, group in events.groupby("unit", sort=True):
                session, subject = str(group["session"].iat[0]), str(group["subject"].iat[0])
                path = out / TIMELINE_DIR / timeline_name(int(unit), session, subject)
                written.append(_timeline(group, path, session, subject))
        written.append(_f1_by_group(scores.doc, out / EVENT_PLOT_FILES[0]))
        if scores.pr_curves is not None:
            written.append(
                _pr_curve(scores.pr_curves, scores.doc["overall"]["ap"], out / "pr_curve.png")
            )
    _report_warnings(caught, warn)
    return written


def _report_warnings(caught: list[warnings.WarningMessage], warn) -> None:
    """Missing glyphs as one line for ``warn``; any other warning shown as it came."""
    missing: dict[str, None] = {}
    fonts: dict[str, None] = {}
    for w in caught:
        match = _MISSING_GLYPH.search(str(w.message))
        if match is None:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            continue
        missing[chr(int(match.group(1)))] = None
        fonts[match.group(2)] = None
    if missing and warn is not None:
        shown = "".join(list(missing)[:10]) + ("..." if len(missing) > 10 else "")
        warn(
            f"the figures' font ({', '.join(fonts)}) cannot draw {len(missing)} character(s) "
            f"of the names ({shown}): they show as empty boxes"
        )
