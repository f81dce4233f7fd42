"""Turn-REMAP as released: the REMAP Open dataset's turns, read into turnbench's contracts.

The release (University of Bristol, REMAP Open dataset) holds the turning episodes of the
REMAP study, the source of the paper's Turn-REMAP (Cheng et al., Section 3.2), as one rater
spreadsheet (:mod:`turn_datasets.remap.open_sheet`) and one folder per turn::

    Turning/Data/turning_human_labels/Turning_human_labels.xls     (or .xlsx, or a CSV)
    Turning/Data/turning_2D3D_skeletons_coarsened/Turning_coarsen_CSV/
        Pt<participant>_<PD|C>_n_<turn id>/
            input_2D/keypoints.csv    one row per frame: x0,y0 ... x16,y16 (no header)
            input_3D/keypoints.csv    one row per frame: x0,y0,z0 ... x16,y16,z16 (no header)

The 17 joints are Human3.6M's (the paper's FastPose 2D detector and Strided Transformer
lifting), at the Kinect's 30 fps. Each turn is a clip of its own: its labels' ``start_s`` is 0
and ``end_s`` the spreadsheet's ``turning_duration`` (the release gives no video times),
``session``, ``annotator`` and ``location`` are empty and ``double_annotated`` false (the
release does not say which turns two raters labelled). The 3D axes and units are not documented (Strided
Transformer writes root-relative camera coordinates, y down): :func:`read_release` infers
the vertical axis of every clip (:mod:`turn_datasets.up_axis`) and records it, and leaves
the arrays as released, so ``turn-eval predict``, ``detect`` and ``h36m mine`` read them as
they are with ``--up-axis auto``.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import sha256_file, typed_frame
from turn_datasets.remap.labels import LABEL_COLUMNS
from turn_datasets.remap.open_sheet import SHEET_SUFFIXES, SheetRow, read_sheet
from turn_datasets.remap.participants import PARTICIPANT_COLUMNS
from turn_datasets.render.order import natural_key
from turn_datasets.skeleton import AUTO, H36M17
from turn_datasets.up_axis import AxesFound, resolve_up_axis

__all__ = [
    "OPEN_LABEL_COLUMNS",
    "FPS_HZ",
    "SHEET_STEM",
    "SKELETON_FOLDER",
    "Release",
    "find_release",
    "read_keypoints",
    "read_release",
    "release_manifest",
]

#: The labels contract plus the release's own labels (DESIGN.md, "Turn-REMAP as released").
OPEN_LABEL_COLUMNS = {
    **LABEL_COLUMNS,
    "steps": "Int64",
    "turn_type": "str",
    "medication": "str",
    "dbs": "str",
}
#: The Kinect's frame rate, as the release describes it.
FPS_HZ = 30.0
#: The spreadsheet's name without its suffix, and the folder of the per-turn folders.
SHEET_STEM = "turning_human_labels"
SKELETON_FOLDER = "turning_coarsen_csv"
_TURN_FOLDER = re.compile(r"^Pt(?P<participant>[^_]+)_(?P<group>PD|C)_n_(?P<turn>.+)$")
_GROUPS = {"PD": "PD", "C": "HC"}
_N_JOINTS = H36M17.n_joints


@dataclass
class Release:
    """What :func:`read_release` read: the outputs' contents and the manifest's facts."""

    labels: pd.DataFrame
    participants: pd.DataFrame
    skeletons: dict[str, np.ndarray]
    skeletons_2d: dict[str, np.ndarray]
    inputs: list[dict[str, Any]]
    axes: AxesFound
    missing: dict[str, list[str]] = field(default_factory=dict)
    no_2d: list[str] = field(default_factory=list)

    def counts(self) -> dict[str, dict[str, int]]:
        """Clips per cohort, medication, DBS state, angle bin, turn type and scenario."""
        out: dict[str, dict[str, int]] = {}
        for col in ("cohort", "medication", "dbs", "angle_deg", "turn_type", "scenario"):
            values = self.labels[col]
            if col == "angle_deg":
                values = values.map(lambda a: f"{a:g}")
            counts = values.astype(str).value_counts()
            key = (lambda v: float(v)) if col == "angle_deg" else (lambda v: v)
            out[col] = {str(v): int(counts[v]) for v in sorted(counts.index, key=key)}
        return out


def find_release(root: str | os.PathLike[str]) -> tuple[Path, Path]:
    """The rater spreadsheet and the folder of per-turn folders under ``root``.

    ``root`` is the dataset's top folder or any folder above the two data folders; names
    are matched in any case. Hidden folders are not searched; folders reached through links
    are, each real folder once (a link back up the tree ends the walk there).

    Raises
    ------
    TurnbenchError
        ``root`` is not a folder; no spreadsheet or two of them (both named); no
        ``Turning_coarsen_CSV`` folder or two of them.
    """
    top = Path(root)
    if not top.is_dir():
        raise TurnbenchError("not a folder", file=top, hint="give the REMAP Open dataset's folder")
    sheets: list[Path] = []
    folders: list[Path] = []
    seen: set[tuple[int, int]] = set()
    for dirpath, dirnames, filenames in os.walk(top, followlinks=True):
        here = Path(dirpath)
        stat = os.stat(dirpath)
        if (stat.st_dev, stat.st_ino) in seen:  # a link back to a folder walked: a loop
            dirnames[:] = []
            continue
        seen.add((stat.st_dev, stat.st_ino))
        if here.name.lower() == SKELETON_FOLDER:
            folders.append(here)
            dirnames[:] = []  # the turn folders themselves need no search
            continue
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        sheets += [
            here / f
            for f in sorted(filenames)
            if Path(f).stem.lower() == SHEET_STEM and Path(f).suffix.lower() in SHEET_SUFFIXES
        ]
    for what, many, found in (
        (
            "rater spreadsheet (Turning_human_labels.xls, .xlsx or .csv)",
            "rater spreadsheets",
            sheets,
        ),
        ("Turning_coarsen_CSV folder", "Turning_coarsen_CSV folders", folders),
    ):
        if not found:
            raise TurnbenchError(
                f"no {what} under this folder",
                file=top,
                hint="give the REMAP Open dataset's folder",
            )
        if len(found) > 1:
            raise TurnbenchError(
                f"{len(found)} {many} under this folder: " + ", ".join(str(p) for p in found),
                file=top,
                hint="keep one (a CSV export beside the .xls counts as a second)",
            )
    return sheets[0], folders[0]


def read_keypoints(path: Path, *, n_dims: int) -> np.ndarray:
    """One ``keypoints.csv``: ``(frames, 17, n_dims)`` float32, as released.

    Raises
    ------
    TurnbenchError
        Naming the file and line: a row without ``17 * n_dims`` fields, a cell that is not
        a finite number, no frame or a single frame.
    """
    width = _N_JOINTS * n_dims
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise TurnbenchError(f"cannot read the keypoints: {exc}", file=path) from None
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if len(lines) < 2:
        what = "no frame" if not lines else "one frame"
        raise TurnbenchError(
            f"the clip has {what}; a turn needs at least two", file=path, row=len(lines) or None
        )
    values = _fast_table(lines, width)
    if values is None:
        values = _checked_table(lines, width, n_dims, path)
    bad = ~np.isfinite(values)
    if bad.any():
        number, column = (int(i) + 1 for i in np.argwhere(bad)[0])
        cell = lines[number - 1].split(",")[column - 1].strip()
        raise TurnbenchError(
            f"field {column} ({cell!r}) is not a finite number", file=path, row=number
        )
    return values.reshape(len(lines), _N_JOINTS, n_dims).astype(np.float32)


def _fast_table(lines: list[str], width: int) -> np.ndarray | None:
    """NumPy's C parser on a well-formed file; None for anything else (the checked reader
    then finds the row and says what is wrong with it)."""
    try:
        values = np.loadtxt(lines, delimiter=",", dtype=np.float64, ndmin=2, comments=None)
    except ValueError:
        return None
    # loadtxt skips blank lines: a row count that differs means one was there
    return values if values.shape == (len(lines), width) else None


def _checked_table(lines: list[str], width: int, n_dims: int, path: Path) -> np.ndarray:
    """The table, row by row, raising on the first row of the wrong width or bad cell."""
    rows = [line.split(",") for line in lines]
    for number, cells in enumerate(rows, start=1):
        if len(cells) != width:
            raise TurnbenchError(
                f"{len(cells)} fields, expected {width} ({_N_JOINTS} joints x {n_dims})",
                file=path,
                row=number,
            )
    try:
        return np.array(rows, dtype=np.float64)
    except ValueError:
        return _first_bad_cell(rows, path)


def _first_bad_cell(rows: list[list[str]], path: Path) -> np.ndarray:
    for number, cells in enumerate(rows, start=1):
        for column, cell in enumerate(cells, start=1):
            try:
                float(cell)
            except ValueError:
                raise TurnbenchError(
                    f"field {column} ({cell!r}) is not a number", file=path, row=number
                ) from None
    raise AssertionError("numpy refused a table whose every cell is a number")  # pragma: no cover


def _turn_folders(folder: Path) -> dict[str, tuple[Path, re.Match[str]]]:
    """The per-turn folders by their turn id; a folder of another name is refused."""
    out: dict[str, tuple[Path, re.Match[str]]] = {}
    for child in sorted(folder.iterdir()):
        if child.name.startswith(".") or not child.is_dir():
            continue
        match = _TURN_FOLDER.match(child.name)
        if match is None:
            raise TurnbenchError(
                "not a turn folder name (Pt<participant>_<PD|C>_n_<turn id>)", file=child
            )
        turn = match.group("turn")
        if turn in out:
            raise TurnbenchError(
                f"turn id {turn!r} has two folders: also {out[turn][0].name}", file=child
            )
        out[turn] = (child, match)
    return out


def _missing_error(sheet: Path, no_row: list[str], no_folder: list[SheetRow]) -> TurnbenchError:
    parts = []
    if no_row:
        parts.append(f"{len(no_row)} turn folder(s) with no spreadsheet row: " + ", ".join(no_row))
    if no_folder:
        parts.append(
            f"{len(no_folder)} row(s) with no turn folder: "
            + ", ".join(f"row {r.row} (Turn ID {r.turn_id})" for r in no_folder)
        )
    return TurnbenchError(
        "; ".join(parts), file=sheet, hint="--allow-missing writes the rest and lists these"
    )


def _check_folder(row: SheetRow, folder: Path, match: re.Match[str], sheet: Path) -> None:
    subject = f"Pt{match.group('participant')}"
    cohort = _GROUPS[match.group("group")]
    if subject != row.subject or cohort != row.cohort:
        raise TurnbenchError(
            f"folder {folder.name} says {subject} {match.group('group')}, its row says "
            f"{row.subject} {'PD' if row.cohort == 'PD' else 'C'}",
            file=sheet,
            row=row.row,
        )


def _label(row: SheetRow, clip_id: str, source: str) -> dict[str, Any]:
    duration = row.duration_s
    return {
        "clip_id": clip_id,
        "session": "",
        "subject": row.subject,
        "cohort": row.cohort,
        "annotator": "",
        "start_s": 0.0 if math.isfinite(duration) else math.nan,
        "end_s": duration,
        "duration_s": duration,
        "angle_deg": row.angle_deg,
        "scenario": row.scenario,
        "location": "",
        "double_annotated": False,
        "source": f"{source}:{row.row}",
        "steps": pd.NA if row.steps is None else row.steps,
        "turn_type": row.turn_type,
        "medication": row.medication,
        "dbs": row.dbs,
    }


def _participants(rows: Iterable[SheetRow], sheet: Path) -> pd.DataFrame:
    cohort: dict[str, tuple[str, int]] = {}
    for r in rows:
        if r.subject in cohort and cohort[r.subject][0] != r.cohort:
            raise TurnbenchError(
                f"{r.subject} is {r.cohort} here and {cohort[r.subject][0]} on row "
                f"{cohort[r.subject][1]}",
                file=sheet,
                row=r.row,
            )
        cohort.setdefault(r.subject, (r.cohort, r.row))
    table = pd.DataFrame(
        [
            {
                "subject": s,
                "cohort": c,
                "pair": "",
                "sex": "",
                "age": math.nan,
                "years_since_diagnosis": math.nan,
            }
            for s, (c, _) in sorted(cohort.items(), key=lambda kv: natural_key(kv[0]))
        ],
        columns=list(PARTICIPANT_COLUMNS),
    )
    return typed_frame(table, PARTICIPANT_COLUMNS)


def read_release(
    root: str | os.PathLike[str],
    *,
    up_axis: str = AUTO,
    allow_missing: bool = False,
    progress: Callable[[Iterable[Any], int], Iterable[Any]] | None = None,
) -> Release:
    """Read the REMAP Open release under ``root`` into labels, participants and skeletons.

    Parameters
    ----------
    root
        The dataset's folder or any folder above its two data folders (:func:`find_release`).
    up_axis
        The 3D files' vertical axis, or ``auto`` to infer it per clip
        (:func:`turn_datasets.up_axis.infer_up_axis`); recorded in ``Release.axes``.
    allow_missing
        Read the turns that have both a row and a folder, and list the others in
        ``Release.missing``, instead of refusing.
    progress
        Wraps the iteration over the turns (a progress bar), given the count.

    Returns
    -------
    Release
        Labels (:data:`OPEN_LABEL_COLUMNS`, one row per turn in sheet order, ``clip_id`` the
        folder's name, ``source`` the spreadsheet and row), participants
        (:data:`~turn_datasets.remap.participants.PARTICIPANT_COLUMNS`, cohort only), the 3D
        and 2D arrays by ``clip_id``, every input with its sha256, the axes found.

    Raises
    ------
    TurnbenchError
        One line naming the file and row: the spreadsheet's problems
        (:func:`~turn_datasets.remap.open_sheet.read_sheet`), folders without rows and rows
        without folders (all listed), a folder whose participant or group disagrees with its
        row, a 2D-only folder, bad keypoints (:func:`read_keypoints`), an unclear axis.
    """
    sheet, folder = find_release(root)
    rows = read_sheet(sheet)
    folders = _turn_folders(folder)
    ids = {r.turn_id for r in rows}
    no_row = [p.name for turn, (p, _) in folders.items() if turn not in ids]
    no_folder = [r for r in rows if r.turn_id not in folders]
    if (no_row or no_folder) and not allow_missing:
        raise _missing_error(sheet, no_row, no_folder)
    top = Path(root)
    source = sheet.relative_to(top).as_posix()
    release = Release(
        labels=pd.DataFrame(),
        participants=_participants(rows, sheet),
        skeletons={},
        skeletons_2d={},
        inputs=[{"path": source, "sha256": sha256_file(sheet)}],
        axes=AxesFound(up_axis),
        missing={
            "folders_without_row": no_row,
            "rows_without_folder": [f"{source}:{r.row} (Turn ID {r.turn_id})" for r in no_folder],
        },
    )
    kept = [r for r in rows if r.turn_id in folders]
    labels = []
    for r in progress(kept, len(kept)) if progress else kept:
        path, match = folders[r.turn_id]
        _check_folder(r, path, match, sheet)
        _read_turn(release, path, top, up_axis)
        labels.append(_label(r, path.name, source))
    release.labels = typed_frame(
        pd.DataFrame(labels, columns=list(OPEN_LABEL_COLUMNS)), OPEN_LABEL_COLUMNS
    )
    return release


def _read_turn(release: Release, path: Path, top: Path, up_axis: str) -> None:
    """Read one turn folder's keypoints into ``release`` (3D required, 2D where present)."""
    file_3d = path / "input_3D" / "keypoints.csv"
    file_2d = path / "input_2D" / "keypoints.csv"
    if not file_3d.is_file():
        if file_2d.is_file():
            raise TurnbenchError(
                "the folder has 2D keypoints only (no input_3D/keypoints.csv)",
                file=path,
                hint="lift to 3D first",
            )
        raise TurnbenchError("no input_3D/keypoints.csv in this turn folder", file=path)
    clip_id = path.name
    positions = read_keypoints(file_3d, n_dims=3)
    try:
        axis = resolve_up_axis(positions, H36M17, up_axis)
    except TurnbenchError as exc:
        raise TurnbenchError(exc.message, file=file_3d, hint=exc.hint) from None
    release.axes.record(clip_id, axis)
    release.skeletons[clip_id] = positions
    release.inputs.append(
        {"path": file_3d.relative_to(top).as_posix(), "sha256": sha256_file(file_3d)}
    )
    if file_2d.is_file():
        release.skeletons_2d[clip_id] = read_keypoints(file_2d, n_dims=2)
        release.inputs.append(
            {"path": file_2d.relative_to(top).as_posix(), "sha256": sha256_file(file_2d)}
        )
    else:
        release.no_2d.append(clip_id)


def release_manifest(
    release: Release,
    *,
    root: str | os.PathLike[str],
    options: dict[str, Any],
    outputs: Iterable[str],
    created_utc: str,
) -> dict[str, Any]:
    """The manifest of ``turn-datasets remap open``: how its outputs were made.

    Tool version, the options, every input (relative to ``root``) with its sha256, counts
    per cohort, medication, DBS state, angle bin, turn type and scenario, the vertical axis
    found (:meth:`turn_datasets.up_axis.AxesFound.manifest`), the turns left out
    (``--allow-missing``) and the clips without 2D keypoints, and the files written.
    ``created_utc`` is the only field that differs between two runs on the same inputs.
    """
    from turn_datasets import __version__

    return {
        "tool": "turn-datasets remap open",
        "version": __version__,
        "created_utc": created_utc,
        "root": str(root),
        "options": dict(options),
        "fps": FPS_HZ,
        "layout": H36M17.name,
        "n_clips": int(len(release.labels)),
        "n_participants": int(len(release.participants)),
        "counts": release.counts(),
        "up_axis": release.axes.manifest(),
        "missing": release.missing,
        "no_2d": list(release.no_2d),
        "inputs": release.inputs,
        "outputs": sorted(outputs),
    }
