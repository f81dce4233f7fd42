"""Cut the clips of a Turn-H3.6M clip index out of the Human3.6M videos.

Human3.6M's videos are ``S*/Videos/<Action>.<camera>.mp4`` (four cameras, 50 fps, frame
``k`` of a video is frame ``k`` of the 50 Hz motion capture). For each clip of the index
(``clip_id, subject, action, subaction, start_frame, end_frame, fps``, frames 0-based with
``end_frame`` exclusive, DESIGN.md) and each camera found, frames ``start_frame`` to
``end_frame - 1`` are cut with the ffmpeg binary that ``imageio-ffmpeg`` ships and written to
``{clip_id}.{camera}.mp4``.

Frame accuracy
    The cut re-encodes (H.264, ``--crf``), so it does not snap to key frames. ffmpeg seeks
    accurately to half a frame before ``start_frame`` (``-ss`` before ``-i`` decodes from the
    previous key frame and drops what precedes the target), so the first frame out is
    exactly ``start_frame`` of a constant-rate video, then stops after
    ``end_frame - start_frame`` frames (``-frames:v``). The frame count of every cut is
    checked afterwards. When a video's frame rate differs from the index's ``fps``, frames are
    mapped through time: ``round(frame * video_fps / fps)``.

Video names are matched through :func:`turn_datasets.mocap.h36m.parse_h36m_action`, so the
index's canonical ``Photo`` finds ``TakingPhoto.55011271.mp4`` and ``WalkDog`` finds
``WalkingDog 1.58860488.mp4``; files whose names are no action (``_ALL.54138969.mp4``, the
whole session) are ignored.
"""

from __future__ import annotations

import os
import re
import subprocess
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import imageio_ffmpeg
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path, check_not_input, staged_dir
from turn_datasets.h36m.clip_index import read_clip_index
from turn_datasets.mocap.h36m import parse_h36m_action

__all__ = [
    "INDEX_COLUMNS",
    "ExportJob",
    "ExportPlan",
    "VideoInfo",
    "find_videos",
    "read_export_index",
    "plan_exports",
    "probe_video",
    "cut_clip",
    "export_clips",
]

#: The clip index columns this command needs (the index has more; they are ignored).
INDEX_COLUMNS = ("clip_id", "subject", "action", "subaction", "start_frame", "end_frame", "fps")
DEFAULT_CRF = 18

VideoKey = tuple[str, str, str]  # (subject, canonical action, subaction)


def find_videos(videos_dir: str | os.PathLike[str]) -> dict[VideoKey, dict[str, Path]]:
    """Index the videos under ``videos_dir``: (subject, action, subaction) -> camera -> path.

    ``videos_dir`` holds the subject folders (``S1/Videos/Walking 1.54138969.mp4``).

    Raises
    ------
    TurnbenchError
        The folder does not exist.
    """
    root = Path(videos_dir)
    if not root.is_dir():
        raise TurnbenchError("no such folder", file=root)
    out: dict[VideoKey, dict[str, Path]] = {}
    for video_folder in sorted(root.glob("S*/Videos")):
        subject = video_folder.parent.name
        if not re.fullmatch(r"S\d+", subject):
            continue
        for path in sorted(video_folder.glob("*.mp4")):
            if path.name.startswith("."):
                continue
            name, _, camera = path.stem.rpartition(".")
            if not name or not camera:
                continue
            try:
                action, subaction = parse_h36m_action(name)
            except TurnbenchError:
                continue  # "_ALL" and other whole-session videos are not actions
            out.setdefault((subject, action, subaction), {})[camera] = path
    return out


def read_export_index(path: str | os.PathLike[str]) -> pd.DataFrame:
    """The columns of a clip index that the export needs (:data:`INDEX_COLUMNS`), checked.

    ``INDEX_COLUMNS`` plus ``row`` (the CSV line number, 1 = header), with ``action``
    canonical, frames as int64 and ``fps`` as float64
    (:func:`turn_datasets.h36m.clip_index.read_clip_index`).
    """
    return read_clip_index(path, INDEX_COLUMNS, h36m_actions=True)


@dataclass(frozen=True)
class VideoInfo:
    """What the cut needs to know of a video."""

    n_frames: int
    fps: float


_FPS_RE = re.compile(r"Video:.*?(\d+(?:\.\d+)?) fps")
_FRAME_RE = re.compile(r"frame=\s*(\d+)")


def probe_video(path: str | os.PathLike[str], *, ffmpeg: str | None = None) -> VideoInfo:
    """Frame count and frame rate of a video, by copying its video stream to nowhere.

    Stream copy reads packets without decoding, so this is fast even for long videos.
    """
    exe = ffmpeg or imageio_ffmpeg.get_ffmpeg_exe()
    cmd = [exe, "-hide_banner", "-nostdin", "-i", str(path), "-map", "0:v:0", "-c", "copy"]
    proc = subprocess.run(
        [*cmd, "-f", "null", "-"], capture_output=True, text=True, errors="replace"
    )
    fps_match = _FPS_RE.search(proc.stderr)
    frames = _FRAME_RE.findall(proc.stderr)
    if proc.returncode != 0 or fps_match is None or not frames:
        last = proc.stderr.strip().splitlines()[-1:] or ["no output"]
        raise TurnbenchError(f"ffmpeg cannot read this video: {last[0]}", file=path)
    return VideoInfo(n_frames=int(frames[-1]), fps=float(fps_match.group(1)))


def cut_clip(
    video: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    start_frame: int,
    n_frames: int,
    video_fps: float,
    crf: int = DEFAULT_CRF,
    ffmpeg: str | None = None,
) -> Path:
    """Cut frames ``start_frame`` to ``start_frame + n_frames - 1`` of ``video`` into ``out``.

    Re-encoded with H.264 (``crf``), no audio, metadata dropped and bit-exact flags set so that
    the same input gives the same bytes; written atomically. See the module docstring for
    why the seek is frame-accurate.
    """
    exe = ffmpeg or imageio_ffmpeg.get_ffmpeg_exe()
    # half a frame early: the first frame whose time is at or after this is start_frame
    seek_s = max(0.0, (start_frame - 0.5) / video_fps)
    target = Path(out)
    with atomic_path(target) as tmp:
        cmd = [
            exe, "-hide_banner", "-nostdin", "-loglevel", "error", "-y",
            "-ss", f"{seek_s:.6f}", "-i", str(video),
            "-map", "0:v:0", "-frames:v", str(n_frames),
            "-vf", "setpts=PTS-STARTPTS", "-fps_mode", "passthrough", "-an",
            "-c:v", "libx264", "-crf", str(crf), "-preset", "veryfast", "-pix_fmt", "yuv420p",
            "-map_metadata", "-1", "-fflags", "+bitexact", "-flags:v", "+bitexact",
            "-f", "mp4", str(tmp),
        ]  # fmt: skip
        proc = subprocess.run(cmd, capture_output=True, text=True, errors="replace")
        if proc.returncode != 0:
            last = proc.stderr.strip().splitlines()[-1:] or [f"exit code {proc.returncode}"]
            raise TurnbenchError(f"ffmpeg failed to cut frames: {last[0]}", file=video)
    return target


@dataclass(frozen=True)
class ExportJob:
    """One output file: a clip seen by one camera."""

    clip_id: str
    camera: str
    video: Path
    start_frame: int  # in the video's frames
    n_frames: int
    video_fps: float
    row: int  # the clip's line in the index

    @property
    def out_name(self) -> str:
        return f"{self.clip_id}.{self.camera}.mp4"


@dataclass
class ExportPlan:
    """Every cut to make, and the clips without any video (``clip_id`` -> expected path)."""

    jobs: list[ExportJob] = field(default_factory=list)
    missing: dict[str, str] = field(default_factory=dict)


def plan_exports(
    index: pd.DataFrame,
    videos: dict[VideoKey, dict[str, Path]],
    *,
    index_path: str | os.PathLike[str],
    cameras: Sequence[str] | None = None,
    probe: Callable[[Path], VideoInfo] = probe_video,
) -> ExportPlan:
    """Match each clip to its videos and check its frames lie inside every one of them.

    Raises
    ------
    TurnbenchError
        A clip whose frames run past the end of a video (naming the index row and video).
    """
    plan = ExportPlan()
    infos: dict[Path, VideoInfo] = {}
    wanted = set(cameras) if cameras else None
    for rec in index.itertuples(index=False):
        found = videos.get((rec.subject, rec.action, rec.subaction), {})
        if wanted is not None:
            found = {cam: p for cam, p in found.items() if cam in wanted}
        if not found:
            on_disk = rec.action + (f" {rec.subaction}" if rec.subaction else "")
            cams = "|".join(sorted(wanted)) if wanted else "<camera>"
            plan.missing[rec.clip_id] = f"{rec.subject}/Videos/{on_disk}.{cams}.mp4"
            continue
        for camera in sorted(found):
            path = found[camera]
            if path not in infos:
                infos[path] = probe(path)
            info = infos[path]
            start = round(rec.start_frame * info.fps / rec.fps)
            end = round(rec.end_frame * info.fps / rec.fps)
            if end > info.n_frames:
                raise TurnbenchError(
                    f"clip {rec.clip_id} ends at video frame {end} but {path} has "
                    f"{info.n_frames} frames",
                    file=index_path,
                    row=rec.row,
                )
            plan.jobs.append(
                ExportJob(
                    clip_id=rec.clip_id,
                    camera=camera,
                    video=path,
                    start_frame=start,
                    n_frames=max(1, end - start),
                    video_fps=info.fps,
                    row=rec.row,
                )
            )
    return plan


def _identity(items: Iterable[ExportJob]) -> Iterator[ExportJob]:
    yield from items


def export_clips(
    index_path: str | os.PathLike[str],
    videos_dir: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    cameras: Sequence[str] | None = None,
    skip_missing: bool = False,
    crf: int = DEFAULT_CRF,
    progress: Callable[[list[ExportJob]], Iterable[ExportJob]] = _identity,
) -> ExportPlan:
    """Cut every clip of the index out of every camera's video into ``out_dir``.

    Everything is checked before the first cut (the index, a video for every clip, frames
    inside every video). The cuts are then made in a temporary folder beside ``out_dir``,
    each one's frame count checked, and moved into ``out_dir`` only when all succeeded: a
    bad input, or ffmpeg failing midway, leaves ``out_dir`` as it was.

    Parameters
    ----------
    cameras
        Only these camera ids (``54138969`` ...); default every camera found.
    skip_missing
        Cut the clips that have videos and return the others in ``plan.missing`` instead of
        failing.
    crf
        H.264 constant rate factor (0 lossless, 18 visually lossless, 51 worst).
    progress
        Wraps the list of jobs (a progress bar on the command line).

    Returns
    -------
    ExportPlan
        The cuts made and the clips left without video.

    Raises
    ------
    TurnbenchError
        Naming the index (and row) or the video: see :func:`read_export_index`,
        :func:`plan_exports`; clips without video unless ``skip_missing``; an ffmpeg failure
        or a cut whose frame count is wrong.
    """
    index = read_export_index(index_path)
    videos = find_videos(videos_dir)
    plan = plan_exports(index, videos, index_path=index_path, cameras=cameras)
    if plan.missing and not skip_missing:
        first = next(iter(plan.missing))
        row = int(index.loc[index["clip_id"] == first, "row"].iloc[0])
        shown = ", ".join(f"{cid} ({where})" for cid, where in list(plan.missing.items())[:5])
        more = f" and {len(plan.missing) - 5} more" if len(plan.missing) > 5 else ""
        raise TurnbenchError(
            f"no video for {len(plan.missing)} clip(s) under {videos_dir}: {shown}{more}",
            file=index_path,
            row=row,
            hint="pass --skip-missing to cut the others",
        )
    out = Path(out_dir)
    for folder in (out, *out.parents):
        if folder.exists():
            if not folder.is_dir():
                raise TurnbenchError("is a file, so --out-dir cannot be made there", file=folder)
            break
    inputs = [index_path, *sorted({job.video for job in plan.jobs})]
    for job in plan.jobs:
        check_not_input(out / job.out_name, inputs, option="--out-dir")
    exe = imageio_ffmpeg.get_ffmpeg_exe()
    try:
        # All cuts or none: they are made in a temporary folder beside out_dir and moved in
        # only when every one succeeded, so ffmpeg failing on the tenth clip leaves out_dir
        # as it was (files already there are kept; cuts of the same name are replaced).
        with staged_dir(out) as stage:
            for job in progress(plan.jobs):
                path = cut_clip(
                    job.video,
                    stage / job.out_name,
                    start_frame=job.start_frame,
                    n_frames=job.n_frames,
                    video_fps=job.video_fps,
                    crf=crf,
                    ffmpeg=exe,
                )
                got = probe_video(path, ffmpeg=exe).n_frames
                if got != job.n_frames:
                    raise TurnbenchError(
                        f"the cut of clip {job.clip_id} has {got} frames, expected "
                        f"{job.n_frames} (variable frame rate video?)",
                        file=job.video,
                    )
    except OSError as exc:
        raise TurnbenchError(f"cannot write the cuts: {exc.strerror or exc}", file=out) from None
    return plan
