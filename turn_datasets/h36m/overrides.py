"""Curation that survives regeneration: a curator's overrides of the mined clips.

The clip index is regenerated from the motion capture whenever the miner or its parameters
change, so a curator's decisions live in a separate file, ``curation.csv``, applied on every
run (``turn-datasets h36m mine --overrides curation.csv``):

``clip_id, decision, start_frame, end_frame, note``
    ``clip_id`` is a mined clip's id (``{subject}_{action}_{start}-{end}``). ``decision``:

    ``exclude``
        Drop the clip (a false turn, a bad capture). Frames empty.
    ``keep``
        The curator checked the clip and keeps it as mined. Frames empty. Recorded so that a
        regeneration that no longer finds it says so.
    ``adjust``
        Keep the clip with new boundaries ``start_frame``/``end_frame`` (0-based, end
        exclusive, in the sequence's frames); its angle, speed, bin and id are measured
        again on the new frames, exactly as the miner measures them.

    ``note`` is free text. An override whose ``clip_id`` matches no mined clip (because the
    miner's boundaries moved, say) is never dropped silently: it is warned about on stderr
    and listed in the manifest under ``overrides.unmatched``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import sha256_file
from turn_datasets.h36m.clip_index import SequenceClips, clip_id_of
from turn_datasets.h36m.miner import MinerParams, measure_clip
from turn_datasets.skeleton import MocapSequence
from turn_datasets.usertable import Problems, and_more, read_table, reading_notes, require

__all__ = [
    "DECISIONS",
    "OVERRIDE_COLUMNS",
    "Override",
    "Overrides",
    "read_overrides",
    "apply_overrides",
    "unmatched_overrides",
]

DECISIONS = ("exclude", "keep", "adjust")
OVERRIDE_COLUMNS = ("clip_id", "decision", "start_frame", "end_frame", "note")
_INT_RE = re.compile(r"^[+]?\d+$")


@dataclass(frozen=True)
class Override:
    """One row of ``curation.csv``; ``line`` is its line in the file (1 = header)."""

    clip_id: str
    decision: str
    start_frame: int | None
    end_frame: int | None
    note: str
    line: int

    @property
    def frames(self) -> tuple[int, int]:
        """``(start_frame, end_frame)`` of an ``adjust`` (:func:`read_overrides` requires
        both for it)."""
        if self.start_frame is None or self.end_frame is None:
            raise TurnbenchError(
                f"{self.decision} of {self.clip_id} has no frames", row=self.line, item=self.clip_id
            )
        return self.start_frame, self.end_frame

    def as_dict(self) -> dict[str, Any]:
        return {
            "clip_id": self.clip_id,
            "decision": self.decision,
            "start_frame": self.start_frame,
            "end_frame": self.end_frame,
            "note": self.note,
            "line": self.line,
        }


@dataclass
class Overrides:
    """The overrides of one file, by clip id, with the file's path and sha256."""

    path: str
    sha256: str
    by_id: dict[str, Override] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.by_id)


def _frame_field(text: str) -> int | None:
    """A whole number of frames, None when empty; raises ValueError for anything else."""
    if text == "":
        return None
    if not _INT_RE.match(text):
        raise ValueError(text)
    return int(text)


class _RowProblems:
    """The rows' problems, by kind, each with its rows' lines, messages and what is there,
    handed to :class:`~turn_datasets.usertable.Problems` at the end (the first row's message
    in full, the others counted)."""

    def __init__(self) -> None:
        self.kinds: dict[str, list[tuple[int, str, str]]] = {}
        self.count = 0

    def add(self, kind: str, line: int, message: str, detail: str = "") -> None:
        self.kinds.setdefault(kind, []).append((line, message, detail))
        self.count += 1

    def into(self, problems: Problems) -> None:
        for kind, rows in self.kinds.items():
            first = rows[0][1]
            details = [d for _, _, d in rows] if all(d for _, _, d in rows) else []
            problems.add(
                kind,
                [line for line, _, _ in rows],
                details[: problems.shown],
                single=first + and_more(len(rows)),
                first=first,
            )


def _check_row(
    cell: dict[str, str], line: int, seen: dict[str, int], found: _RowProblems
) -> Override | None:
    """One row as an override, or None after adding its problems to ``found``."""
    n_before = found.count
    clip_id = cell["clip_id"]
    decision = cell["decision"].lower()
    if not clip_id:
        found.add("empty clip_id", line, "empty clip_id")
    if decision not in DECISIONS:
        found.add(
            f"decision is not one of {', '.join(DECISIONS)}",
            line,
            f"decision {cell['decision']!r} is not one of {', '.join(DECISIONS)}",
            repr(cell["decision"]),
        )
    frames: dict[str, int | None] = {}
    for name in ("start_frame", "end_frame"):
        try:
            frames[name] = _frame_field(cell[name])
        except ValueError:
            found.add(
                f"{name} is not a whole number of frames",
                line,
                f"{name} {cell[name]!r} is not a whole number of frames",
                repr(cell[name]),
            )
    start, end = frames.get("start_frame"), frames.get("end_frame")
    if decision == "adjust" and len(frames) == 2:
        if start is None or end is None:
            found.add(
                "adjust needs start_frame and end_frame",
                line,
                "adjust needs start_frame and end_frame",
            )
        elif end < start + 2:
            found.add(
                "end_frame must exceed start_frame by at least 2",
                line,
                f"end_frame {end} must exceed start_frame {start} by at least 2 "
                "(frames are 0-based, end exclusive)",
                f"{start}-{end}",
            )
    elif decision in DECISIONS and decision != "adjust" and (start is not None or end is not None):
        found.add(
            f"{decision} takes frames",
            line,
            f"{decision} takes no frames (only adjust does); leave start_frame and end_frame empty",
        )
    if clip_id and clip_id in seen:
        found.add(
            "clip_id given twice",
            line,
            f"clip {clip_id!r} already has an override on line {seen[clip_id]}",
            repr(clip_id),
        )
    elif clip_id:
        seen[clip_id] = line
    if found.count > n_before:
        return None
    return Override(
        clip_id=clip_id,
        decision=decision,
        start_frame=start,
        end_frame=end,
        note=cell["note"],
        line=line,
    )


def read_overrides(
    path: str | os.PathLike[str], *, warn: Callable[[str], None] | None = None
) -> Overrides:
    """Read and check ``curation.csv`` (see the module docstring for its columns).

    The file is read by the one reader of user tables (:mod:`turn_datasets.usertable`):
    UTF-8 with or without a byte-order mark, header names ignoring case and spaces, a comma,
    semicolon or tab delimiter, blank lines skipped, each row's own line number. ``warn``
    is called with each thing the reader did that the file does not say (a semicolon
    export, padded cells: :func:`~turn_datasets.usertable.reading_notes`).

    Raises
    ------
    TurnbenchError
        A missing or unreadable file, a missing column; then every bad row in one error,
        grouped by kind, each naming its lines: an empty ``clip_id``, an unknown decision,
        frames given to ``exclude``/``keep``, missing or bad frames for ``adjust`` (not whole
        numbers, negative, or ``end_frame <= start_frame + 1``), a clip id given twice.
    """
    p = Path(path)
    if not p.is_file():
        raise TurnbenchError("no such overrides file", file=p)
    table = read_table(p, what="overrides", numeric_columns=(), allow_no_rows=True)
    for note in reading_notes(table):
        if warn is not None:
            warn(note)
    require(table, OVERRIDE_COLUMNS, what="the overrides file")
    out = Overrides(path=str(p), sha256=sha256_file(p))
    found = _RowProblems()
    seen: dict[str, int] = {}
    columns = [table.columns[c] for c in OVERRIDE_COLUMNS]
    for i, line in enumerate(table.lines.tolist()):
        cell = {c: str(values[i]) for c, values in zip(OVERRIDE_COLUMNS, columns, strict=True)}
        override = _check_row(cell, line, seen, found)
        if override is not None:
            out.by_id[override.clip_id] = override
    problems = Problems(str(p))
    found.into(problems)
    problems.raise_if_any("no override applied")
    return out


def apply_overrides(
    seq: MocapSequence,
    clips: SequenceClips,
    overrides: Overrides | None,
    params: MinerParams,
) -> tuple[SequenceClips, list[dict[str, Any]]]:
    """Apply the overrides that match one sequence's mined clips.

    Parameters
    ----------
    seq
        The sequence the clips were mined from (an ``adjust`` measures its new frames).
    clips
        Its clips (:func:`turn_datasets.h36m.miner.mine_clips`).
    overrides
        The overrides, or None.
    params
        The miner's parameters (an adjusted clip is measured with the same bridging and
        filtering).

    Returns
    -------
    clips, applied
        The curated clips, and one record per override applied (its fields, plus
        ``result_clip_id``: the clip's id after it, None when excluded).

    Raises
    ------
    TurnbenchError
        An ``adjust`` whose frames lie outside the sequence or across a long dropout, or
        are those of another kept clip of the sequence, naming the overrides file and line.
    """
    if overrides is None or not len(overrides) or not len(clips):
        return clips, []
    ids = clips.clip_ids
    hits = [(i, overrides.by_id[c]) for i, c in enumerate(ids) if c in overrides.by_id]
    if not hits:
        return clips, []
    start = clips.start_frame.copy()
    end = clips.end_frame.copy()
    angle = clips.angle_deg.copy()
    net = clips.net_deg.copy()
    hip = clips.hip_rotation_deg.copy()
    keep = np.ones(len(clips), dtype=bool)
    applied: list[dict[str, Any]] = []
    for i, ov in hits:
        record = ov.as_dict()
        if ov.decision == "exclude":
            keep[i] = False
            record["result_clip_id"] = None
        elif ov.decision == "keep":
            record["result_clip_id"] = ov.clip_id
        else:
            try:
                start_frame, end_frame = ov.frames
                turn = measure_clip(
                    seq.positions,
                    layout=seq.layout,
                    fps_hz=seq.fps,
                    start_frame=start_frame,
                    end_frame=end_frame,
                    params=params,
                )
            except TurnbenchError as exc:
                raise TurnbenchError(
                    f"cannot adjust {ov.clip_id}: {exc.message}", file=overrides.path, row=ov.line
                ) from None
            start[i], end[i] = ov.frames
            angle[i], net[i] = turn.angle_deg, turn.net_deg
            hip[i] = turn.hip_rotation_deg
            record["result_clip_id"] = clip_id_of(
                clips.subject, clips.action, clips.subaction, start[i], end[i]
            )
        applied.append(record)
    # An adjust onto the frames of another clip of the sequence would give two clips one id.
    pairs = list(zip(start[keep].tolist(), end[keep].tolist(), strict=True))
    for _, ov in hits:
        if ov.decision == "adjust" and pairs.count(ov.frames) > 1:
            raise TurnbenchError(
                f"adjusting {ov.clip_id} to frames {ov.start_frame}-{ov.end_frame} makes it "
                "the same clip as another one of its sequence; exclude one of them instead",
                file=overrides.path,
                row=ov.line,
            )
    return clips.replace_clips(start[keep], end[keep], angle[keep], net[keep], hip[keep]), applied


def unmatched_overrides(
    overrides: Overrides | None, applied: Iterable[Mapping[str, Any]]
) -> list[dict[str, Any]]:
    """The overrides that matched no mined clip, in file order."""
    if overrides is None:
        return []
    used = {a["clip_id"] for a in applied}
    return [
        ov.as_dict()
        for ov in sorted(overrides.by_id.values(), key=lambda o: o.line)
        if ov.clip_id not in used
    ]
