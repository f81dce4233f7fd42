"""``turn-eval estimate``: video to 3D skeletons, offline, with MediaPipe's bundled BlazePose."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from turn_datasets.cli.common import CONTEXT_SETTINGS, FPS_HZ, info, wrote
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import check_not_input, staged_dir
from turn_eval.cli import cli
from turn_eval.estimate.blazepose import load_mediapipe
from turn_eval.estimate.pipeline import EstimateParams, estimate_video, write_estimate
from turn_eval.estimate.timing import RATE_AGREEMENT_FRACTION

if TYPE_CHECKING:
    from click._termui_impl import ProgressBar


def _targets(videos: tuple[Path, ...], out: Path | None, out_dir: Path | None) -> list[str]:
    """The npz file name of each video, checked for clashes."""
    if (out is None) == (out_dir is None):
        raise TurnbenchError("give exactly one of --out FILE (one video) or --out-dir DIR")
    if out is not None:
        if len(videos) != 1:
            raise TurnbenchError(f"--out takes one video, got {len(videos)}; use --out-dir")
        if out.suffix.lower() != ".npz":
            raise TurnbenchError("the skeletons file must end in .npz", file=out)
        return [out.name]
    names: dict[str, Path] = {}
    for video in videos:
        name = video.stem + ".npz"
        if name in names:
            raise TurnbenchError(
                f"two videos would both write {name} (also {names[name]})",
                file=video,
                hint="rename one, or run them into different --out-dir folders",
            )
        names[name] = video
    return list(names)


class _FrameBar:
    """A progress bar over frames, sized when the first frame says how many to expect."""

    def __init__(self, label: str) -> None:
        self.label = label
        self._stack = contextlib.ExitStack()
        self._bar: ProgressBar[int] | None = None

    def __enter__(self) -> _FrameBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self._stack.close()

    def tick(self, expected_frames: int) -> None:
        if self._bar is None:
            self._bar = self._stack.enter_context(
                click.progressbar(
                    length=max(expected_frames, 1),
                    label=self.label,
                    file=sys.stderr,
                    show_pos=True,
                )
            )
        self._bar.update(1)


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
    help="Folder for <stem>.npz and <stem>.manifest.json per video.",
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
def estimate_command(
    videos: tuple[Path, ...],
    out: Path | None,
    out_dir: Path | None,
    preview_dir: Path | None,
    fps_hz: float | None,
    level: bool,
) -> None:
    """Estimate 3D skeletons from VIDEOS with MediaPipe Pose, offline on the CPU.

    Writes per video an .npz (the stem is the session; one (frames, 17, 3) array per
    tracked person, Human3.6M 17-joint order, metres, MediaPipe's world axes: x to the
    image's right, y down, z away from the camera; NaN where nobody is seen) and a
    manifest (video sha256, frame times, detection rate, identity breaks, versions).
    Variable-frame-rate videos are put on a regular grid at their nominal rate. When the
    tracker jumps to another person, the frames are split into tracks <stem>.t1, .t2, ...
    Needs the optional extra: pip install 'turnbench[video]'.

    \b
    Example:
      turn-eval estimate walk.mp4 --out walk.npz --preview qa/
      turn-eval estimate videos/*.mp4 --out-dir skeletons/
      turn-eval predict skeletons/*.npz --layout h36m17 --up-axis -y --out predictions.csv
    """
    names = _targets(videos, out, out_dir)
    for video in videos:
        if not video.is_file():
            raise TurnbenchError("no such video file", file=video)
    load_mediapipe()  # before any work: a missing extra is one line, exit 2
    params = EstimateParams(fps_hz=fps_hz, level=level)
    target_dir = out.parent if out is not None else out_dir
    assert target_dir is not None
    for name in names:
        check_not_input(
            target_dir / name, videos, option="--out" if out is not None else "--out-dir"
        )
    written: list[Path] = []
    with staged_dir(target_dir) as stage, contextlib.ExitStack() as previews:
        preview_stage = previews.enter_context(staged_dir(preview_dir)) if preview_dir else None
        for video, name in zip(videos, names, strict=True):
            preview = preview_stage / f"{video.stem}.preview.mp4" if preview_stage else None
            with _FrameBar(video.name) as bar:
                result = estimate_video(video, params=params, preview=preview, on_frame=bar.tick)
            write_estimate(result, stage / name)
            speed = result.manifest["speed"]["frames_per_s"] or 0.0
            breaks = len(result.manifest["identity_breaks"])
            info(
                f"{video.name}: {result.manifest['video']['n_decoded_frames']} frames, "
                f"person detected in {100 * result.detection_rate:.1f}% of "
                f"{result.n_frames}, {breaks} identity break{'' if breaks == 1 else 's'}, "
                f"{speed:.1f} frames/s"
            )
            written.append(target_dir / name)
    wrote(*written, what="skeletons (and manifests) to")
    if preview_dir is not None:
        wrote(preview_dir, what="QA previews to")
