"""Video to skeleton streams: decode, MediaPipe Pose, time grid, identity guard, levelling.

:func:`estimate_video` runs the whole chain on one file and :func:`write_estimate` writes
its two outputs (DESIGN.md, "Skeleton streams"):

``<stem>.npz``
    One ``(frames, 17, 3)`` float32 array per track in Human3.6M's 17-joint order
    (:mod:`turn_eval.estimate.joints`), metres, MediaPipe's world frame: origin between the
    hips, x to the image's right, y down, z away from the camera (so ``--up-axis -y``),
    levelled to the floor unless asked not to (:mod:`turn_eval.estimate.tilt`). NaN where
    the person is not seen. Frames are on a regular time grid
    (:mod:`turn_eval.estimate.timing`). A *track* is the frames between two identity breaks
    (:mod:`turn_eval.estimate.guard`): one array, keyed by the stem, when the tracker kept to
    one person; ``<stem>.t1``, ``<stem>.t2``, ... (in time order, each as long as the video,
    NaN outside its track) when it jumped between people.
``<stem>.manifest.json``
    The video's sha256 and format, the grid (rate, start, frames, how many were empty or
    dropped) and every decoded frame's presentation time, the detection rate, the tracks and
    breaks, the levelling rotation, the axes and unit, every parameter and the package
    versions. No wall-clock time: the same video and options give the same bytes.

The steps after decoding are :func:`skeletons_from_landmarks`, which needs no MediaPipe and
is tested on synthetic landmarks.
"""

from __future__ import annotations

import itertools
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import manifest_path, sha256_file, write_json, write_npz
from turn_eval.estimate.blazepose import BlazePose, PoseParams
from turn_eval.estimate.guard import IdentityGuardParams, identity_breaks, tracks
from turn_eval.estimate.joints import blazepose_to_h36m17
from turn_eval.estimate.preview import PreviewWriter
from turn_eval.estimate.tilt import LevelParams, level
from turn_eval.estimate.timing import regular_grid, resample
from turn_eval.estimate.video import open_video

__all__ = [
    "manifest_path",
    "AXES",
    "EstimateParams",
    "SkeletonEstimate",
    "estimate_video",
    "skeletons_from_landmarks",
    "write_estimate",
]

#: The frame the arrays are in, as the manifest states it.
AXES = {
    "frame": "MediaPipe world",
    "origin": "midpoint of the hips",
    "x": "to the image's right",
    "y": "down",
    "z": "away from the camera",
    "up_axis": "-y",
    "units": "m",
    "layout": "h36m17",
}


@dataclass(frozen=True)
class EstimateParams:
    """Everything ``turn-eval estimate`` can be told; the defaults are MediaPipe's own."""

    #: The grid's rate; None: the container's, or the frames' own when they disagree.
    fps_hz: float | None = None
    #: Rotate the skeletons so that the floor's normal is the vertical (camera tilt).
    level: bool = True
    pose: PoseParams = field(default_factory=PoseParams)
    guard: IdentityGuardParams = field(default_factory=IdentityGuardParams)
    levelling: LevelParams = field(default_factory=LevelParams)


@dataclass
class SkeletonEstimate:
    """One video's skeleton streams and manifest (module docstring)."""

    session: str
    arrays: dict[str, np.ndarray]
    manifest: dict[str, Any]

    @property
    def n_frames(self) -> int:
        return int(self.manifest["time"]["n_frames"])

    @property
    def detection_rate(self) -> float:
        return float(self.manifest["detection"]["rate"])


def skeletons_from_landmarks(
    world33: np.ndarray,
    image33: np.ndarray,
    pts_s: np.ndarray,
    *,
    session: str,
    width_px: int,
    height_px: int,
    declared_fps_hz: float | None = None,
    params: EstimateParams | None = None,
) -> SkeletonEstimate:
    """Per-decoded-frame BlazePose landmarks -> the tracks' arrays and their manifest.

    Parameters
    ----------
    world33, image33
        ``(decoded frames, 33, 3)`` world and ``(decoded frames, 33, 2)`` image landmarks,
        NaN where nobody was found.
    pts_s
        Presentation time of each decoded frame.
    session
        The video's stem: the key of a single track, the prefix of several.
    """
    prm = params or EstimateParams()
    grid = regular_grid(pts_s, fps_hz=prm.fps_hz, declared_fps_hz=declared_fps_hz)
    world = resample(blazepose_to_h36m17(world33), grid)
    image = resample(image33, grid)
    detected = np.isfinite(world).all(axis=(1, 2))
    # Every time of the manifest counts from the first frame, as the tracks' and the
    # detections' do (time.start_s is that frame's presentation time).
    breaks = identity_breaks(
        image, grid.times_s - grid.start_s, width_px=width_px, height_px=height_px, params=prm.guard
    )
    spans = tracks(detected, breaks)
    levelling = None
    if prm.level and detected.any():
        world, levelling = level(world, up_axis=AXES["up_axis"], params=prm.levelling)
    keys = [session] if len(spans) <= 1 else [f"{session}.t{i + 1}" for i in range(len(spans))]
    arrays: dict[str, np.ndarray] = {}
    track_rows = []
    for key, (start, stop) in zip(keys, spans, strict=False):
        array = np.full(world.shape, np.nan, dtype=np.float32)
        array[start:stop] = world[start:stop]
        arrays[key] = array
        track_rows.append(
            {
                "key": key,
                "start_frame": start,
                "end_frame": stop,
                "start_s": round(start / grid.fps_hz, 6),
                "end_s": round(stop / grid.fps_hz, 6),
                "n_detected": int(np.count_nonzero(detected[start:stop])),
            }
        )
    if not spans:  # nobody in the whole video: one all-NaN array, so the file still says so
        arrays[session] = world.astype(np.float32)
    n_detected = int(np.count_nonzero(detected))
    manifest = {
        "time": {
            "fps_hz": grid.fps_hz,
            "declared_fps_hz": declared_fps_hz,
            "start_s": grid.start_s,
            "n_frames": grid.n_frames,
            "regular": grid.regular,
            "resampled": not grid.regular,
            "n_empty": grid.n_empty,
            "n_dropped": grid.n_dropped,
            "decoded_pts_s": np.round(np.asarray(pts_s, dtype=float), 6).tolist(),
        },
        "detection": {
            "n_detected": n_detected,
            "rate": round(n_detected / grid.n_frames, 6) if grid.n_frames else 0.0,
        },
        "tracks": track_rows,
        "identity_breaks": [b.to_dict() for b in breaks],
        "levelling": None if levelling is None else asdict(levelling),
        "axes": {**AXES, "levelled": levelling is not None},
    }
    return SkeletonEstimate(session=session, arrays=arrays, manifest=manifest)


def _package_versions() -> dict[str, str]:
    out = {"turnbench": __version__}
    for name in ("mediapipe", "numpy", "imageio-ffmpeg"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def _expected_frames(duration_s: float | None, fps_hz: float | None) -> int:
    return int(round(duration_s * fps_hz)) if duration_s and fps_hz and fps_hz <= 240 else 0


def _preview_fps(declared_fps_hz: float | None) -> float:
    # A variable-rate WebM declares 1000 fps; a preview is for eyes, 30 fps will do there.
    return declared_fps_hz if declared_fps_hz and declared_fps_hz <= 120 else 30.0


def estimate_video(
    path: str | os.PathLike[str],
    *,
    params: EstimateParams | None = None,
    preview: str | os.PathLike[str] | None = None,
    on_frame: Callable[[int], None] | None = None,
    sha256: str | None = None,
) -> SkeletonEstimate:
    """Run MediaPipe Pose over every frame of one video (module docstring).

    ``preview`` is the path of a QA preview video to write alongside
    (:mod:`turn_eval.estimate.preview`); ``on_frame(expected_frames)`` is called after each
    decoded frame (a progress bar), with the container's duration times its rate (0 if
    unknown). ``sha256`` is the video's, when the caller has hashed it already. The
    manifest's ``speed`` block (frames per second, wall time) is the
    only part that changes between runs; :func:`write_estimate` leaves it out of the file.
    """
    prm = params or EstimateParams()
    src = Path(path)
    world, image, pts = [], [], []
    started = time.perf_counter()
    stream = open_video(src)
    writer: PreviewWriter | None = None
    size = (0, 0)
    try:
        # The first frame before the pose model: a video that cannot be decoded is refused
        # before MediaPipe builds (and logs) anything.
        frames = iter(stream)
        first = next(frames, None)
        if first is None:
            raise TurnbenchError("the video has no decodable frame", file=src)
        with BlazePose(prm.pose) as pose:
            for rgb, pts_s in itertools.chain([first], frames):
                w, i, _ = pose.process(rgb)
                world.append(w)
                image.append(i)
                pts.append(pts_s)
                size = (rgb.shape[1], rgb.shape[0])
                if preview is not None:
                    if writer is None:
                        writer = PreviewWriter(
                            preview,
                            width_px=size[0],
                            height_px=size[1],
                            fps_hz=_preview_fps(stream.declared_fps_hz),
                            guard=prm.guard,
                        )
                    writer.add(rgb, i, pts_s)
                if on_frame is not None:
                    on_frame(_expected_frames(stream.duration_s, stream.declared_fps_hz))
            version = pose.version
    finally:
        stream.close()
        if writer is not None:
            writer.close()
    elapsed = time.perf_counter() - started
    try:
        result = skeletons_from_landmarks(
            np.asarray(world),
            np.asarray(image),
            np.asarray(pts),
            session=src.stem,
            width_px=size[0],
            height_px=size[1],
            declared_fps_hz=stream.declared_fps_hz,
            params=prm,
        )
    except TurnbenchError as exc:
        raise TurnbenchError(exc.message, file=src, hint=exc.hint) from None
    result.manifest = {
        "tool": f"turn-eval estimate {__version__}",
        "video": {
            "file": src.name,
            "sha256": sha256 or sha256_file(src),
            "width_px": size[0],
            "height_px": size[1],
            "codec": stream.codec,
            "duration_s": stream.duration_s,
            "n_decoded_frames": len(pts),
        },
        **result.manifest,
        "estimator": {"name": "MediaPipe Pose (BlazePose GHUM)", "mediapipe": version},
        "parameters": asdict(prm),
        "packages": _package_versions(),
        "speed": {"wall_s": elapsed, "frames_per_s": len(pts) / elapsed if elapsed > 0 else None},
    }
    return result


def write_estimate(result: SkeletonEstimate, out_npz: str | os.PathLike[str]) -> tuple[Path, Path]:
    """Write the arrays (fixed zip timestamps), then the manifest without its speed block.

    Each file lands whole (written aside, then renamed); the manifest comes last and records
    the npz's sha256 (``skeletons.sha256``), so an npz without a manifest that vouches for
    it is an unfinished output (``estimate --resume`` redoes it).
    """
    npz = write_npz(out_npz, result.arrays)
    manifest = {k: v for k, v in result.manifest.items() if k != "speed"}
    manifest["skeletons"] = {"sha256": sha256_file(npz)}
    return npz, write_json(manifest_path(npz), manifest)
