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

import csv
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from turn_datasets.errors import TurnbenchError, require_columns
from turn_datasets.fileio import sha256_file
from turn_datasets.h36m.clip_index import SequenceClips, clip_id_of
from turn_datasets.h36m.miner import MinerParams, measure_clip
from turn_datasets.skeleton import MocapSequence

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


def _frame_field(text: str, *, name: str, path: str, line: int) -> int | None:
    text = text.strip()
    if text == "":
        return None
    if not _INT_RE.match(text):
        raise TurnbenchError(
            f"{name} {text!r} is not a whole number of frames", file=path, row=line
        )
    return int(text)


def read_overrides(path: str | os.PathLike[str]) -> Overrides:
    """Read and check ``curation.csv`` (see the module docstring for its columns).

    Raises
    ------
    TurnbenchError
        A missing or unreadable file, a missing column, an empty ``clip_id``, an unknown
        decision, frames given to ``exclude``/``keep``, missing or bad frames for ``adjust``
        (not whole numbers, negative, or ``end_frame <= start_frame + 1``), or a clip id given
        twice; each names the file and the line.
    """
    p = Path(path)
    if not p.is_file():
        raise TurnbenchError("no such overrides file", file=p)
    name = str(p)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise TurnbenchError(f"cannot read the overrides file: {exc}", file=p) from None
    reader = csv.reader(text.splitlines(keepends=True))
    try:
        header = [h.strip() for h in next(reader)]
    except StopIteration:
        raise TurnbenchError(
            f"the overrides file is empty; expected a header {','.join(OVERRIDE_COLUMNS)}",
            file=p,
            row=1,
        ) from None
    require_columns(header, OVERRIDE_COLUMNS, what="the overrides file", file=p)
    col = {c: header.index(c) for c in OVERRIDE_COLUMNS}
    out = Overrides(path=name, sha256=sha256_file(p))
    try:
        for fields in reader:
            line = reader.line_num
            if not any(f.strip() for f in fields):
                continue  # a blank line
            if len(fields) != len(header):
                raise TurnbenchError(
                    f"{len(fields)} fields, expected {len(header)} as in the header",
                    file=p,
                    row=line,
                )
            clip_id = fields[col["clip_id"]].strip()
            decision = fields[col["decision"]].strip().lower()
            if not clip_id:
                raise TurnbenchError("empty clip_id", file=p, row=line)
            if decision not in DECISIONS:
                raise TurnbenchError(
                    f"decision {fields[col['decision']]!r} is not one of {', '.join(DECISIONS)}",
                    file=p,
                    row=line,
                )
            start = _frame_field(
                fields[col["start_frame"]], name="start_frame", path=name, line=line
            )
            end = _frame_field(fields[col["end_frame"]], name="end_frame", path=name, line=line)
            if decision == "adjust":
                if start is None or end is None:
                    raise TurnbenchError("adjust needs start_frame and end_frame", file=p, row=line)
                if end < start + 2:
                    raise TurnbenchError(
                        f"end_frame {end} must exceed start_frame {start} by at least 2 "
                        "(frames are 0-based, end exclusive)",
                        file=p,
                        row=line,
                    )
            elif start is not None or end is not None:
                raise TurnbenchError(
                    f"{decision} takes no frames (only adjust does); leave start_frame and "
                    "end_frame empty",
                    file=p,
                    row=line,
                )
            if clip_id in out.by_id:
                raise TurnbenchError(
                    f"clip {clip_id!r} already has an override on line {out.by_id[clip_id].line}",
                    file=p,
                    row=line,
                )
            out.by_id[clip_id] = Override(
                clip_id=clip_id,
                decision=decision,
                start_frame=start,
                end_frame=end,
                note=fields[col["note"]].strip(),
                line=line,
            )
    except csv.Error as exc:
        raise TurnbenchError(f"malformed CSV: {exc}", file=p, row=reader.line_num) from None
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
