"""Curation that survives regeneration: overrides, the manifest, and the index's statistics.

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

The manifest, ``<index stem>.manifest.json`` beside the index, records how the index was
made: the tool version, every parameter, each input file with its sha256, size and the
number of sequences read from it, the units of each source, its ``frame_offset`` (1 for a BVH
whose rest-pose frame 0 was dropped, so that the index's frame k is the file's frame k + 1;
else 0), counts per bin, split, subject
and action, the overrides applied and unmatched, and the files and single sequences
skipped (``--skip-bad``; ``item`` names the sequence, null for a whole file).
Its ``created_utc`` timestamp is the only field that changes between two runs on the same
inputs.
"""

from __future__ import annotations

import csv
import datetime as _dt
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import sha256_file, typed_frame
from turn_datasets.geometry import quantise_deg
from turn_datasets.h36m.miner import MinerParams, SequenceClips, clip_id_of, measure_clip
from turn_datasets.limits import MAX_ANGLE_DEG
from turn_datasets.mocap.readers import natural_key
from turn_datasets.skeleton import MocapSequence

__all__ = [
    "DECISIONS",
    "OVERRIDE_COLUMNS",
    "STATS_COLUMNS",
    "Override",
    "Overrides",
    "read_overrides",
    "apply_overrides",
    "unmatched_overrides",
    "manifest_path",
    "build_manifest",
    "read_clip_index",
    "clip_stats",
    "table3",
    "stats_markdown",
    "stats_csv",
    "stats_dict",
]

DECISIONS = ("exclude", "keep", "adjust")
OVERRIDE_COLUMNS = ("clip_id", "decision", "start_frame", "end_frame", "note")
STATS_COLUMNS = {
    "clips": "int64",
    "min_deg": "float64",
    "max_deg": "float64",
    "mean_deg": "float64",
    "mean_duration_s": "float64",
}
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
    missing = [c for c in OVERRIDE_COLUMNS if c not in header]
    if missing:
        raise TurnbenchError(
            f"the header lacks {', '.join(missing)}; expected {','.join(OVERRIDE_COLUMNS)}",
            file=p,
            row=1,
        )
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
                turn = measure_clip(
                    seq.positions,
                    layout=seq.layout,
                    fps_hz=seq.fps,
                    start_frame=int(ov.start_frame),
                    end_frame=int(ov.end_frame),
                    **params.as_dict(),
                )
            except TurnbenchError as exc:
                raise TurnbenchError(
                    f"cannot adjust {ov.clip_id}: {exc.message}", file=overrides.path, row=ov.line
                ) from None
            start[i], end[i] = int(ov.start_frame), int(ov.end_frame)
            angle[i], net[i] = turn.angle_deg, turn.net_deg
            hip[i] = turn.hip_rotation_deg
            record["result_clip_id"] = clip_id_of(
                clips.subject, clips.action, clips.subaction, start[i], end[i]
            )
        applied.append(record)
    # An adjust onto the frames of another clip of the sequence would give two clips one id.
    pairs = list(zip(start[keep].tolist(), end[keep].tolist(), strict=True))
    for _, ov in hits:
        if ov.decision == "adjust" and pairs.count((int(ov.start_frame), int(ov.end_frame))) > 1:
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


def manifest_path(index_path: str | os.PathLike[str]) -> Path:
    """``turn-h36m.csv`` -> ``turn-h36m.manifest.json`` (beside the index)."""
    p = Path(index_path)
    stem = p.name[: -len(p.suffix)] if p.suffix else p.name
    return p.with_name(f"{stem}.manifest.json")


def _counts(series: pd.Series, key=None) -> dict[str, int]:
    counts = series.astype(str).value_counts()
    names = sorted(counts.index, key=key) if key else sorted(counts.index)
    return {str(n): int(counts[n]) for n in names}


def build_manifest(
    *,
    index: pd.DataFrame,
    params: MinerParams,
    reader_options: Mapping[str, Any],
    inputs: Sequence[Mapping[str, Any]],
    overrides: Overrides | None,
    applied: Sequence[Mapping[str, Any]],
    unmatched: Sequence[Mapping[str, Any]],
    skipped: Sequence[Mapping[str, Any]],
    n_sequences: int,
    n_frames: int,
    created_utc: str | None = None,
) -> dict[str, Any]:
    """The manifest as a JSON-ready dict (see the module docstring).

    ``created_utc`` defaults to now; every other field depends only on the inputs.
    """
    created = created_utc or _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    by_bin = index["bin_deg"].astype(int).value_counts()
    return {
        "tool": "turn-datasets h36m mine",
        "version": __version__,
        "created_utc": created,
        "parameters": {"miner": params.as_dict(), "reader": dict(reader_options)},
        "inputs": [dict(i) for i in inputs],
        "skipped": [dict(s) for s in skipped],
        "counts": {
            "sequences": int(n_sequences),
            "frames": int(n_frames),
            "clips": int(len(index)),
            "per_bin_deg": {str(b): int(by_bin[b]) for b in sorted(by_bin.index)},
            "per_split": _counts(index["split"].fillna("")),
            "per_subject": _counts(index["subject"], key=natural_key),
            "per_action": _counts(index["action"]),
            "per_direction": _counts(index["direction"]),
        },
        "overrides": {
            "file": None if overrides is None else overrides.path,
            "sha256": None if overrides is None else overrides.sha256,
            "applied": [dict(a) for a in applied],
            "unmatched": [dict(u) for u in unmatched],
        },
    }


# --- statistics (the paper's Table 3) -------------------------------------------------------

_STATS_NEEDS = ("subject", "action", "angle_deg", "duration_s", "bin_deg")


def read_clip_index(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a clip index CSV for statistics, checking the columns :func:`table3` needs.

    Raises
    ------
    TurnbenchError
        A missing or unreadable file, a missing column, or a row (naming its file line)
        whose ``angle_deg``, ``duration_s`` or ``bin_deg`` is not a finite number, whose
        angle is negative or duration not positive, or whose ``bin_deg`` is not
        :func:`turn_datasets.geometry.quantise_deg` of its angle.
    """
    p = Path(path)
    if not p.is_file():
        raise TurnbenchError("no such clip index", file=p)
    try:
        frame = pd.read_csv(
            p, dtype={"subject": str, "action": str, "subaction": str}, keep_default_na=False
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise TurnbenchError(f"cannot read the clip index: {exc}", file=p) from None
    missing = [c for c in _STATS_NEEDS if c not in frame.columns]
    if missing:
        raise TurnbenchError(f"not a clip index: no column {', '.join(missing)}", file=p, row=1)
    for col in ("angle_deg", "duration_s", "bin_deg"):
        values = pd.to_numeric(frame[col], errors="coerce")
        bad = ~np.isfinite(values.to_numpy(dtype=float))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise TurnbenchError(
                f"{col} {frame[col].iloc[i]!r} is not a finite number", file=p, row=i + 2
            )
        frame[col] = values.astype(float)
    # Table 3 groups by bin_deg: a bin that is not the angle's nearest multiple of 45 (an
    # angle edited by hand, a column shifted) would put a clip in the wrong row unnoticed.
    checks = (
        (frame["angle_deg"] < 0, "angle_deg {} is negative (it is a magnitude)", "angle_deg"),
        (
            frame["angle_deg"] > MAX_ANGLE_DEG,
            f"angle_deg {{}} is beyond the plausible {MAX_ANGLE_DEG:g} (see the README)",
            "angle_deg",
        ),
        (frame["duration_s"] <= 0, "duration_s {} is not positive", "duration_s"),
        (
            frame["bin_deg"] != quantise_deg(frame["angle_deg"].to_numpy()),
            "bin_deg {} is not the nearest multiple of 45 to angle_deg",
            "bin_deg",
        ),
    )
    for bad, message, col in checks:
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            value = frame[col].iloc[i]
            raise TurnbenchError(message.format(f"{value:g}"), file=p, row=i + 2)
    return frame


def clip_stats(index: pd.DataFrame, by: str) -> pd.DataFrame:
    """Clips, min, max and mean angle and mean duration per value of column ``by``.

    Groups are sorted (bins numerically, subjects S2 before S11, others by name); the index
    of the result is the group value as text.
    """
    if index.empty:
        return typed_frame(pd.DataFrame({c: [] for c in STATS_COLUMNS}), STATS_COLUMNS)
    keys = index[by].astype(int) if by == "bin_deg" else index[by].astype(str)
    grouped = index.groupby(keys, sort=False)
    frame = pd.DataFrame(
        {
            "clips": grouped.size(),
            "min_deg": grouped["angle_deg"].min(),
            "max_deg": grouped["angle_deg"].max(),
            "mean_deg": grouped["angle_deg"].mean(),
            "mean_duration_s": grouped["duration_s"].mean(),
        }
    )
    order = sorted(
        frame.index, key=(lambda v: v) if by == "bin_deg" else (lambda v: natural_key(str(v)))
    )
    frame = frame.loc[order]
    names = [str(v) for v in frame.index]
    out = typed_frame(frame.reset_index(drop=True), STATS_COLUMNS)
    out.index = pd.Index(names, name=by)
    return out


def table3(index: pd.DataFrame) -> pd.DataFrame:
    """The paper's Table 3: per 45° bin, clips, min/max/mean angle and mean duration, + Total."""
    per_bin = clip_stats(index, "bin_deg")
    total = pd.DataFrame(
        {
            "clips": [len(index)],
            "min_deg": [index["angle_deg"].min() if len(index) else np.nan],
            "max_deg": [index["angle_deg"].max() if len(index) else np.nan],
            "mean_deg": [index["angle_deg"].mean() if len(index) else np.nan],
            "mean_duration_s": [index["duration_s"].mean() if len(index) else np.nan],
        },
        index=pd.Index(["Total"], name="bin_deg"),
    )
    out = pd.concat(
        [per_bin, typed_frame(total.reset_index(drop=True), STATS_COLUMNS).set_axis(total.index)]
    )
    out.index.name = "bin_deg"
    return out


def _fmt(value: float, digits: int) -> str:
    return "–" if value is None or not np.isfinite(value) else f"{value:.{digits}f}"


def _md_table(first: str, frame: pd.DataFrame) -> list[str]:
    header = [first, "Clips", "Min (°)", "Max (°)", "Mean (°)", "Mean duration (s)"]
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(["---"] + ["---:"] * 5) + "|"]
    for name, r in frame.iterrows():
        label = f"**{name}**" if name == "Total" else str(name)
        cells = [
            label,
            str(int(r["clips"])),
            _fmt(r["min_deg"], 1),
            _fmt(r["max_deg"], 1),
            _fmt(r["mean_deg"], 1),
            _fmt(r["mean_duration_s"], 2),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def stats_markdown(index: pd.DataFrame) -> str:
    """Table 3, then the same figures per subject and per action, as Markdown."""
    lines = ["## Table 3: clips per angle bin", ""]
    lines += _md_table("Bin (°)", table3(index))
    lines += ["", "## Clips per subject", ""]
    lines += _md_table("Subject", clip_stats(index, "subject"))
    lines += ["", "## Clips per action", ""]
    lines += _md_table("Action", clip_stats(index, "action"))
    return "\n".join(lines) + "\n"


def _long(index: pd.DataFrame) -> pd.DataFrame:
    parts = []
    for name, frame in (
        ("bin", table3(index)),
        ("subject", clip_stats(index, "subject")),
        ("action", clip_stats(index, "action")),
    ):
        part = frame.reset_index(names="group")
        part.insert(0, "table", name)
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def stats_csv(index: pd.DataFrame) -> str:
    """The three tables as one CSV: ``table`` (bin, subject, action), ``group``, the figures."""
    return _long(index).to_csv(index=False, lineterminator="\n")


def stats_dict(index: pd.DataFrame) -> dict[str, Any]:
    """The three tables as JSON-ready dicts (NaN becomes null when written)."""
    out: dict[str, Any] = {}
    for name, frame in (
        ("table3", table3(index)),
        ("subject", clip_stats(index, "subject")),
        ("action", clip_stats(index, "action")),
    ):
        out[name] = {
            str(g): {k: (int(v) if k == "clips" else float(v)) for k, v in row.items()}
            for g, row in frame.iterrows()
        }
    return out
