"""Map one function over many files, serially or on a Dask cluster, with the same results.

A file's result never depends on another's, so :func:`map_files` calls ``fn(path,
sha256=..., **kwargs)`` once per file:

- serially in this process (``workers`` and ``scheduler`` None; Dask is not even imported);
- on a cluster (:func:`turn_eval.mapping.cluster.connect`), as one task per file, or with
  ``tasks_per_worker`` as a few tasks per worker, each a run of consecutive files (Dask's
  own messages cost milliseconds of CPU per task, a large share of a file that takes a
  few tens of milliseconds).

Every file is hashed here first, and the task carries its *absolute* path and that sha256.
The worker checks the copy it can see before reading it: a worker on another machine (or
in another folder) must not quietly read a different file of the same name and record its
sha256 as if it were ours. A file the worker cannot see is "not reachable from worker W";
a copy with another sha256 is refused naming both digests. The function gets the sha256 so
that it need not hash the file a third time.

A :class:`~turn_datasets.errors.TurnbenchError` raised by ``fn`` comes back as a
:class:`Failure` (plain data, so a worker hands it back whole), as does a worker that died
running the file (killed, out of memory); the caller decides to stop or to skip. Any other
exception is a bug and is raised here with its traceback. Results come back in input order
whatever order the tasks finish in.

Progress: with ``on_progress``, ``fn`` is also given ``on_progress(n)`` to call as it works
(frames decoded, say); on a cluster the counts travel as Dask events, sent at most every
:data:`PROGRESS_EVERY_S` per worker, and ``on_progress`` is called on the client.
"""

from __future__ import annotations

import logging
import os
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import sha256_file

__all__ = ["PROGRESS_EVERY_S", "Failure", "map_files"]

#: How often a worker reports progress to the client at most, seconds.
PROGRESS_EVERY_S = 0.25

_REACH_HINT = (
    "every worker needs the files at the same absolute paths as here (a shared mount, or "
    "the same copy on each machine)"
)


@dataclass(frozen=True)
class Failure:
    """A file that gave no result: why, and (as far as known) the stream or item at fault."""

    path: str
    message: str
    item: str | None = None
    hint: str | None = None
    #: The worker running it died (killed, out of memory): the caller may word it its way.
    died: bool = False

    def error(self) -> TurnbenchError:
        """The failure as the error a command reports (one line naming the file)."""
        return TurnbenchError(self.message, file=self.path, item=self.item, hint=self.hint)


def _call(
    fn: Callable[..., Any],
    path: str,
    sha256: str,
    kwargs: dict,
    on_progress: Callable[[int], None] | None,
) -> Any:
    extra = {} if on_progress is None else {"on_progress": on_progress}
    try:
        return fn(path, sha256=sha256, **kwargs, **extra)
    except TurnbenchError as exc:
        return Failure(path, exc.message, exc.where.item, exc.hint)


class _Events:
    """A worker's progress counts, sent to the client as Dask events (module docstring)."""

    def __init__(self, worker: Any, topic: str) -> None:
        self.worker = worker
        self.topic = topic
        self.pending = 0
        self.last = time.monotonic()

    def __call__(self, n: int = 1) -> None:
        self.pending += n
        if time.monotonic() - self.last >= PROGRESS_EVERY_S:
            self.flush()

    def flush(self) -> None:
        if self.pending:
            self.worker.log_event(self.topic, self.pending)
            self.pending = 0
        self.last = time.monotonic()


def _on_worker(
    fn: Callable[..., Any], jobs: list[tuple[str, str, dict]], topic: str | None
) -> list[Any]:
    """One task: for each of its files ``(path, sha256, kwargs)``, check that the worker sees
    our file, then run ``fn`` on it; the results (or :class:`Failure`) in order."""
    import socket

    from distributed import get_worker

    worker = get_worker()
    name = f"{worker.address} ({socket.gethostname()})"
    events = _Events(worker, topic) if topic else None
    try:
        return [_checked_call(fn, *job, name, events) for job in jobs]
    finally:
        if events is not None:
            events.flush()


def _checked_call(
    fn: Callable[..., Any],
    path: str,
    sha256: str,
    kwargs: dict,
    name: str,
    events: _Events | None,
) -> Any:
    """``fn`` on one file on worker ``name``, once the copy there is known to be ours."""
    if not os.path.isfile(path):
        return Failure(path, f"not reachable from worker {name}", hint=_REACH_HINT)
    try:
        digest = sha256_file(path)
    except OSError as exc:
        return Failure(path, f"cannot be read on worker {name}: {exc.strerror or exc}")
    if digest != sha256:
        return Failure(
            path,
            f"the copy on worker {name} is another file: sha256 {digest} there, {sha256} here",
            hint=_REACH_HINT,
        )
    return _call(fn, path, sha256, kwargs, events)


class _NoDeathNotice(logging.Filter):
    """Drops the scheduler's log line about a task whose worker died: :func:`map_files`
    hands that file back as a :class:`Failure`, and the command says it in one line."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "workers died while trying to run it" not in record.getMessage()


_NO_DEATH_NOTICE = _NoDeathNotice()


def _hashes(files: Sequence[str], given: Sequence[str | None] | None) -> list[str | Failure]:
    out: list[str | Failure] = []
    for i, path in enumerate(files):
        digest = given[i] if given is not None else None
        if digest is None:
            try:
                digest = sha256_file(path)
            except OSError as exc:
                out.append(Failure(path, str(exc.strerror or exc)))
                continue
        out.append(digest)
    return out


def _batches(indices: list[int], n_tasks: int) -> list[list[int]]:
    """``indices`` cut into ``n_tasks`` runs of consecutive entries (at most one each), of
    sizes that differ by one at most."""
    n = min(len(indices), max(n_tasks, 1))
    bounds = [len(indices) * k // n for k in range(n + 1)] if n else [0]
    return [indices[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def _distributed(
    fn: Callable[..., Any],
    files: Sequence[str],
    digests: Sequence[str | Failure],
    kwargs: Sequence[dict],
    keep: Callable[[int, Any], Any],
    on_progress: Callable[[int], None] | None,
    *,
    workers: int | None,
    scheduler: str | None,
    on_start: Callable[[], None],
    tasks_per_worker: int | None,
) -> list[Any]:
    from dask.distributed import as_completed
    from distributed import KilledWorker

    from turn_eval.mapping.cluster import connect, noting_interrupts

    results: list[Any] = [None] * len(files)
    token = uuid.uuid4().hex
    name = getattr(fn, "__name__", "task")
    logging.getLogger("distributed.scheduler").addFilter(_NO_DEATH_NOTICE)
    # Ctrl-C at a terminal signals the workers too: they die, and this process may hear of
    # their deaths before its own KeyboardInterrupt surfaces (a Dask call into its event loop
    # can swallow it), which once made a Ctrl-C "the worker process died" and exit 2. A task
    # that ends after a noted Ctrl-C, or dies as it arrives, is the interrupt.
    pressed: list[int] = []
    with (
        connect(workers=workers, scheduler=scheduler) as client,
        noting_interrupts(pressed, then_raise=True),
    ):
        on_start()
        topic = None
        if on_progress is not None:
            topic = f"turnbench-progress-{token}"
            client.subscribe_topic(topic, lambda event: on_progress(int(event[1])))
        todo = []
        for i, digest in enumerate(digests):
            if isinstance(digest, Failure):
                results[i] = keep(i, digest)
            else:
                todo.append(i)
        if tasks_per_worker is None:
            groups = [[i] for i in todo]
        else:
            groups = _batches(todo, tasks_per_worker * max(sum(client.nthreads().values()), 1))
        sent: dict[str, tuple[list[int], Any]] = {}

        def submit(group: list[int]) -> Any:
            jobs = [(files[i], digests[i], kwargs[i]) for i in group]
            key = f"{name}-{group[0]}-{len(group)}-{token}"
            future = client.submit(_on_worker, fn, jobs, topic, key=key, pure=False)
            sent[future.key] = (group, future)
            return future

        finished = as_completed([submit(g) for g in groups])
        for future in finished:
            if pressed:  # a Ctrl-C that Dask swallowed: its workers' deaths are not files'
                raise KeyboardInterrupt
            group, _ = sent.pop(future.key)
            died = future.status == "error" and isinstance(future.exception(), KilledWorker)
            if died and pressed:
                raise KeyboardInterrupt
            if died and len(group) > 1:
                # which of its files killed the worker is unknown: each is sent again alone,
                # so that one dies alone and the others give their results
                future.release()
                for i in group:
                    finished.add(submit([i]))
                continue
            if died:
                out: list[Any] = [
                    Failure(
                        files[group[0]],
                        "the worker running it died (killed, or out of memory)",
                        hint="--skip-bad lists it and goes on; --resume then redoes it",
                        died=True,
                    )
                ]
            else:
                out = future.result()  # a bug on the worker re-raises here, with its traceback
            future.release()  # the worker may drop it: memory stays one task's per worker
            for i, result in zip(group, out, strict=True):
                results[i] = keep(i, result)
    return results


def map_files(
    fn: Callable[..., Any],
    paths: Sequence[str | os.PathLike[str]],
    *,
    kwargs: dict | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    sha256s: Sequence[str | None] | None = None,
    on_result: Callable[[int, Any], Any] | None = None,
    on_progress: Callable[[int], None] | None = None,
    on_start: Callable[[], None] | None = None,
    per_file: Sequence[dict] | None = None,
    tasks_per_worker: int | None = None,
) -> list[Any]:
    """``fn`` over every file (module docstring); its results (or :class:`Failure`) in order.

    Parameters
    ----------
    fn
        ``fn(path, *, sha256, **kwargs)``, importable by name on a cluster's workers; it
        gets the absolute path and the file's sha256 (and ``on_progress``, when given).
    paths
        The files, in the order of the results.
    kwargs
        Further keyword arguments of ``fn`` (picklable, for a cluster).
    workers
        Map over a local cluster of this many processes; None (default) runs serially.
    scheduler
        Address of a running Dask scheduler (``tcp://host:8786``); overrides ``workers``.
    sha256s
        The files' sha256 where already known (None entries are hashed here).
    on_result
        Called in this process as each file finishes, in the order they finish, with its
        index and result; what it returns is kept in the result's place (a small record in
        place of large arrays already written out). It may raise to stop the run: the
        cluster is then closed, ending the other tasks.
    on_progress
        Progress counts from ``fn`` (module docstring).
    on_start
        Called once the cluster is up (at once when serial): where a progress bar starts,
        so that a cluster that fails to start is one line, not a bar and then an error.
    per_file
        Keyword arguments of ``fn`` for each file (its output's name, say), added to
        ``kwargs``.
    tasks_per_worker
        On a cluster, send the files in about this many tasks per worker thread (runs of
        consecutive files) instead of one task per file: for many files that each take a
        fraction of a second, Dask's own work per task (messages between this process, the
        scheduler and the worker) is a large share of the whole. A task whose worker dies
        has its files sent again one per task. None (default): one task per file.
    """
    if workers is not None and workers < 1:
        raise TurnbenchError(f"workers must be at least 1, got {workers}")
    files = [os.path.abspath(Path(p)) for p in paths]
    digests = _hashes(files, sha256s)
    extra = [{**(kwargs or {}), **(per_file[i] if per_file else {})} for i in range(len(files))]

    def keep(i: int, result: Any) -> Any:
        return on_result(i, result) if on_result is not None else result

    start = on_start or (lambda: None)
    if scheduler or workers is not None:
        return _distributed(
            fn,
            files,
            digests,
            extra,
            keep,
            on_progress,
            workers=workers,
            scheduler=scheduler,
            on_start=start,
            tasks_per_worker=tasks_per_worker,
        )
    start()
    results = []
    for i, (path, digest) in enumerate(zip(files, digests, strict=True)):
        if isinstance(digest, Failure):
            results.append(keep(i, digest))
        else:
            results.append(keep(i, _call(fn, path, digest, extra[i], on_progress)))
    return results
