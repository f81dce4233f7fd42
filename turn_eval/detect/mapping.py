"""Detect turns over many files: serially, or mapped over a Dask cluster, with the same result.

Home monitoring means thousands of hours of streams. One file's turns never depend on
another's, so :func:`detect_files` maps :func:`detect_file` over the files with
:func:`turn_eval.mapping.map_files` (the mapping ``estimate`` uses too):

- serially in this process (the default; Dask is not even imported);
- on a local cluster of ``workers`` processes (one thread per worker: the rule is
  NumPy-bound and holds the GIL often enough that processes, not threads, scale), or on an
  existing cluster at ``scheduler`` (``tcp://host:port``), each worker given the file's
  absolute path and checking its sha256 against this machine's before reading it.

Each task is a run of consecutive files (about :data:`TASKS_PER_WORKER` tasks per worker:
a 10-minute stream takes a few tens of milliseconds, and each task costs about 5 ms of
CPU in the client and scheduler alone: 1.1 s for 120 one-file tasks, 0.55 s for 8 tasks
of 15, hashing included); it reads them one at a time, detects and returns each file's
turns (a few arrays) with its sha256 and frame counts; nothing is shared, so memory is
bounded by the largest single file per worker, not by the corpus. Results are put back in
input order whatever order they finish in, so the table is identical, row for row, to the serial run. A file that cannot be
read raises a :class:`TurnbenchError` naming it, or with ``skip_bad`` is listed in
``skipped`` and left out, as ``h36m mine --skip-bad`` does.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import sha256_file, typed_frame
from turn_datasets.machine import check_local_workers
from turn_datasets.skeleton import Layout
from turn_eval.detect.plugins import call_detector, check_picklable, detector_name
from turn_eval.detect.protocol import TurnDetector, checked_turns
from turn_eval.detect.streams import read_streams
from turn_eval.events.contract import DETECTION_DTYPES
from turn_eval.mapping import Failure, local_cluster, map_files

__all__ = [
    "FileResult",
    "DetectRun",
    "build_manifest",
    "detect_file",
    "detect_files",
    "local_cluster",
]


@dataclass(frozen=True)
class FileResult:
    """One file's detections and what the manifest records of it.

    ``columns`` holds the detections column by column (:data:`DETECTION_DTYPES`' names,
    NumPy arrays): cheaper to hand back from a worker and to join than a table per file;
    :attr:`turns` is the table. ``error`` is ``(message, item, hint)`` when the file could
    not be used (then there are no turns and ``streams`` lists what was read before the
    error): plain data, so that a worker process hands it back whole.
    """

    path: str
    sha256: str
    streams: tuple[dict, ...]
    columns: dict[str, np.ndarray]
    error: tuple[str, str | None, str | None] | None = None

    @property
    def turns(self) -> pd.DataFrame:
        """The file's detections as a table (:data:`DETECTION_DTYPES`)."""
        return typed_frame(pd.DataFrame(self.columns), DETECTION_DTYPES)

    def raise_error(self) -> None:
        if self.error is not None:
            message, item, hint = self.error
            raise TurnbenchError(message, file=self.path, item=item, hint=hint)


@dataclass
class DetectRun:
    """All files' detections (:data:`~turn_eval.events.contract.DETECTION_DTYPES`, in input
    order), the inputs (path, sha256, streams with frame counts) and the skipped files."""

    detections: pd.DataFrame
    inputs: list[dict] = field(default_factory=list)
    skipped: list[dict] = field(default_factory=list)


def detect_file(
    path: str | Path,
    *,
    detector: TurnDetector,
    layout: Layout,
    up_axis: str | None,
    fps_hz: float | None,
    source_format: str = "arrays",
    sha256: str | None = None,
) -> FileResult:
    """Every stream of one file through ``detector``; errors are returned, not raised, so a
    worker process hands them back as data (the caller decides: stop, or skip the file)."""
    streams: list[dict] = []
    parts: list[tuple[str, str, pd.DataFrame]] = []
    try:
        digest = sha256 or sha256_file(path)  # the caller's, when it has hashed the file
    except OSError as exc:
        return FileResult(str(path), "", (), _columns([]), (str(exc.strerror or exc), None, None))
    try:
        for s in read_streams(path, layout=layout, up_axis=up_axis, source_format=source_format):
            entry = {
                "key": s.key,
                "session": s.session,
                "subject": s.subject,
                "n_frames": s.n_frames,
                "up_axis": s.up_axis,
            }
            if s.fps_hz is not None:
                entry["fps_hz"] = s.fps_hz
            streams.append(entry)
            # motion capture brings its own joints and rate (read_streams' ``mocap``)
            s_layout, s_fps = s.layout or layout, s.fps_hz or fps_hz
            if s_fps is None:  # the command requires --fps for every other format
                raise TurnbenchError("no frame rate: give --fps", file=path, item=s.key)
            try:
                found = call_detector(detector, s.positions, s_fps, s_layout)
                found = checked_turns(
                    found, detector=detector_name(detector), n_frames=s.n_frames, fps_hz=s_fps
                )
            except TurnbenchError as exc:
                raise TurnbenchError(exc.message, file=path, item=s.key, hint=exc.hint) from None
            # what the built-in rule left out (circling, too fast), counted per stream
            rejected = getattr(detector, "rejected_", None)
            if rejected is not None:
                entry["rejected"] = dict(sorted(Counter(rejected).items()))
            parts.append((s.session, s.subject, found))
    except TurnbenchError as exc:
        error = (exc.message, exc.where.item, exc.hint)
        return FileResult(str(path), digest, tuple(streams), _columns([]), error)
    return FileResult(str(path), digest, tuple(streams), _columns(parts))


def _columns(parts: Sequence[tuple[str, str, pd.DataFrame]]) -> dict[str, np.ndarray]:
    """The streams' turns (``(session, subject, turns)`` each) joined column by column
    (:data:`DETECTION_DTYPES`' names; none: empty arrays)."""
    out = {}
    for col, dtype in DETECTION_DTYPES.items():
        kind = object if dtype == "str" else np.dtype(dtype)
        if col == "session":
            arrays = [np.full(len(t), session, dtype=kind) for session, _, t in parts]
        elif col == "subject":
            arrays = [np.full(len(t), subject, dtype=kind) for _, subject, t in parts]
        else:
            arrays = [np.asarray(t[col].to_numpy(), dtype=kind) for *_, t in parts]
        out[col] = np.concatenate(arrays) if arrays else np.zeros(0, dtype=kind)
    return out


def _empty() -> pd.DataFrame:
    return typed_frame(pd.DataFrame({c: [] for c in DETECTION_DTYPES}), DETECTION_DTYPES)


#: On a cluster, the files go out in about this many tasks per worker (runs of consecutive
#: files), not one task each (:func:`turn_eval.mapping.map_files`).
TASKS_PER_WORKER = 4

_DIED = (
    "the worker process died while detecting turns in this file (the detector exited the "
    "process, or it was killed: out of memory?)"
)


def detect_files(
    paths: Sequence[str | Path],
    *,
    detector: TurnDetector,
    layout: Layout,
    up_axis: str | None,
    fps_hz: float | None,
    source_format: str = "arrays",
    workers: int | None = None,
    scheduler: str | None = None,
    skip_bad: bool = False,
    on_file_done: Callable[[], None] | None = None,
    on_start: Callable[[], None] | None = None,
) -> DetectRun:
    """Detect turns in every stream of every file (module docstring).

    Parameters
    ----------
    paths
        Stream files (:func:`turn_eval.detect.streams.stream_files` lists a folder's).
    detector
        Any :class:`~turn_eval.detect.protocol.TurnDetector` (picklable, for a cluster).
    layout, up_axis, fps_hz
        What the files do not say: joint layout, vertical axis, frame rate.
    source_format
        ``arrays``, or the estimator that wrote the files
        (:func:`turn_eval.detect.streams.read_streams`); its up axis unless ``up_axis``.
    workers
        Map over a local cluster of this many processes; None (default) runs serially.
    scheduler
        Address of an existing Dask scheduler (``tcp://host:8786``); overrides ``workers``.
    skip_bad
        Leave out files that cannot be used, listing them in ``skipped``, instead of
        raising on the first.
    on_file_done
        Called once per finished file (a progress bar).
    on_start
        Called once the cluster is up (at once when serial): where the bar starts.

    Raises
    ------
    TurnbenchError
        A file that cannot be used (without ``skip_bad``): the first in input order, naming
        it; two streams with the same session and subject, naming both files.
    """
    if workers is not None and workers < 1:
        raise TurnbenchError(f"workers must be at least 1, got {workers}")
    if workers is not None and not scheduler:
        check_local_workers(workers)  # the processes must fit the machine's memory
    kwargs = {
        "detector": detector,
        "layout": layout,
        "up_axis": up_axis,
        "fps_hz": fps_hz,
        "source_format": source_format,
    }
    done = on_file_done or (lambda: None)
    files = [Path(p) for p in paths]
    if scheduler or workers is not None:
        check_picklable(detector)  # one line, before any cluster starts

    def finished(i: int, result: FileResult | Failure) -> FileResult:
        done()
        if isinstance(result, Failure):  # not reachable or another file on a worker; a dead one
            message = _DIED if result.died else result.message
            return FileResult(str(files[i]), "", (), _columns([]), (message, result.item, None))
        return replace(result, path=str(files[i]))  # the path as given, not the absolute one

    results = map_files(
        detect_file,
        files,
        kwargs=kwargs,
        workers=workers,
        scheduler=scheduler,
        on_result=finished,
        on_start=on_start,
        tasks_per_worker=TASKS_PER_WORKER,
    )
    run = DetectRun(_empty())
    parts = []
    seen: dict[tuple[str, str], str] = {}
    for r in results:
        if r.error is not None:
            if not skip_bad:
                r.raise_error()
            message, item, _ = r.error
            run.skipped.append({"file": r.path, "item": item, "error": message})
            continue
        for s in r.streams:
            key = (s["session"], s["subject"])
            if key in seen:
                raise TurnbenchError(
                    f"session {key[0]!r} subject {key[1]!r} is also in {seen[key]}",
                    file=r.path,
                    item=s["key"],
                    hint="each (session, subject) must come from one file: rename one",
                )
            seen[key] = r.path
        run.inputs.append({"file": r.path, "sha256": r.sha256, "streams": list(r.streams)})
        parts.append(r.columns)
    if parts:
        joined = {c: np.concatenate([p[c] for p in parts]) for c in DETECTION_DTYPES}
        run.detections = typed_frame(pd.DataFrame(joined), DETECTION_DTYPES)
    return run


def build_manifest(
    run: DetectRun,
    *,
    detector: TurnDetector,
    params: dict,
    layout: Layout,
    up_axis: str | None,
    fps_hz: float | None,
    source_format: str = "arrays",
) -> dict:
    """What ``turn-eval detect`` writes beside its detections: the tool's version, the
    detector and every parameter, the reading options, every input with its sha256 and the
    frame count of each stream, the skipped files and the counts. No timestamp, so that the
    same inputs give the same bytes (serial or on a cluster alike). ``reading.up_axis`` is
    the axis the streams were turned by: the one given, else a named format's own."""
    from turn_datasets import __version__
    from turn_eval.estimate.formats import ESTIMATOR_FORMATS

    if up_axis is None and source_format in ESTIMATOR_FORMATS:
        up_axis = ESTIMATOR_FORMATS[source_format].up_axis

    streams = [s for f in run.inputs for s in f["streams"]]
    n_frames = sum(s["n_frames"] for s in streams)
    seconds = sum(s["n_frames"] / (s.get("fps_hz") or fps_hz) for s in streams)
    rejected: Counter[str] = Counter()
    for s in streams:
        rejected.update(s.get("rejected", {}))
    return {
        "tool": "turn-eval detect",
        "version": __version__,
        "detector": detector.name,
        "params": params,
        "reading": {
            "from": source_format,
            "layout": None if source_format == "mocap" else layout.name,  # mocap: the file's
            "up_axis": up_axis,
            # None: each stream at its file's own rate (motion capture), listed per stream
            "fps_hz": None if fps_hz is None else float(fps_hz),
        },
        "inputs": run.inputs,
        "skipped": run.skipped,
        "counts": {
            "files": len(run.inputs),
            "streams": sum(len(f["streams"]) for f in run.inputs),
            "frames": int(n_frames),
            "hours": round(seconds / 3600.0, 6),
            "detections": len(run.detections),
            "rejected": dict(sorted(rejected.items())),
            "skipped": len(run.skipped),
        },
    }
