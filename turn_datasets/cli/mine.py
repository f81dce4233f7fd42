"""``turn-datasets h36m mine`` and ``turn-datasets h36m stats`` (registered on the h36m group).

Thin: options are parsed here, the work is :mod:`turn_datasets.mocap.readers`,
:mod:`turn_datasets.h36m.miner`, :mod:`turn_datasets.h36m.overrides`,
:mod:`turn_datasets.h36m.manifest` and :mod:`turn_datasets.h36m.stats`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import pandas as pd

from turn_datasets import limits
from turn_datasets.cli import h36m
from turn_datasets.cli.common import (
    ANGLE_DEG,
    DURATION_S,
    FPS_HZ,
    POSITIVE_DURATION_S,
    SPEED_DEG_S,
    Number,
    emit,
    format_option,
    info,
    progress,
    warn,
)
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path, check_not_input, sha256_file, to_json_text
from turn_datasets.h36m.clip_index import read_clip_index
from turn_datasets.h36m.manifest import build_manifest, manifest_path
from turn_datasets.h36m.miner import MinerParams, build_index, mine_clips
from turn_datasets.h36m.overrides import apply_overrides, read_overrides, unmatched_overrides
from turn_datasets.h36m.stats import STATS_INDEX_COLUMNS, stats_csv, stats_dict, stats_markdown
from turn_datasets.mocap.arrays import UNITS
from turn_datasets.mocap.bvh import parse_joint_map
from turn_datasets.mocap.readers import (
    FORMATS,
    SourceFile,
    discover,
    read_source,
    sorted_sources,
)
from turn_datasets.skeleton import LAYOUTS, UP_AXES

_D = MinerParams()


def _discover_each(
    sources: tuple[Path, ...], fmt: str | None, bad: dict[Path, TurnbenchError]
) -> list[SourceFile]:
    """Every source file to read, in path order; a named file that cannot even be opened is
    put in ``bad`` (listed or skipped like any unreadable file) instead of stopping the run.
    A missing path or a folder with nothing to read is a mistake in the command: it stops it.
    """
    found: list[SourceFile] = []
    for item in sources:
        try:
            found.extend(discover([item], fmt=fmt))
        except TurnbenchError as exc:
            if not item.is_file():
                raise
            bad[item] = exc
            found.append(SourceFile(item, fmt or "unknown"))
    return sorted_sources(found)


def _check_out_folder(out: Path) -> None:
    """Fail before mining, not after, when --out cannot be made: a file where a folder is."""
    for folder in out.parents:
        if folder.exists():
            if not folder.is_dir():
                raise TurnbenchError("is a file, so --out cannot be written under it", file=folder)
            return


def _sha256_or_none(path: Path) -> str | None:
    # a file that cannot even be opened was already reported as unreadable
    try:
        return sha256_file(path)
    except OSError:
        return None


@h36m.command("mine")
@click.argument(
    "sources", nargs=-1, required=True, type=click.Path(path_type=Path), metavar="SOURCE..."
)
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="Clip index CSV to write; the manifest goes beside it as <stem>.manifest.json.",
)
@click.option(
    "--format",
    "fmt",
    type=click.Choice(FORMATS),
    default=None,
    help="Read every source as this format instead of detecting it.",
)
@click.option(
    "--layout",
    type=click.Choice(sorted(LAYOUTS)),
    default=None,
    help="Joint layout of generic arrays (.npy/.npz/.h5 of shape frames x joints x 3).",
)
@click.option("--fps", type=FPS_HZ, default=None, help="Frame rate of generic arrays, in Hz.")
@click.option(
    "--up-axis",
    type=click.Choice(UP_AXES),
    default=None,
    help="Vertical axis of generic arrays (converted to z up).",
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
@click.option(
    "--min-turn-deg",
    type=ANGLE_DEG,
    default=_D.min_turn_deg,
    show_default=True,
    help="Smallest heading change of a clip, in degrees (the paper's 45).",
)
@click.option(
    "--max-gap-s",
    type=DURATION_S,
    default=_D.max_gap_s,
    show_default=True,
    help="Dropouts up to this long (seconds) are bridged; longer ones cut the sequence.",
)
@click.option(
    "--smooth-s",
    type=POSITIVE_DURATION_S,
    default=_D.smooth_s,
    show_default=True,
    help="Moving-mean window of the hip yaw against joint noise, in seconds.",
)
@click.option(
    "--start-speed-deg-s",
    type=Number(float, min=0, min_open=True, max=limits.MAX_SPEED_DEG_S),
    default=_D.start_speed_deg_s,
    show_default=True,
    help="A turn's heading must somewhere change faster than this, in degrees per second.",
)
@click.option(
    "--stop-speed-deg-s",
    type=SPEED_DEG_S,
    default=_D.stop_speed_deg_s,
    show_default=True,
    help="A turn lasts while its heading changes faster than this, in degrees per second.",
)
@click.option(
    "--merge-gap-s",
    type=DURATION_S,
    default=_D.merge_gap_s,
    show_default=True,
    help="Rotations in the same direction this close (seconds) are one turn.",
)
@click.option(
    "--position-cutoff-hz",
    type=Number(float, min=0, max=limits.MAX_FPS_HZ),
    default=_D.position_cutoff_hz,
    show_default=True,
    help="Zero-phase low-pass of the hip positions against joint noise, in Hz (0: off).",
)
@click.option(
    "--stride-s",
    type=POSITIVE_DURATION_S,
    default=_D.stride_s,
    show_default=True,
    help="Typical stride period, in seconds: the first guess when looking for the sway's period.",
)
@click.option(
    "--min-stride-s",
    type=POSITIVE_DURATION_S,
    default=_D.min_stride_s,
    show_default=True,
    help="Shortest stride period looked for in the knees' swing or the hip's sway, in seconds.",
)
@click.option(
    "--max-stride-s",
    type=POSITIVE_DURATION_S,
    default=_D.max_stride_s,
    show_default=True,
    help="Longest stride period looked for in the knees' swing or the hip's sway, in seconds.",
)
@click.option(
    "--no-sway-window-s",
    type=POSITIVE_DURATION_S,
    default=_D.no_sway_window_s,
    show_default=True,
    help="Heading-rate window where no stride shows (standing, turning in place), in seconds.",
)
@click.option(
    "--onset-deg",
    type=ANGLE_DEG,
    default=_D.onset_deg,
    show_default=True,
    help="Heading departure (degrees) from which, to four times it, boundaries are fitted.",
)
@click.option(
    "--overrides",
    "overrides_path",
    type=click.Path(dir_okay=False, path_type=Path),
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
    min_turn_deg: float,
    max_gap_s: float,
    smooth_s: float,
    start_speed_deg_s: float,
    stop_speed_deg_s: float,
    merge_gap_s: float,
    position_cutoff_hz: float,
    stride_s: float,
    min_stride_s: float,
    max_stride_s: float,
    no_sway_window_s: float,
    onset_deg: float,
    overrides_path: Path | None,
    skip_bad: bool,
) -> None:
    """Mine turning clips from motion capture into a clip index and its manifest.

    SOURCE is a dataset root (the layout is detected: S*/MyPoseFeatures/D3_Positions/*.cdf,
    S*/MyPoses/3D_positions/*.h5, data_3d_h36m.npz, *.bvh), a file, or several of them. A
    clip is a run of rotation in one direction whose heading (the hip yaw averaged over a
    stride, so the pelvis' rotation with each step cancels) changes by at least
    --min-turn-deg, from where the heading starts to change to where it stops (see the
    miner's documentation for the rule); hip_rotation_deg keeps the paper's net hip rotation. By default any unreadable file, or unusable sequence in a
    file of many, fails the run (exit 2, nothing written) after all are listed; --skip-bad
    writes the index without them and lists them in the manifest.

    \b
    Example:
      turn-datasets h36m mine /data/human36m --out turn-h36m.csv
      turn-datasets h36m mine data_3d_h36m.npz --out turn-h36m.csv --overrides curation.csv
      turn-datasets h36m mine cmu/*.bvh --out cmu-turns.csv
      turn-datasets h36m mine poses.npy --layout h36m17 --fps 30 --up-axis y --units m \\
          --out turns.csv
      turn-datasets h36m mine visit1.npz --layout h36m17 --up-axis -y --fps 30 --units m \\
          --out turns.csv   (`turn-eval estimate`'s skeletons: see its manifest's fps_hz)
    """
    params = MinerParams(
        min_turn_deg=min_turn_deg,
        max_gap_s=max_gap_s,
        smooth_s=smooth_s,
        start_speed_deg_s=start_speed_deg_s,
        stop_speed_deg_s=stop_speed_deg_s,
        merge_gap_s=merge_gap_s,
        position_cutoff_hz=position_cutoff_hz,
        stride_s=stride_s,
        min_stride_s=min_stride_s,
        max_stride_s=max_stride_s,
        no_sway_window_s=no_sway_window_s,
        onset_deg=onset_deg,
    )
    jmap = parse_joint_map(joint_map) if joint_map else None
    mpath = manifest_path(out)
    _check_out_folder(out)
    overrides = read_overrides(overrides_path) if overrides_path is not None else None
    bad: dict[Path, TurnbenchError] = {}
    files = _discover_each(sources, fmt, bad)
    inputs = [f.path for f in files] + ([overrides_path] if overrides_path else [])
    check_not_input(out, inputs)
    check_not_input(mpath, inputs)
    reader_kw: dict[str, Any] = {
        "layout": layout,
        "fps": fps,
        "up_axis": up_axis,
        "units": units,
        "joint_map": jmap,
        "skip_first_frame": skip_first_frame,
    }

    per_file: dict[Path, dict[str, Any]] = {
        f.path: {
            "clips": [],
            "applied": [],
            "sequences": 0,
            "frames": 0,
            "units": set(),
            "frame_offset": 0,
            "bad_sequences": [],
        }
        for f in files
    }

    def sequences():
        for src in files:
            if src.path in bad:
                continue
            # In a file of many sequences (VideoPose3D's npz holds all of Human3.6M) one
            # unusable sequence is listed or skipped alone; the file's others are still read.
            on_bad = per_file[src.path]["bad_sequences"].append
            try:
                for seq in read_source(src, **reader_kw, on_bad_sequence=on_bad):
                    yield src, seq
            except TurnbenchError as exc:
                bad[src.path] = (
                    exc if exc.where.file else TurnbenchError(exc.message, file=src.path)
                )

    for src, seq in progress(sequences(), label="mining sequences"):
        try:
            clips = mine_clips(seq, params)
        except TurnbenchError as exc:
            per_file[src.path]["bad_sequences"].append(exc)
            continue
        # curation errors (an adjust outside its sequence) are the curator's, not the file's:
        # they fail the run whatever --skip-bad says
        clips, applied = apply_overrides(seq, clips, overrides, params)
        state = per_file[src.path]
        state["clips"].append(clips)
        state["applied"].extend(applied)
        state["sequences"] += 1
        state["frames"] += seq.n_frames
        state["units"].add(seq.units)
        # a BVH whose frame 0 (a rest pose) was dropped: index frame k is the file's frame k + 1
        state["frame_offset"] = int(bool(seq.meta.get("skipped_first_frame", False)))

    bad = {f.path: bad[f.path] for f in files if f.path in bad}  # in path order
    # a file that could not be read at all drops the sequences it gave before failing
    bad_sequences = [
        (f.path, exc)
        for f in files
        if f.path not in bad
        for exc in per_file[f.path]["bad_sequences"]
    ]
    if (bad or bad_sequences) and not skip_bad:
        for exc in [*bad.values(), *(e for _, e in bad_sequences)]:
            click.echo(f"turn-datasets: error: {exc}", err=True)
        what = [f"{len(bad)} of {len(files)} files could not be read"] if bad else []
        if bad_sequences:
            what.append(f"{len(bad_sequences)} sequence(s) could not be used")
        raise TurnbenchError(
            f"{' and '.join(what)}; nothing written",
            hint="fix or remove them, or pass --skip-bad to write the index without them",
        )
    good = [f for f in files if f.path not in bad]
    if not any(per_file[f.path]["sequences"] for f in good):
        raise TurnbenchError("no sequence could be read from the sources; nothing written")

    index = build_index(c for f in good for c in per_file[f.path]["clips"])
    applied = [a for f in good for a in per_file[f.path]["applied"]]
    unmatched = unmatched_overrides(overrides, applied)
    for u in unmatched:
        warn(
            f"override {u['clip_id']} ({u['decision']}, {overrides.path}:{u['line']}) "
            "matches no mined clip"
        )
    inputs_record = []
    for f in files:
        state = per_file[f.path]
        inputs_record.append(
            {
                "path": str(f.path),
                "format": f.fmt,
                "sha256": _sha256_or_none(f.path),
                "bytes": f.path.stat().st_size if f.path.is_file() else None,
                "status": "skipped" if f.path in bad else "read",
                "sequences": state["sequences"] if f.path not in bad else 0,
                "frames": state["frames"] if f.path not in bad else 0,
                "units": sorted(state["units"]) if f.path not in bad else [],
                "frame_offset": state["frame_offset"],
                "skipped_sequences": len(state["bad_sequences"]) if f.path not in bad else 0,
            }
        )
    # whole files first (item null), then single sequences of files that were read
    skipped = [{"path": str(p), "item": None, "error": str(exc)} for p, exc in bad.items()]
    skipped += [
        {"path": str(p), "item": exc.where.item, "error": str(exc)} for p, exc in bad_sequences
    ]
    manifest = build_manifest(
        index=index,
        params=params,
        reader_options={**reader_kw, "format": fmt},
        inputs=inputs_record,
        overrides=overrides,
        applied=applied,
        unmatched=unmatched,
        skipped=skipped,
        n_sequences=sum(per_file[f.path]["sequences"] for f in good),
        n_frames=sum(per_file[f.path]["frames"] for f in good),
    )
    # Both files or neither: each is written to a temporary file and renamed at the end.
    try:
        with atomic_path(out) as tmp_index, atomic_path(mpath) as tmp_manifest:
            index.to_csv(tmp_index, index=False, lineterminator="\n")
            tmp_manifest.write_text(to_json_text(manifest), encoding="utf-8", newline="\n")
    except OSError as exc:
        # a folder that cannot be made or written (a file in the way, no permission, full)
        raise TurnbenchError(
            f"cannot write the clip index: {exc.strerror or exc}", file=out
        ) from None
    if skipped:
        what = [f"{len(bad)} unreadable file(s)"] if bad else []
        if bad_sequences:
            what.append(f"{len(bad_sequences)} unusable sequence(s)")
        warn(f"skipped {' and '.join(what)}, listed in {mpath}")
    info(
        f"wrote {len(index)} clips from {manifest['counts']['sequences']} sequences "
        f"to {out}, manifest {mpath}"
    )


@h36m.command("stats")
@click.argument("index_csv", type=click.Path(dir_okay=False, path_type=Path), metavar="INDEX.csv")
@click.option("--csv", "as_csv", is_flag=True, help="Same as --format csv.")
@format_option(default="md", choices=("md", "csv", "json"))
def stats_cmd(index_csv: Path, as_csv: bool, fmt: str) -> None:
    """Summarise a clip index as the paper's Table 3, and per subject and action.

    Table 3: per 45° bin, the number of clips, the smallest, largest and mean angle and the
    mean duration, with a Total row; then the same figures per subject and per action.
    Markdown by default; --csv prints one CSV (table, group, clips, min_deg, max_deg,
    mean_deg, mean_duration_s).

    \b
    Example:
      turn-datasets h36m stats turn-h36m.csv
      turn-datasets h36m stats turn-h36m.csv --csv > table3.csv
    """
    index: pd.DataFrame = read_clip_index(index_csv, STATS_INDEX_COLUMNS)
    fmt = "csv" if as_csv else fmt
    if fmt == "csv":
        emit(stats_csv(index))
    elif fmt == "json":
        emit(to_json_text(stats_dict(index)))
    else:
        emit(stats_markdown(index))
