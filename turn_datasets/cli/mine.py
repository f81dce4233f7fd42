"""``turn-datasets h36m mine`` and ``turn-datasets h36m stats`` (registered on the h36m group).

Thin: options are parsed here (the miner's from :class:`turn_datasets.h36m.miner.MinerParams`),
the work is :mod:`turn_datasets.h36m.corpus` and :mod:`turn_datasets.h36m.stats`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import pandas as pd

from turn_datasets.cli import h36m
from turn_datasets.cli.common import (
    FILE,
    FPS_HZ,
    counted,
    emit,
    file_option,
    format_option,
    info,
    layout_option,
    params_from,
    params_options,
    progress,
    up_axis_option,
    warn,
)
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import check_not_input, manifest_path, to_json_text
from turn_datasets.h36m.clip_index import read_clip_index
from turn_datasets.h36m.corpus import (
    find_sources,
    mine_corpus,
    passed_over_lines,
    write_corpus,
)
from turn_datasets.h36m.miner import MinerParams
from turn_datasets.h36m.overrides import read_overrides
from turn_datasets.h36m.stats import (
    STATS_INDEX_COLUMNS,
    STATS_OPTIONAL_COLUMNS,
    stats_csv,
    stats_dict,
    stats_markdown,
)
from turn_datasets.mocap.arrays import UNITS
from turn_datasets.mocap.bvh import parse_joint_map
from turn_datasets.mocap.readers import (
    FORMATS,
)
from turn_datasets.skeleton import AUTO


def _check_out_folder(out: Path) -> None:
    """Fail before mining, not after, when --out cannot be made: a file where a folder is."""
    for folder in out.parents:
        if folder.exists():
            if not folder.is_dir():
                raise TurnbenchError("is a file, so --out cannot be written under it", file=folder)
            return


@h36m.command("mine")
@click.argument(
    "sources", nargs=-1, required=True, type=click.Path(path_type=Path), metavar="SOURCE..."
)
@file_option(
    "--out",
    "out",
    required=True,
    help="Clip index CSV to write; the manifest goes beside it as <stem>.manifest.json.",
)
@click.option(
    "--format",
    "fmt",
    type=click.Choice(FORMATS),
    default=None,
    help="Read every source as this format instead of detecting it.",
)
@layout_option(
    default=None,
    help="Joint layout of generic arrays (.npy/.npz/.h5 of shape frames x joints x 3).",
)
@click.option("--fps", type=FPS_HZ, default=None, help="Frame rate of generic arrays, in Hz.")
@up_axis_option(
    default=None,
    help="Vertical axis of generic arrays (converted to z up). Default: auto, inferred per "
    "array from the trunk, signed by the head above the feet (recorded in the manifest).",
)
@click.option(
    "--units",
    type=click.Choice(UNITS),
    default=None,
    help="Length unit of generic arrays (recorded in the manifest; BVH: a label).",
)
@click.option(
    "--skip-first-frame/--keep-first-frame",
    default=None,
    help="BVH only: drop or keep frame 0. Default: drop it only when it is a rest pose "
    "(root rotation exactly zero and a jump to frame 1), the T-pose CMU's conversion adds.",
)
@click.option(
    "--joint-map",
    default=None,
    metavar="OURS=THEIRS,...",
    help="BVH only: joint names over CMU's built-in ones, e.g. left_hip=LHip,right_hip=RHip.",
)
@params_options(MinerParams)
@file_option(
    "--overrides",
    "overrides_path",
    default=None,
    help="Curation CSV (clip_id, decision, start_frame, end_frame, note) applied to the result.",
)
@click.option(
    "--skip-bad",
    is_flag=True,
    help="Write the index without unreadable files and unusable sequences (listed in the "
    "manifest) instead of failing.",
)
def mine_cmd(
    sources: tuple[Path, ...],
    out: Path,
    fmt: str | None,
    layout: str | None,
    fps: float | None,
    up_axis: str | None,
    units: str | None,
    skip_first_frame: bool | None,
    joint_map: str | None,
    overrides_path: Path | None,
    skip_bad: bool,
    **miner_options: float,
) -> None:
    """Mine turning clips from motion capture into a clip index and its manifest.

    SOURCE is a dataset root (the layout is detected: S*/MyPoseFeatures/D3_Positions/*.cdf,
    S*/MyPoses/3D_positions/*.h5, data_3d_h36m.npz, *.bvh), a file, or several of them. A
    clip is a run of rotation in one direction whose heading (the hip yaw averaged over a
    stride, so the pelvis' rotation with each step cancels) changes by at least
    --min-turn-deg, from where the heading starts to change to where it stops (see the
    miner's documentation for the rule); hip_rotation_deg keeps the paper's net hip
    rotation. By default any unreadable file, or unusable sequence in a file of many, fails
    the run (exit 2, nothing written) after all are listed; --skip-bad writes the index
    without them and lists them in the manifest. Folders reached through symbolic links are
    walked; a folder that cannot be read is listed like a bad file.

    VideoPose3D's npz holds a pickle, and unpickling can run code: it is read only when
    named, or as data_3d_h36m.npz at the top of a dataset root, after its header is checked,
    with an unpickler that builds NumPy arrays only. Any other npz is read as an array
    without unpickling (--format array), never because a walk met it.

    \b
    Example:
      turn-datasets h36m mine /data/human36m --out turn-h36m.csv
      turn-datasets h36m mine data_3d_h36m.npz --out turn-h36m.csv --overrides curation.csv
      turn-datasets h36m mine cmu/*.bvh --out cmu-turns.csv
      turn-datasets h36m mine poses.npy --layout h36m17 --fps 30 --up-axis y --units m \\
          --out turns.csv
      turn-datasets h36m mine remap-open/skeletons.npz --layout h36m17 --fps 30 --units m \\
          --out turns.csv   (up axis inferred)
      turn-datasets h36m mine visit1.npz --layout h36m17 --up-axis -y --fps 30 --units m \\
          --out turns.csv   (`turn-eval estimate`'s skeletons: see its manifest's fps_hz)
    """
    params = params_from(MinerParams, miner_options)
    jmap = parse_joint_map(joint_map) if joint_map else None
    mpath = manifest_path(out)
    _check_out_folder(out)
    overrides = read_overrides(overrides_path, warn=warn) if overrides_path is not None else None
    found = find_sources(sources, fmt=fmt)
    inputs = found.paths + ([overrides_path] if overrides_path else [])
    check_not_input(out, inputs)
    check_not_input(mpath, inputs)
    reader_options: dict[str, Any] = {
        "layout": layout,
        "fps": fps,
        "up_axis": up_axis,
        "units": units,
        "joint_map": jmap,
        "skip_first_frame": skip_first_frame,
    }
    corpus = mine_corpus(
        found,
        params,
        reader_options,
        overrides,
        fmt=fmt,
        skip_bad=skip_bad,
        on_problem=lambda exc: click.echo(f"turn-datasets: error: {exc}", err=True),
        iterate=lambda stream: progress(stream, label="mining sequences"),
    )
    for u in corpus.unmatched:
        path = overrides.path if overrides is not None else ""
        warn(f"override {u['clip_id']} ({u['decision']}, {path}:{u['line']}) matches no mined clip")
    for note in corpus.notes:
        warn(note)
    write_corpus(corpus, out)
    for line in passed_over_lines(found.passed_over, mpath):
        warn(line)
    if corpus.bad_files or corpus.bad_sequences:
        what = [f"{len(corpus.bad_files)} unreadable file(s)"] if corpus.bad_files else []
        if corpus.bad_sequences:
            what.append(f"{len(corpus.bad_sequences)} unusable sequence(s)")
        warn(f"skipped {' and '.join(what)}, listed in {mpath}")
    n_read = sum(1 for r in corpus.records if r.error is None)
    axes = sorted({a for r in corpus.records for a in r.up_axes})
    if axes:
        how = "stated" if up_axis not in (None, AUTO) else "inferred from the trunk"
        info(f"up axis of the arrays, {how}: {', '.join(axes)} (per file in the manifest)")
    info(
        f"wrote {counted(len(corpus.index), 'clip')} from "
        f"{counted(corpus.manifest['counts']['sequences'], 'sequence')} to {out}, manifest "
        f"{mpath} ({counted(n_read, 'file')} read)"
    )


@h36m.command("stats")
@click.argument("index_csv", type=FILE, metavar="INDEX.csv")
@click.option("--csv", "as_csv", is_flag=True, help="Same as --format csv.")
@format_option(default="md", choices=("md", "csv", "json"))
def stats_cmd(index_csv: Path, as_csv: bool, fmt: str) -> None:
    """Summarise a clip index as the paper's Table 3, and per subject and action.

    Table 3: per 45° bin, the number of clips, the smallest, largest and mean angle and the
    mean duration, with a Total row; then the same figures per subject and per action. An
    index with hip_rotation_deg (the paper's hip rotation, beside the heading change
    angle_deg) also gets Table 3 over that column and the median and quartiles of
    hip_rotation_deg - angle_deg. Markdown by default; --csv prints one CSV (table, group,
    clips, min_deg, max_deg, mean_deg, mean_duration_s).

    \b
    Example:
      turn-datasets h36m stats turn-h36m.csv
      turn-datasets h36m stats turn-h36m.csv --csv > table3.csv
    """
    index: pd.DataFrame = read_clip_index(
        index_csv, STATS_INDEX_COLUMNS, optional=STATS_OPTIONAL_COLUMNS
    )
    fmt = "csv" if as_csv else fmt
    if fmt == "csv":
        emit(stats_csv(index))
    elif fmt == "json":
        emit(to_json_text(stats_dict(index)))
    else:
        emit(stats_markdown(index))
