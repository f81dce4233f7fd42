"""``turn-eval estimate``: video to 3D skeletons, offline, with MediaPipe's bundled BlazePose;
many videos serially or on Dask (``--workers``, ``--scheduler``), resumable (``--resume``)."""

from __future__ import annotations

import contextlib
import os
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import IO, Any

import click

from turn_datasets.cli.common import (
    CONTEXT_SETTINGS,
    FPS_HZ,
    Number,
    info,
    params_from,
    params_options,
    wrote,
)
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import check_not_input, write_json
from turn_eval.cli import cli
from turn_eval.estimate.batch import (
    RUN_MANIFEST,
    VideoJob,
    estimate_videos,
    run_manifest,
)
from turn_eval.estimate.blazepose import PoseParams, load_mediapipe
from turn_eval.estimate.guard import IdentityGuardParams
from turn_eval.estimate.pipeline import EstimateParams, manifest_path
from turn_eval.estimate.tilt import LevelParams
from turn_eval.estimate.timing import RATE_AGREEMENT_FRACTION
from turn_eval.estimate.video import expected_frames
from turn_eval.mapping import WORKER_WAIT_S, check_scheduler_address


def _jobs(
    videos: tuple[Path, ...], out: Path | None, out_dir: Path | None, preview_dir: Path | None
) -> list[VideoJob]:
    """Each video's outputs, checked for clashes with each other and with the inputs."""
    if (out is None) == (out_dir is None):
        raise TurnbenchError("give exactly one of --out FILE (one video) or --out-dir DIR")
    if out is not None:
        if len(videos) != 1:
            raise TurnbenchError(f"--out takes one video, got {len(videos)}; use --out-dir")
        if out.suffix.lower() != ".npz":
            raise TurnbenchError("the skeletons file must end in .npz", file=out)
    names: dict[str, Path] = {}
    jobs = []
    for video in videos:
        npz = out if out is not None else out_dir / (video.stem + ".npz")  # type: ignore[operator]
        if npz.name in names:
            raise TurnbenchError(
                f"two videos would both write {npz.name} (also {names[npz.name]})",
                file=video,
                hint="rename one, or run them into different --out-dir folders",
            )
        if out_dir is not None and manifest_path(npz).name == RUN_MANIFEST:
            raise TurnbenchError(
                f"its manifest would be {RUN_MANIFEST}, the run manifest's name",
                file=video,
                hint="rename the video",
            )
        names[npz.name] = video
        preview = preview_dir / f"{video.stem}.preview.mp4" if preview_dir else None
        jobs.append(VideoJob(video, npz, preview))
    option = "--out" if out is not None else "--out-dir"
    for job in jobs:
        for target in (job.npz, manifest_path(job.npz)):
            check_not_input(target, videos, option=option)
        if job.preview is not None:
            check_not_input(job.preview, videos, option="--preview")
    if out_dir is not None:
        check_not_input(out_dir / RUN_MANIFEST, videos, option="--out-dir")
    return jobs


def _video_line(row: dict) -> str:
    name = Path(row["video"]).name
    if row["status"] == "resumed":
        return f"{name}: done before (same video, version and options): skipped"
    if row["status"] == "failed":
        return f"skipped {row['video']}: {row['error']}"
    breaks = row["identity_breaks"]
    return (
        f"{name}: {row['decoded_frames']} frames, person detected in "
        f"{100 * row['detection_rate']:.1f}% of {row['frames']}, {breaks} identity "
        f"break{'' if breaks == 1 else 's'}, {row['frames_per_s'] or 0.0:.1f} frames/s"
    )


class _Progress:
    """A bar over every video's frames, on a terminal; a line per video either way.

    The bar draws on its own duplicate of the terminal's descriptor: MediaPipe's native
    chatter is held on descriptor 2 while a video is tracked (turn_eval.estimate.blazepose),
    and the bar must not be held with it.
    """

    def __init__(self, label: str) -> None:
        self.label = label
        self._stack = contextlib.ExitStack()
        self._stream: IO[str] | None = None
        self._bar: Any = None

    def __enter__(self) -> _Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self._stack.close()

    def start(self, jobs: list[VideoJob]) -> None:
        if not jobs or not sys.stderr.isatty():
            return
        total = sum(expected_frames(job.video) for job in jobs)
        self._stream = self._stack.enter_context(os.fdopen(os.dup(2), "w", buffering=1))
        bar = click.progressbar(
            length=max(total, 1), label=self.label, file=self._stream, show_pos=True
        )
        self._bar = self._stack.enter_context(bar)

    def frames(self, n: int) -> None:
        if self._bar is not None:
            self._bar.update(n)

    def video(self, row: dict) -> None:
        if self._stream is not None:
            self._stream.write("\r\x1b[K" + _video_line(row) + "\n")
        else:
            info(_video_line(row))


@contextlib.contextmanager
def _made_if_missing(*folders: Path | None):
    """Create the output folders; remove those made here if the run leaves them empty."""
    made = [f for f in folders if f is not None and not f.exists()]
    for f in made:
        f.mkdir(parents=True, exist_ok=True)
    try:
        yield
    finally:
        for f in made:
            with contextlib.suppress(OSError):
                f.rmdir()  # only if empty


@cli.command("estimate", context_settings=CONTEXT_SETTINGS)
@click.argument("videos", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Skeletons .npz to write for one video (manifest beside it).",
)
@click.option(
    "--out-dir",
    type=click.Path(file_okay=False, path_type=Path),
    help=f"Folder for <stem>.npz and <stem>.manifest.json per video, and {RUN_MANIFEST}.",
)
@click.option(
    "--preview",
    "preview_dir",
    type=click.Path(file_okay=False, path_type=Path),
    help="Also write <stem>.preview.mp4 here: the frames with the tracked skeleton drawn.",
)
@click.option(
    "--fps",
    "fps_hz",
    type=FPS_HZ,
    default=None,
    help="Frame rate of the output grid, Hz. Default: the rate the video declares when its "
    "frames' median interval agrees with it (within "
    f"{100 * RATE_AGREEMENT_FRACTION:g}%), else one over that median interval "
    "(a phone's variable rate); the manifest records the rate used.",
)
@click.option(
    "--level/--no-level",
    default=True,
    show_default=True,
    help="Rotate the skeletons so the floor is level (removes the camera's tilt).",
)
@params_options(PoseParams)
@params_options(IdentityGuardParams)
@params_options(LevelParams)
@click.option(
    "--workers",
    type=Number(int, min=1, max=4096),
    default=None,
    help="Estimate videos on a local Dask cluster of N processes (default: one after another).",
)
@click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="Use a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (see --help).",
)
@click.option(
    "--resume",
    is_flag=True,
    help="Skip videos whose outputs exist from the same video, version and options.",
)
@click.option(
    "--skip-bad",
    is_flag=True,
    help=f"List a video that cannot be used in {RUN_MANIFEST} and go on, instead of stopping.",
)
def estimate_command(
    videos: tuple[Path, ...],
    out: Path | None,
    out_dir: Path | None,
    preview_dir: Path | None,
    fps_hz: float | None,
    level: bool,
    workers: int | None,
    scheduler: str | None,
    resume: bool,
    skip_bad: bool,
    **param_values: float,
) -> None:
    """Estimate 3D skeletons from VIDEOS with MediaPipe Pose, offline on the CPU.

    Writes per video an .npz (the stem is the session; one (frames, 17, 3) array per
    tracked person, Human3.6M 17-joint order, metres, MediaPipe's world axes: x to the
    image's right, y down, z away from the camera; NaN where nobody is seen) and a
    manifest (video sha256, frame times, detection rate, identity breaks, versions).
    Variable-frame-rate videos are put on a regular grid at their nominal rate. When the
    tracker jumps to another person, the frames are split into tracks <stem>.t1, .t2, ...
    Only the named local files are read; a truncated video is refused. The pose model's
    confidences, the identity guard's thresholds and the levelling's upright frames are
    options below; every manifest records them.

    Many videos: --workers N maps them over N local processes, --scheduler over a running
    Dask cluster (every worker needs turnbench with the video extra and the videos, and
    --preview's folder, at the same absolute paths; a scheduler that no worker joins within
    WAIT s is an error). Each video's files land whole as it finishes; --resume skips those
    done before with the same video, version and options, so a stopped run carries on.
    --out-dir also gets estimate.manifest.json: every video's sha256, frames, detection
    rate, tracks, wall time and status. Needs the extra: pip install 'turnbench[video]'.

    \b
    Example:
      turn-eval estimate walk.mp4 --out walk.npz --preview qa/
      turn-eval estimate videos/*.mp4 --out-dir skeletons/ --workers 2 --resume
      turn-eval detect skeletons/ --from turnbench --fps 30 --out detections.csv
    """
    jobs = _jobs(videos, out, out_dir, preview_dir)
    for video in videos:
        if not video.is_file():
            raise TurnbenchError("no such video file", file=video)
    if scheduler:
        check_scheduler_address(scheduler)
    else:
        load_mediapipe()  # before any work: a missing extra is one line, exit 2
    params = EstimateParams(
        fps_hz=fps_hz,
        level=level,
        pose=params_from(PoseParams, param_values),
        guard=params_from(IdentityGuardParams, param_values),
        levelling=params_from(LevelParams, param_values),
    )
    where = f" on {scheduler}" if scheduler else (f" on {workers} local workers" if workers else "")
    started_utc = datetime.now(timezone.utc).isoformat(timespec="seconds")
    with (
        _made_if_missing(out.parent if out else out_dir, preview_dir),
        _Progress(
            f"estimating {len(jobs)} video{'' if len(jobs) == 1 else 's'}{where}"
        ) as progress,
    ):
        run = estimate_videos(
            jobs,
            params=params,
            workers=workers,
            scheduler=scheduler,
            resume=resume,
            skip_bad=skip_bad,
            on_video=progress.video,
            on_progress=progress.frames,
            on_start=progress.start,
        )
        if out_dir is not None:
            options = {
                "preview": None if preview_dir is None else str(preview_dir),
                "workers": workers,
                "scheduler": scheduler,
                "resume": resume,
                "skip_bad": skip_bad,
            }
            manifest = run_manifest(run, params=params, options=options, started_utc=started_utc)
            write_json(out_dir / RUN_MANIFEST, manifest)
    if out is not None:
        wrote(out, what="skeletons (and manifests) to")
    elif out_dir is not None:
        c = manifest["counts"]
        wrote(
            out_dir,
            out_dir / RUN_MANIFEST,
            what=f"skeletons (and manifests) of {c['videos']} videos ({c['done']} estimated, "
            f"{c['resumed']} resumed, {c['failed']} failed) to",
        )
    if preview_dir is not None:
        wrote(preview_dir, what="QA previews to")


estimate_command.help = (estimate_command.help or "").replace("WAIT s", f"{WORKER_WAIT_S} s")
