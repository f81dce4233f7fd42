"""``turn-datasets remap open``: the REMAP Open release into Turn-REMAP's contracts.

Parses options, calls :func:`turn_datasets.remap.open_release.read_release`, writes, prints.
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path

import click

from turn_datasets.cli import CONTEXT_SETTINGS, remap
from turn_datasets.cli.common import (
    check_out_dir,
    counted,
    info,
    one_run,
    progress,
    up_axis_option,
    warn,
    wrote,
)
from turn_datasets.fileio import write_csv, write_json, write_npz
from turn_datasets.remap.open_release import read_release, release_manifest
from turn_datasets.skeleton import AUTO

#: What ``remap open`` writes into ``--out-dir`` (it owns these names there).
OPEN_FILES = (
    "labels.csv",
    "participants.csv",
    "skeletons.npz",
    "skeletons_2d.npz",
    "manifest.json",
)


def _turns(items, length: int):
    return progress(items, label="reading turns", length=length)


@remap.command("open", context_settings=CONTEXT_SETTINGS)
@click.argument("root", type=click.Path(file_okay=False, path_type=Path))
@click.option(
    "--out-dir",
    required=True,
    type=click.Path(path_type=Path),
    help="Folder for labels.csv, participants.csv, skeletons.npz, skeletons_2d.npz and "
    "manifest.json.",
)
@up_axis_option(
    default=AUTO,
    show_default=True,
    help="The 3D files' vertical axis; auto infers it per clip from the trunk, signed by the "
    "head above the feet (the release does not document its axes).",
)
@click.option(
    "--allow-missing",
    is_flag=True,
    help="Write the turns that have both a spreadsheet row and a folder; list the others in "
    "the manifest (default: refuse).",
)
def open_command(root: Path, out_dir: Path, up_axis: str, allow_missing: bool) -> None:
    """Read the REMAP Open dataset's turns (rater spreadsheet + per-turn skeleton CSVs).

    ROOT is the dataset's folder (Open_dataset_REMAP) or any folder above
    Turning/Data/turning_human_labels/Turning_human_labels.xls (or .xlsx, or a CSV export)
    and Turning/Data/turning_2D3D_skeletons_coarsened/Turning_coarsen_CSV/. OUT-DIR gets
    labels.csv (the Turn-REMAP labels contract plus steps, turn_type, medication, dbs),
    participants.csv, skeletons.npz and skeletons_2d.npz (one array per clip id, the turn
    folder's name, as released) and manifest.json (inputs with sha256, counts, the vertical
    axis found). Any bad input is one line naming the file and row, exit 2, nothing written.

    \b
    Example:
      turn-datasets remap open Open_dataset_REMAP --out-dir remap-open/
      turn-eval predict remap-open/skeletons.npz --layout h36m17 --fps 30 --out pred.csv
      turn-eval score pred.csv -r remap-open/labels.csv --by medication --by turn_type
    """
    check_out_dir(out_dir, OPEN_FILES, [root])
    release = read_release(root, up_axis=up_axis, allow_missing=allow_missing, progress=_turns)
    info(release.axes.summary())
    left_out = sum(len(v) for v in release.missing.values())
    if left_out:
        warn(
            f"left out {counted(left_out, 'turn')} without a row or a folder "
            "(listed in the manifest's 'missing')"
        )
    if release.no_2d:
        warn(f"{counted(len(release.no_2d), 'clip')} without 2D keypoints (manifest 'no_2d')")
    manifest = release_manifest(
        release,
        root=root,
        options={"up_axis": up_axis, "allow_missing": allow_missing},
        outputs=OPEN_FILES,
        created_utc=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
    )
    # every run writes all of OPEN_FILES: nothing of an earlier run is left to remove
    with one_run(out_dir, what="the REMAP Open outputs") as stage:
        write_csv(release.labels, stage / "labels.csv")
        write_csv(release.participants, stage / "participants.csv")
        write_npz(stage / "skeletons.npz", release.skeletons)
        write_npz(stage / "skeletons_2d.npz", release.skeletons_2d)
        write_json(stage / "manifest.json", manifest)
    wrote(
        out_dir,
        what=f"{counted(len(release.labels), 'turn')} of "
        f"{counted(len(release.participants), 'participant')} to",
    )
