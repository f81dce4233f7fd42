"""Many videos in one run: serially or on Dask, resumable, with a run manifest.

A week of home video is hundreds of hours, and pose estimation is the costliest step of the
whole path, so ``turn-eval estimate VIDEOS --out-dir DIR`` maps :func:`estimate_file` over
the videos with :func:`turn_eval.mapping.map_files` (the mapping ``detect`` uses): one video
per task, serially or on a local or running Dask cluster, the results identical byte for
byte. Each video's outputs land as soon as it is done, each file whole (written aside,
then renamed) and the manifest last: a run stopped by Ctrl-C, SIGTERM or a dead worker
leaves complete outputs only, and ``--resume`` carries on from there.

``--resume`` skips a video whose outputs are complete (:func:`finished`): its manifest
records the same video sha256, the same turnbench version and the same options, and the
sha256 of the npz beside it (and its preview exists, when previews are asked for).
Anything else is done again.

A video that cannot be used (not decodable, truncated, not reachable from a worker, a
worker that died on it) stops the run naming it, or with ``skip_bad`` is listed as failed,
its stale outputs of an earlier run removed, and the run goes on. The run manifest
(:data:`RUN_MANIFEST`, :func:`run_manifest`) lists every video with its sha256, frames,
detection rate, tracks, wall time and status: a study's provenance in one file.

Memory: frames are streamed from ffmpeg and never held whole; a worker holds one video's
landmarks (a few kilobytes a frame), and this process one video's arrays at a time.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from turn_datasets import __version__
from turn_datasets.fileio import check_output_path, sha256_file, to_json_text
from turn_eval.estimate.pipeline import (
    EstimateParams,
    SkeletonEstimate,
    estimate_video,
    manifest_path,
    write_estimate,
)
from turn_eval.mapping import Failure, map_files

__all__ = [
    "RUN_MANIFEST",
    "EstimateRun",
    "VideoJob",
    "estimate_file",
    "estimate_videos",
    "finished",
    "run_manifest",
]

#: The run manifest's name in ``--out-dir``.
RUN_MANIFEST = "estimate.manifest.json"


@dataclass(frozen=True)
class VideoJob:
    """One video and where its outputs go (the npz; the manifest beside it; the preview)."""

    video: Path
    npz: Path
    preview: Path | None = None


@dataclass
class EstimateRun:
    """One row per video, in input order (:func:`run_manifest` gives the columns)."""

    videos: list[dict] = field(default_factory=list)
    wall_s: float = 0.0


def _tmp_name(target: Path, token: str) -> Path:
    return target.with_name(f".{target.name}.{token}.tmp")


def estimate_file(
    path: str,
    *,
    sha256: str,
    params: EstimateParams,
    preview: str | None = None,
    token: str = "",
    on_progress: Callable[[int], None] | None = None,
) -> SkeletonEstimate:
    """One video's skeletons (the task :func:`estimate_videos` maps); its preview, when
    asked for, lands at ``preview`` (written aside as ``.<name>.<token>.tmp`` meanwhile),
    unless something not a regular file has appeared there since the run's checks."""
    tmp = _tmp_name(Path(preview), token or uuid.uuid4().hex) if preview else None
    try:
        result = estimate_video(
            path,
            params=params,
            preview=tmp,
            on_frame=None if on_progress is None else (lambda _expected: on_progress(1)),
            sha256=sha256,
        )
        if tmp is not None and preview is not None:
            # checked before the run; again here: minutes went by, and a rename replaces
            # whatever has the name (a FIFO, a link) as the npz's atomic write never does
            check_output_path(preview, option="--preview")
            os.replace(tmp, preview)
    finally:
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
    return result


def _options(params: EstimateParams) -> Any:
    """The options as a manifest records them (JSON's own types)."""
    return json.loads(to_json_text(asdict(params)))


def finished(job: VideoJob, sha256: str, params: EstimateParams) -> dict | None:
    """The manifest of ``job``'s complete outputs made from this video with these options
    by this turnbench, or None when anything is missing or different (module docstring)."""
    mpath = manifest_path(job.npz)
    try:
        if not (mpath.is_file() and job.npz.is_file()):
            return None
        manifest = json.loads(mpath.read_text(encoding="utf-8"))
        same = (
            manifest["video"]["sha256"] == sha256
            and manifest["packages"]["turnbench"] == __version__
            and manifest["parameters"] == _options(params)
            and manifest["skeletons"]["sha256"] == sha256_file(job.npz)
        )
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not same or (job.preview is not None and not job.preview.is_file()):
        return None
    return manifest


def _row(job: VideoJob, sha256: str, status: str, manifest: dict | None, **extra: Any) -> dict:
    row: dict[str, Any] = {
        "video": str(job.video),
        "sha256": sha256,
        "status": status,
        "skeletons": str(job.npz) if manifest else None,
        "frames": None,
        "decoded_frames": None,
        "detection_rate": None,
        "tracks": None,
        "identity_breaks": None,
        "wall_s": None,
        "frames_per_s": None,
        "error": None,
    }
    if manifest:
        row.update(
            frames=manifest["time"]["n_frames"],
            decoded_frames=manifest["video"]["n_decoded_frames"],
            detection_rate=manifest["detection"]["rate"],
            tracks=len(manifest["tracks"]),
            identity_breaks=len(manifest["identity_breaks"]),
        )
    row.update(extra)
    return row


def _remove_stale(job: VideoJob) -> None:
    """An earlier run's outputs of a video that now failed: gone, so that nothing reads
    skeletons of another version of it (only files whose manifest says we wrote them)."""
    mpath = manifest_path(job.npz)
    try:
        ours = json.loads(mpath.read_text(encoding="utf-8"))["tool"].startswith(
            "turn-eval estimate"
        )
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return
    if ours:
        for p in (mpath, job.npz, job.preview):
            if p is not None and p.is_file() and not p.is_symlink():
                p.unlink()


def _sweep(jobs: Sequence[VideoJob], token: str) -> None:
    """Previews a worker was writing when it was stopped (its ``.<name>.<token>.tmp``)."""
    for job in jobs:
        if job.preview is not None:
            with contextlib.suppress(OSError):
                _tmp_name(job.preview, token).unlink()


def estimate_videos(
    jobs: Sequence[VideoJob],
    *,
    params: EstimateParams,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    skip_bad: bool = False,
    on_video: Callable[[dict], None] | None = None,
    on_progress: Callable[[int], None] | None = None,
    on_start: Callable[[list[VideoJob]], None] | None = None,
) -> EstimateRun:
    """Estimate every video of ``jobs`` and write its outputs as it finishes (module docstring).

    Parameters
    ----------
    jobs
        The videos and their outputs, names checked (no clashes, no input overwritten).
    params
        The options, the same for every video.
    workers, scheduler
        As :func:`turn_eval.mapping.map_files`; neither: serially, in this process.
    resume
        Skip the videos whose outputs are :func:`finished`.
    skip_bad
        List a video that fails as failed and go on, instead of stopping at it.
    on_video
        Called with each video's row as it is done, skipped or failed.
    on_progress
        Called with counts of frames decoded, as they are.
    on_start
        Called with the videos to be estimated once the cluster is up (a progress bar).

    Raises
    ------
    TurnbenchError
        The first video that fails, naming it (without ``skip_bad``).
    """
    started = time.perf_counter()
    report = on_video or (lambda row: None)
    run = EstimateRun()
    digests = [sha256_file(job.video) for job in jobs]
    rows: list[dict | None] = [None] * len(jobs)
    todo: list[int] = []
    for i, (job, digest) in enumerate(zip(jobs, digests, strict=True)):
        done = finished(job, digest, params) if resume else None
        if done is not None:
            row = _row(job, digest, "resumed", done)
            rows[i] = row
            report(row)
        else:
            todo.append(i)
    token = uuid.uuid4().hex

    def land(k: int, result: SkeletonEstimate | Failure) -> dict:
        i = todo[k]
        job = jobs[i]
        if isinstance(result, Failure):
            if not skip_bad:
                raise result.error()
            _remove_stale(job)
            row = _row(job, digests[i], "failed", None, error=result.message)
        else:
            write_estimate(result, job.npz)
            speed = result.manifest["speed"]
            row = _row(job, digests[i], "done", result.manifest, **speed)
        report(row)
        return row

    kwargs = {"params": params, "token": token}
    landed: list[dict] = []
    try:
        if todo:  # all resumed: no cluster to start
            landed = map_files(
                estimate_file,
                [jobs[i].video for i in todo],
                kwargs=kwargs,
                workers=workers,
                scheduler=scheduler,
                sha256s=[digests[i] for i in todo],
                on_result=land,
                on_progress=on_progress,
                on_start=(lambda: on_start([jobs[i] for i in todo])) if on_start else None,
                per_file=[{"preview": _preview_arg(jobs[i])} for i in todo],
            )
    finally:
        _sweep(jobs, token)
    for k, row in zip(todo, landed, strict=True):
        rows[k] = row
    run.videos = [r for r in rows if r is not None]
    run.wall_s = time.perf_counter() - started
    return run


def _preview_arg(job: VideoJob) -> str | None:
    return None if job.preview is None else os.path.abspath(job.preview)


def run_manifest(
    run: EstimateRun, *, params: EstimateParams, options: dict, started_utc: str
) -> dict:
    """What ``estimate --out-dir`` writes as :data:`RUN_MANIFEST`: the tool, its version, the
    options, every video's row (status ``done``, ``resumed`` or ``failed``) and the counts.
    Wall times and the start time make it differ from run to run, unlike the outputs."""
    videos = run.videos
    frames = sum(v["frames"] or 0 for v in videos if v["status"] == "done")
    wall = sum(v["wall_s"] or 0.0 for v in videos if v["status"] == "done")
    return {
        "tool": "turn-eval estimate",
        "version": __version__,
        "started_utc": started_utc,
        "options": options,
        "parameters": asdict(params),
        "videos": videos,
        "counts": {
            "videos": len(videos),
            "done": sum(v["status"] == "done" for v in videos),
            "resumed": sum(v["status"] == "resumed" for v in videos),
            "failed": sum(v["status"] == "failed" for v in videos),
            "frames_estimated": int(frames),
            "wall_s": round(run.wall_s, 3),
            "frames_per_s_per_worker": round(frames / wall, 3) if wall > 0 else None,
        },
    }
