"""The Turn-H3.6M clip index: its columns, its ids and splits, building it from mined
sequences, and reading it back (``turn-datasets h36m mine``'s CSV), checked row by row.

The index's columns are DESIGN.md's contract (:data:`CLIP_INDEX_DTYPES`); the miner
(:mod:`turn_datasets.h36m.miner`) finds the clips of each sequence (:class:`SequenceClips`)
and :func:`build_index` makes them one table.
A command reads the columns it needs and nothing else, so an index with extra columns, or
from another corpus, is read as long as those columns are right. Every problem names the
file and its CSV line (1 = the header).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import angular_speed_deg_s, direction_of, quantise_deg
from turn_datasets.limits import MAX_ANGLE_DEG
from turn_datasets.mocap.h36m import parse_h36m_action
from turn_datasets.render.order import natural_key
from turn_datasets.usertable import read_table, require

__all__ = [
    "CLIP_INDEX_DTYPES",
    "TRAIN_SUBJECTS",
    "TEST_SUBJECTS",
    "split_of",
    "clip_id_of",
    "SequenceClips",
    "build_index",
    "read_clip_index",
]

#: The clip index (DESIGN.md), column order and dtypes.
CLIP_INDEX_DTYPES = MappingProxyType(
    {
        "clip_id": "str",
        "subject": "str",
        "action": "str",
        "subaction": "str",
        "split": "str",
        "start_frame": "int64",
        "end_frame": "int64",
        "n_frames": "int64",
        "fps": "float64",
        "start_s": "float64",
        "end_s": "float64",
        "duration_s": "float64",
        "angle_deg": "float64",
        "direction": "str",
        "bin_deg": "int64",
        "speed_deg_s": "float64",
        "hip_rotation_deg": "float64",
        "source": "str",
    }
)
#: Human3.6M's usual protocol: train on S1, S5, S6, S7, S8, test on S9 and S11.
TRAIN_SUBJECTS = ("S1", "S5", "S6", "S7", "S8")
TEST_SUBJECTS = ("S9", "S11")

#: Checked as a column, all rows at once: finite numbers, then each rule in order.
_NUMERIC = ("angle_deg", "duration_s", "bin_deg", "hip_rotation_deg")


def split_of(subject: str) -> str:
    """``train`` for S1, S5, S6, S7, S8; ``test`` for S9, S11; ``""`` for anything else."""
    if subject in TRAIN_SUBJECTS:
        return "train"
    if subject in TEST_SUBJECTS:
        return "test"
    return ""


def clip_id_of(subject: str, action: str, subaction: str, start_frame: int, end_frame: int) -> str:
    """``{subject}_{action}_{start}-{end}`` (DESIGN.md), spaces in the action replaced by ``-``.

    The action is written as on disk, trial included (``Walking 1`` -> ``Walking-1``), so
    the two trials of an action never share an id.
    """
    name = f"{action} {subaction}" if subaction else action
    name = re.sub(r"\s+", "-", name.strip())
    return f"{subject}_{name}_{int(start_frame)}-{int(end_frame)}"


@dataclass
class SequenceClips:
    """The clips of one sequence with what the index needs to know about the sequence.

    Arrays, not a DataFrame, so that mining a whole corpus builds one table at the end
    (:func:`build_index`). ``start_frame``/``end_frame`` are 0-based, end exclusive.
    """

    subject: str
    action: str
    subaction: str
    fps: float
    source: str
    start_frame: np.ndarray
    end_frame: np.ndarray
    angle_deg: np.ndarray
    net_deg: np.ndarray
    hip_rotation_deg: np.ndarray
    #: Why each run of turning that was not a clip was left out (the miner's
    #: ``rejection_reasons``: circling, too_fast), for the manifest's counts.
    rejected: tuple[str, ...] = ()

    def __len__(self) -> int:
        return int(self.start_frame.shape[0])

    @property
    def clip_ids(self) -> list[str]:
        return [
            clip_id_of(self.subject, self.action, self.subaction, s, e)
            for s, e in zip(self.start_frame.tolist(), self.end_frame.tolist(), strict=True)
        ]

    def replace_clips(
        self,
        start: np.ndarray,
        end: np.ndarray,
        angle: np.ndarray,
        net: np.ndarray,
        hip_rotation: np.ndarray,
    ) -> SequenceClips:
        """The same sequence with other clips, sorted by frames."""
        order = np.lexsort((end, start))
        return SequenceClips(
            self.subject,
            self.action,
            self.subaction,
            self.fps,
            self.source,
            np.asarray(start, dtype=np.int64)[order],
            np.asarray(end, dtype=np.int64)[order],
            np.asarray(angle, dtype=float)[order],
            np.asarray(net, dtype=float)[order],
            np.asarray(hip_rotation, dtype=float)[order],
            self.rejected,
        )

    def to_frame(self) -> pd.DataFrame:
        """Its rows of the clip index."""
        return build_index([self])


def build_index(parts: Iterable[SequenceClips]) -> pd.DataFrame:
    """The clip index (DESIGN.md's columns, in order, typed) from mined sequences.

    Rows are ordered by subject (S2 before S11), action, subaction, source and start frame,
    so the index does not depend on the order in which the sources were read.

    Raises
    ------
    TurnbenchError
        Two clips with the same id (the same sequence read twice, for example from both a
        CDF and an h5 copy), naming both sources.
    """
    seqs = sorted(
        (p for p in parts if len(p)),
        key=lambda p: (
            natural_key(p.subject),
            p.action,
            natural_key(p.subaction),
            p.source,
        ),
    )
    if not seqs:
        return typed_frame(pd.DataFrame({c: [] for c in CLIP_INDEX_DTYPES}), CLIP_INDEX_DTYPES)
    counts = [len(p) for p in seqs]

    def per_clip(values: list) -> np.ndarray:
        return np.repeat(np.asarray(values, dtype=object), counts)

    start = np.concatenate([p.start_frame for p in seqs])
    end = np.concatenate([p.end_frame for p in seqs])
    angle = np.concatenate([p.angle_deg for p in seqs])
    net = np.concatenate([p.net_deg for p in seqs])
    hip = np.concatenate([p.hip_rotation_deg for p in seqs])
    fps = np.repeat(np.asarray([p.fps for p in seqs], dtype=float), counts)
    duration = (end - start) / fps
    frame = pd.DataFrame(
        {
            "clip_id": [c for p in seqs for c in p.clip_ids],
            "subject": per_clip([p.subject for p in seqs]),
            "action": per_clip([p.action for p in seqs]),
            "subaction": per_clip([p.subaction for p in seqs]),
            "split": per_clip([split_of(p.subject) for p in seqs]),
            "start_frame": start,
            "end_frame": end,
            "n_frames": end - start,
            "fps": fps,
            "start_s": start / fps,
            "end_s": end / fps,
            "duration_s": duration,
            "angle_deg": angle,
            "direction": [direction_of(v) for v in net.tolist()],
            "bin_deg": np.asarray(quantise_deg(angle)).astype(np.int64),
            "speed_deg_s": angular_speed_deg_s(angle, duration),
            "hip_rotation_deg": hip,
            "source": per_clip([p.source for p in seqs]),
        }
    )
    dup = frame["clip_id"].duplicated(keep=False)
    if dup.any():
        first = frame.loc[dup, "clip_id"].iloc[0]
        sources = sorted(set(frame.loc[frame["clip_id"] == first, "source"]))
        raise TurnbenchError(
            f"clip id {first!r} occurs twice: the same subject and action were read from "
            f"{' and '.join(sources)}",
            hint="give each sequence once (one copy of the dataset)",
        )
    return typed_frame(frame, CLIP_INDEX_DTYPES)


def _read(p: Path, columns: Sequence[str]) -> pd.DataFrame:
    """The index as text, through the one reader of user tables (:mod:`turn_datasets.usertable`:
    UTF-8 with or without a byte-order mark, header names ignoring case and spaces); each
    row's CSV line in ``attrs["lines"]``."""
    if not p.is_file():
        raise TurnbenchError("no such file", file=p)
    table = read_table(p, what="clip index", numeric_columns=(), allow_no_rows=True)
    require(table, columns, what="the clip index")
    frame = pd.DataFrame({c: table.columns[c] for c in table.header if c}, dtype=object)
    frame.attrs["lines"] = table.lines
    return frame


def _check_rows(frame: pd.DataFrame, p: Path, *, h36m_actions: bool) -> pd.DataFrame:
    """clip_id unique and not empty, canonical actions, whole frames in order, fps > 0."""
    has = set(frame.columns)
    lines = frame.attrs["lines"]
    seen: dict[str, int] = {}
    for i, rec in enumerate(frame.to_dict("records")):
        line = int(lines[i])
        if "clip_id" in has:
            clip_id = rec["clip_id"].strip()
            if not clip_id:
                raise TurnbenchError("empty clip_id", file=p, row=line)
            if clip_id in seen:
                raise TurnbenchError(
                    f"clip_id {clip_id!r} repeats row {seen[clip_id]}", file=p, row=line
                )
            seen[clip_id] = line
        if h36m_actions:
            try:
                parse_h36m_action(rec["action"])
            except TurnbenchError as exc:
                raise TurnbenchError(exc.message, file=p, row=line) from None
        if {"start_frame", "end_frame"} <= has:
            try:
                start, end = int(rec["start_frame"]), int(rec["end_frame"])
            except ValueError:
                raise TurnbenchError(
                    f"start_frame {rec['start_frame']!r} / end_frame {rec['end_frame']!r} are "
                    "not whole numbers",
                    file=p,
                    row=line,
                ) from None
            if not 0 <= start < end:
                raise TurnbenchError(
                    f"frames must satisfy 0 <= start_frame < end_frame, got {start} and {end}",
                    file=p,
                    row=line,
                )
        if "fps" in has:
            try:
                fps = float(rec["fps"])
            except ValueError:
                fps = float("nan")
            if not fps > 0:
                raise TurnbenchError(f"fps must be positive, got {rec['fps']!r}", file=p, row=line)
    out = frame.copy()
    if "clip_id" in has:
        out["clip_id"] = out["clip_id"].str.strip()
    if h36m_actions:
        out["action"] = [parse_h36m_action(a)[0] for a in out["action"]]
    for col in ("subject", "subaction"):
        if h36m_actions and col in has:
            out[col] = out[col].str.strip()
    for col, dtype in (("start_frame", "int64"), ("end_frame", "int64"), ("fps", "float64")):
        if col in has:
            out[col] = out[col].astype(float).astype(dtype) if len(out) else out[col].astype(dtype)
    return out


def _check_angles(frame: pd.DataFrame, p: Path) -> pd.DataFrame:
    """Finite angles, durations and bins; angles >= 0, durations > 0, bins as quantised."""
    cols = [c for c in _NUMERIC if c in frame.columns]
    for col in cols:
        values = pd.to_numeric(frame[col], errors="coerce")
        bad = ~np.isfinite(values.to_numpy(dtype=float))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise TurnbenchError(
                f"{col} {frame[col].iloc[i]!r} is not a finite number",
                file=p,
                row=int(frame.attrs["lines"][i]),
            )
        frame[col] = values.astype(float)
    checks = []
    if "angle_deg" in cols:
        checks.append(
            (frame["angle_deg"] < 0, "angle_deg {} is negative (it is a magnitude)", "angle_deg")
        )
        checks.append(
            (
                frame["angle_deg"] > MAX_ANGLE_DEG,
                f"angle_deg {{}} is beyond the plausible {MAX_ANGLE_DEG:g} (see the README)",
                "angle_deg",
            )
        )
    if "duration_s" in cols:
        checks.append((frame["duration_s"] <= 0, "duration_s {} is not positive", "duration_s"))
    if "hip_rotation_deg" in cols:
        checks.append(
            (
                frame["hip_rotation_deg"] < 0,
                "hip_rotation_deg {} is negative (it is a magnitude)",
                "hip_rotation_deg",
            )
        )
    if {"angle_deg", "bin_deg"} <= set(cols):
        # a bin that is not the angle's nearest multiple of 45 (an angle edited by hand, a
        # column shifted) would put a clip in the wrong row of Table 3 unnoticed
        checks.append(
            (
                frame["bin_deg"] != quantise_deg(frame["angle_deg"].to_numpy()),
                "bin_deg {} is not the nearest multiple of 45 to angle_deg",
                "bin_deg",
            )
        )
    for bad, message, col in checks:
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            row = int(frame.attrs["lines"][i])
            raise TurnbenchError(message.format(f"{frame[col].iloc[i]:g}"), file=p, row=row)
    return frame


def read_clip_index(
    path: str | os.PathLike[str],
    columns: Sequence[str],
    *,
    h36m_actions: bool = False,
    optional: Sequence[str] = (),
) -> pd.DataFrame:
    """The ``columns`` of a clip index CSV, checked, plus ``row`` (its CSV line number).

    Parameters
    ----------
    path
        The index (``turn-datasets h36m mine``'s ``--out``).
    columns
        The columns the caller needs, in the order returned. Of these, ``clip_id`` must be
        non-empty and unique; ``start_frame``/``end_frame`` whole numbers with
        ``0 <= start_frame < end_frame`` (int64); ``fps`` positive (float64);
        ``angle_deg``, ``duration_s`` and ``bin_deg`` finite (float64), the angle not
        negative (a magnitude) nor beyond :data:`turn_datasets.limits.MAX_ANGLE_DEG`, the duration positive and the bin
        :func:`turn_datasets.geometry.quantise_deg` of the angle. Other columns are text
        (an empty cell is ``""``).
    optional
        Columns read (after ``columns``) and checked the same way when the file has them,
        such as ``hip_rotation_deg`` (finite, not negative), which older indexes lack.
    h36m_actions
        ``action`` must be a Human3.6M action (any spelling of
        :func:`turn_datasets.mocap.h36m.parse_h36m_action`) and is returned canonical;
        ``subject`` and ``subaction`` are returned stripped of spaces.

    Raises
    ------
    TurnbenchError
        A missing or unreadable file, a missing column, or the first bad row, naming its
        line.
    """
    p = Path(path)
    frame = _read(p, columns)
    lines = frame.attrs["lines"]
    frame = frame.loc[:, list(columns) + [c for c in optional if c in frame.columns]]
    frame.attrs["lines"] = lines
    frame = _check_rows(frame, p, h36m_actions=h36m_actions)
    frame.attrs["lines"] = lines
    frame = _check_angles(frame, p)
    frame["row"] = np.asarray(lines, dtype=np.int64)
    frame.attrs.pop("lines", None)
    return frame.reset_index(drop=True)
