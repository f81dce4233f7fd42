"""``turn-datasets h36m export-clips``: cut the clips of an index out of the Human3.6M videos."""

from __future__ import annotations

from pathlib import Path

import click

from turn_datasets.cli import h36m
from turn_datasets.cli.common import FILE, Number, progress, warn, wrote
from turn_datasets.h36m import export


@h36m.command("export-clips")
@click.argument("index", type=FILE)
@click.option(
    "--videos",
    "videos_dir",
    required=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="Human3.6M root holding S*/Videos/<Action>.<camera>.mp4 (50 fps).",
)
@click.option(
    "--out-dir",
    "--out",
    "out_dir",
    required=True,
    type=click.Path(path_type=Path),
    help="Folder for the cuts, named {clip_id}.{camera}.mp4 (created if needed); all cuts "
    "are written or, if one fails, none.",
)
@click.option(
    "--camera",
    "cameras",
    multiple=True,
    metavar="ID",
    help="Only this camera (e.g. 54138969); repeat for several. Default: every camera found.",
)
@click.option(
    "--skip-missing",
    is_flag=True,
    help="Cut the clips that have videos and list the others, instead of failing.",
)
@click.option(
    "--crf",
    type=Number(int, min=0, max=51),
    default=export.DEFAULT_CRF,
    show_default=True,
    help="H.264 quality of the re-encoded cuts (0 lossless, 51 worst).",
)
def export_clips_cmd(
    index: Path,
    videos_dir: Path,
    out_dir: Path,
    cameras: tuple[str, ...],
    skip_missing: bool,
    crf: int,
) -> None:
    """Cut each clip of a Turn-H3.6M INDEX.csv out of every camera's video.

    Frames start_frame to end_frame - 1 of S*/Videos/<Action>.<camera>.mp4 are cut
    frame-accurately (re-encoded, with the ffmpeg that imageio-ffmpeg ships) into
    OUT_DIR/{clip_id}.{camera}.mp4. Every clip is checked against its videos before the
    first cut; a clip without video fails the run unless --skip-missing.

    \b
    Example:
      turn-datasets h36m export-clips turn-h36m.csv --videos /data/human36m --out-dir clips/
      turn-datasets h36m export-clips turn-h36m.csv --videos /data/human36m \\
          --out-dir clips/ --camera 54138969 --skip-missing
    """
    plan = export.export_clips(
        index,
        videos_dir,
        out_dir,
        cameras=cameras or None,
        skip_missing=skip_missing,
        crf=crf,
        progress=lambda jobs: progress(jobs, label="cutting clips", length=len(jobs)),
    )
    for clip_id, where in plan.missing.items():
        warn(f"no video for clip {clip_id} (expected {where}); skipped")
    n_clips = len({job.clip_id for job in plan.jobs})
    n_cameras = len({job.camera for job in plan.jobs})
    skipped = f", {len(plan.missing)} clips without video skipped" if plan.missing else ""
    wrote(
        out_dir,
        what=f"{len(plan.jobs)} cuts ({n_clips} clips x {n_cameras} cameras{skipped}) to",
    )
