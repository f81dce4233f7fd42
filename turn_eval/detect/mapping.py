"""Detect turns over many files: serially, or mapped over a Dask cluster, with the same result.

Home monitoring means thousands of hours of streams. One file's turns never depend on
another's, so :func:`detect_files` maps :func:`detect_file` over the files:

- serially in this process (the default; Dask is not even imported);
- on a local cluster of ``workers`` processes (``dask.distributed.LocalCluster`` with one
  thread per worker: the rule is NumPy-bound and holds the GIL often enough that processes,
  not threads, scale), or on an existing cluster at ``scheduler`` (``tcp://host:port``).

Each task reads one file, detects and returns its turns (a small table) with the file's
sha256 and frame counts; nothing is shared, so memory is bounded by the largest single
file per worker, not by the corpus. Results are put back in input order whatever order they
finish in, so the table is identical, row for row, to the serial run. A file that cannot be
read raises a :class:`TurnbenchError` naming it, or with ``skip_bad`` is listed in
``skipped`` and left out, as ``h36m mine --skip-bad`` does.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import sha256_file, typed_frame
from turn_datasets.machine import check_local_workers
from turn_datasets.skeleton import Layout
from turn_eval.detect.plugins import (
    call_detector,
    check_picklable,
    detector_name,
    hush_worker_deaths,
    worker_result,
)
from turn_eval.detect.protocol import TurnDetector, checked_turns
from turn_eval.detect.streams import read_streams
from turn_eval.events.contract import DETECTION_DTYPES

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
    fps_hz: float,
    source_format: str = "arrays",
) -> FileResult:
    """Every stream of one file through ``detector``; errors are returned, not raised, so a
    worker process hands them back as data (the caller decides: stop, or skip the file)."""
    streams: list[dict] = []
    parts: list[pd.DataFrame] = []
    try:
        digest = sha256_file(path)
    except OSError as exc:
        return FileResult(str(path), "", (), _columns([]), (str(exc.strerror or exc), None, None))
    try:
        for s in read_streams(path, layout=layout, up_axis=up_axis, source_format=source_format):
            streams.append(
                {
                    "key": s.key,
                    "session": s.session,
                    "subject": s.subject,
                    "n_frames": s.n_frames,
                    "up_axis": s.up_axis,
                }
            )
            try:
                found = call_detector(detector, s.positions, fps_hz, layout)
                found = checked_turns(
                    found, detector=detector_name(detector), n_frames=s.n_frames, fps_hz=fps_hz
                )
            except TurnbenchError as exc:
                raise TurnbenchError(exc.message, file=path, item=s.key, hint=exc.hint) from None
            found.insert(0, "subject", s.subject)
            found.insert(0, "session", s.session)
            parts.append(found)
    except TurnbenchError as exc:
        error = (exc.message, exc.where.item, exc.hint)
        return FileResult(str(path), digest, tuple(streams), _columns([]), error)
    return FileResult(str(path), digest, tuple(streams), _columns(parts))


def _columns(parts: Sequence[pd.DataFrame]) -> dict[str, np.ndarray]:
    """The tables' columns joined, by name (:data:`DETECTION_DTYPES`; none: empty arrays)."""
    out = {}
    for col, dtype in DETECTION_DTYPES.items():
        kind = object if dtype == "str" else np.dtype(dtype)
        arrays = [np.asarray(p[col].to_numpy(), dtype=kind) for p in parts]
        out[col] = np.concatenate(arrays) if arrays else np.zeros(0, dtype=kind)
    return out


def _empty() -> pd.DataFrame:
    return typed_frame(pd.DataFrame({c: [] for c in DETECTION_DTYPES}), DETECTION_DTYPES)


def _serial(paths: Sequence[Path], kwargs: dict, done: Callable[[], None]) -> list[FileResult]:
    out = []
    for p in paths:
        out.append(detect_file(p, **kwargs))
        done()
    return out


#: How long to try to reach a ``--scheduler`` before giving up, seconds.
SCHEDULER_TIMEOUT_S = 10


def local_cluster(n_workers: int):
    """A local Dask cluster of ``n_workers`` single-threaded processes, as ``--workers`` starts
    it: no dashboard, quiet logs, and workers that keep freed memory for the next file.

    Dask's workers start with ``MALLOC_TRIM_THRESHOLD_`` small, handing freed memory back to
    the system at once; every file's arrays (megabytes) are then fresh pages, faulted in
    again: 25-35% more CPU per file than serially (measured on 10-minute streams). Keeping
    freed memory costs no more than the largest file per worker.
    """
    # Imported here: a serial run never pays for Dask's import.
    import dask
    from dask.distributed import LocalCluster

    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    environ.update({"MALLOC_TRIM_THRESHOLD_": str(2**30), "MALLOC_MMAP_THRESHOLD_": str(2**30)})
    with (
        warnings.catch_warnings(),
        dask.config.set({"distributed.nanny.pre-spawn-environ": environ}),
    ):
        # the scheduler's HTTP server says so when another cluster has port 8787; it then
        # takes another port, and no dashboard is asked for
        warnings.filterwarnings("ignore", message="Port .* is already in use")
        return LocalCluster(
            n_workers=int(n_workers),
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )


def _dead(path: str, message: str) -> FileResult:
    """The result of a file whose worker died: its error, no sha256 (never hashed here)."""
    return FileResult(path, "", (), _columns([]), (message, None, None))


def _distributed(
    paths: Sequence[Path],
    kwargs: dict,
    done: Callable[[], None],
    *,
    workers: int | None,
    scheduler: str | None,
) -> list[FileResult]:
    from dask.distributed import Client, as_completed

    cluster = None
    if scheduler:
        try:
            client = Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT_S}s")
        except (OSError, ValueError) as exc:
            raise TurnbenchError(
                f"cannot reach the Dask scheduler at {scheduler}: {exc}",
                hint="start one (`dask scheduler`, then `dask worker ADDRESS` per machine) "
                "or use --workers N for a local cluster",
            ) from None
    else:
        cluster = local_cluster(workers or 1)
        client = Client(cluster)
    try:
        hush_worker_deaths()  # a dead worker is reported by worker_result, in one line
        futures = client.map(detect_file, list(paths), pure=False, **kwargs)
        order = {f.key: i for i, f in enumerate(futures)}
        results: list[FileResult | None] = [None] * len(futures)
        for fut in as_completed(futures):
            # a worker that died on a file: that file's error (plugins.worker_result)
            results[order[fut.key]] = worker_result(fut, str(paths[order[fut.key]]), _dead)
            fut.release()  # the worker may drop it: memory stays one file per worker
            done()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return [r for r in results if r is not None]


def detect_files(
    paths: Sequence[str | Path],
    *,
    detector: TurnDetector,
    layout: Layout,
    up_axis: str | None,
    fps_hz: float,
    source_format: str = "arrays",
    workers: int | None = None,
    scheduler: str | None = None,
    skip_bad: bool = False,
    on_file_done: Callable[[], None] | None = None,
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
        results = _distributed(files, kwargs, done, workers=workers, scheduler=scheduler)
    else:
        results = _serial(files, kwargs, done)
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
    fps_hz: float,
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

    n_frames = sum(s["n_frames"] for f in run.inputs for s in f["streams"])
    return {
        "tool": "turn-eval detect",
        "version": __version__,
        "detector": detector.name,
        "params": params,
        "reading": {
            "from": source_format,
            "layout": layout.name,
            "up_axis": up_axis,
            "fps_hz": float(fps_hz),
        },
        "inputs": run.inputs,
        "skipped": run.skipped,
        "counts": {
            "files": len(run.inputs),
            "streams": sum(len(f["streams"]) for f in run.inputs),
            "frames": int(n_frames),
            "hours": round(n_frames / fps_hz / 3600.0, 6),
            "detections": len(run.detections),
            "skipped": len(run.skipped),
        },
    }
