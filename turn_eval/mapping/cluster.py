"""The Dask cluster a mapping runs on: a local one (``--workers N``) or a running one (``--scheduler``).

Everything that can go wrong in setting one up is one line naming what and where, never a
traceback of Dask's internals:

- ``--scheduler`` takes ``tcp://HOST:PORT`` (or ``HOST:PORT``) only: ``tls://`` needs
  certificates and ``ucx://`` a UCX installation, neither of which a command configures;
- a scheduler that cannot be reached within :data:`SCHEDULER_TIMEOUT_S`, or that no worker
  joins within :data:`WORKER_WAIT_S` (a scheduler started without its workers would
  otherwise leave the run waiting at 0 of N for ever);
- a local cluster that cannot start (an unwritable ``DASK_TEMPORARY_DIRECTORY``), or that
  would run out of file descriptors: its processes, pipes and sockets need
  :func:`open_files_needed` of them, so the soft limit is raised towards the hard one, and a
  hard limit below it (``ulimit -n 40``) is refused before anything starts (Dask's own
  processes would otherwise fail one by one, each with its own traceback).

A local cluster's worker processes write nothing to the terminal: Ctrl-C at a terminal
reaches every process of the foreground group, and each worker printed its own traceback
(most of all while still importing). The command alone speaks: it stops, closes the cluster
(which ends its workers) and says "aborted".
"""

from __future__ import annotations

import contextlib
import logging
import os
import resource
import signal
import sys
import threading
import warnings
from collections.abc import Iterator
from typing import Any

from turn_datasets.errors import TurnbenchError

__all__ = [
    "SCHEDULER_TIMEOUT_S",
    "WORKER_WAIT_S",
    "check_scheduler_address",
    "connect",
    "local_cluster",
    "noting_interrupts",
    "open_files_needed",
]

#: How long to try to reach a ``--scheduler`` before giving up, seconds.
SCHEDULER_TIMEOUT_S = 10
#: How long to wait for the first worker to join a ``--scheduler``, seconds.
WORKER_WAIT_S = 60
#: The protocols ``--scheduler`` accepts.
SCHEMES = ("tcp",)

_SETUP_HINT = (
    "a local Dask cluster needs a writable temporary folder (DASK_TEMPORARY_DIRECTORY, or "
    "TMPDIR) and a few hundred open files (ulimit -n)"
)


def open_files_needed(n_workers: int) -> int:
    """File descriptors a local cluster of ``n_workers`` needs, with room to spare: 256
    for this process (Dask's scheduler, the files read) and 32 per worker (its pipes and
    sockets), about twice what a cluster was seen to use on Linux."""
    return 256 + 32 * int(n_workers)


def _check_open_files(n_workers: int) -> None:
    need = open_files_needed(n_workers)
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY or soft >= need:
        return
    if hard == resource.RLIM_INFINITY or hard >= need:
        resource.setrlimit(resource.RLIMIT_NOFILE, (need, hard))
        return
    raise TurnbenchError(
        f"a local Dask cluster of {n_workers} workers needs {need} open files, but this "
        f"session allows {hard} (ulimit -n)",
        hint=f"raise the limit (ulimit -n {need}), or run without --workers",
    )


def _one_line(exc: BaseException) -> str:
    """The innermost cause's message, on one line (Dask wraps set-up errors several deep)."""
    while exc.__cause__ is not None or exc.__context__ is not None:
        exc = exc.__cause__ or exc.__context__  # type: ignore[assignment]
    text = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.strerror}" + (f": {exc.filename}" if exc.filename else "")
    return text


def check_scheduler_address(address: str) -> str:
    """``address`` as Dask takes it, or a one-line refusal of a protocol we cannot use."""
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    if scheme not in SCHEMES:
        raise TurnbenchError(
            f"--scheduler {address}: only tcp:// schedulers are supported, not {scheme}://",
            hint="tls:// needs certificates and ucx:// a UCX installation, which turnbench "
            "does not configure; give tcp://HOST:PORT",
        )
    host, _, port = rest.rpartition(":")
    if not host or not port.isdigit():
        raise TurnbenchError(f"--scheduler {address}: give it as tcp://HOST:PORT")
    return f"{scheme}://{rest}"


@contextlib.contextmanager
def _starting_workers(pressed: list[int]) -> Iterator[None]:
    """While a local cluster starts: its processes get a null stderr, and Ctrl-C is noted.

    Ctrl-C at a terminal signals every process of the foreground group; a worker process
    interrupted while importing NumPy printed a traceback (every worker, dozens of lines).
    Started with ``/dev/null`` as file descriptor 2, the workers' tracebacks, logs and
    native libraries' chatter never reach the terminal (their errors come back as task
    results). Meanwhile a Ctrl-C here is noted, not raised inside Dask's start-up (which
    would print its own tracebacks at exit); the caller stops once the cluster is up.
    Signal handlers can only be set in the main thread; elsewhere Ctrl-C is not ours.
    """
    with noting_interrupts(pressed, then_raise=False):
        sys.stderr.flush()
        saved = os.dup(2)
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 2)
        os.close(null)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)


@contextlib.contextmanager
def noting_interrupts(pressed: list[int], *, then_raise: bool) -> Iterator[None]:
    """Inside the block, Ctrl-C is noted in ``pressed`` and, with ``then_raise``, raised as
    before; without, only noted (for a caller that stops at a point of its own choosing).

    Signal handlers can only be set in the main thread: elsewhere Ctrl-C is not ours. An
    ignored SIGINT (a job started in the background) stays ignored."""
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or previous == signal.SIG_IGN:
        yield
        return

    def note(signum: int, frame: Any) -> None:
        pressed.append(signum)
        if not then_raise:
            return
        if callable(previous):
            previous(signum, frame)
        else:
            raise KeyboardInterrupt

    signal.signal(signal.SIGINT, note)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def _quiet(level: int = logging.CRITICAL) -> Iterator[None]:
    """Dask's own loggers held at ``level`` (closing an interrupted cluster logs errors)."""
    logger = logging.getLogger("distributed")
    before = logger.level
    logger.setLevel(level)
    try:
        yield
    finally:
        logger.setLevel(before)


def local_cluster(n_workers: int) -> Any:
    """A local Dask cluster of ``n_workers`` single-threaded processes, as ``--workers`` starts
    it: no dashboard, quiet logs, workers silent on the terminal that keep freed memory for the
    next file, and a task whose worker dies reported at once (not retried on another), the
    only one lost with it (no task waits queued on a worker).

    Dask's workers start with ``MALLOC_TRIM_THRESHOLD_`` small, handing freed memory back to
    the system at once; every file's arrays (megabytes) are then fresh pages, faulted in
    again: 25-35% more CPU per file than serially (measured on 10-minute streams). Keeping
    freed memory costs no more than the largest file per worker.
    """
    _check_open_files(n_workers)
    # Imported here: a serial run never pays for Dask's import.
    import dask
    from dask.distributed import LocalCluster

    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    environ.update({"MALLOC_TRIM_THRESHOLD_": str(2**30), "MALLOC_MMAP_THRESHOLD_": str(2**30)})
    settings = {
        "distributed.nanny.pre-spawn-environ": environ,
        # a file whose worker died (killed, out of memory) is reported, not run again on
        # another worker to kill that one too
        "distributed.scheduler.allowed-failures": 0,
        # a worker is given its next task only as it starts it, so a worker that dies takes
        # down only the task it was running, not one queued behind it (by default a worker
        # holds 1.1 x its threads, rounded up: a second task on one thread)
        "distributed.scheduler.worker-saturation": 1.0,
    }
    pressed: list[int] = []
    try:
        with (
            warnings.catch_warnings(),
            dask.config.set(settings),
            _quiet(logging.ERROR),
            _starting_workers(pressed),
        ):
            # the scheduler's HTTP server says so when another cluster has port 8787; it
            # then takes another port, and no dashboard is asked for
            warnings.filterwarnings("ignore", message="Port .* is already in use")
            cluster = LocalCluster(
                n_workers=int(n_workers),
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
    except Exception as exc:
        if pressed:
            raise KeyboardInterrupt from None
        raise TurnbenchError(
            f"cannot start a local Dask cluster of {n_workers} workers: {_one_line(exc)}",
            hint=_SETUP_HINT,
        ) from None
    if pressed:  # Ctrl-C during start-up: stop now that the cluster can be closed cleanly
        with _quiet(), contextlib.suppress(Exception):
            cluster.close()
        raise KeyboardInterrupt
    return cluster


def _join(scheduler: str) -> Any:
    from dask.distributed import Client

    address = check_scheduler_address(scheduler)
    try:
        with _quiet():
            client = Client(address, timeout=f"{SCHEDULER_TIMEOUT_S}s")
    except Exception as exc:
        raise TurnbenchError(
            f"cannot reach the Dask scheduler at {scheduler}: {_one_line(exc)}",
            hint="start one (`dask scheduler`, then `dask worker ADDRESS` per machine) "
            "or use --workers N for a local cluster",
        ) from None
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_S)
    except Exception:
        with _quiet(), contextlib.suppress(Exception):
            client.close()
        raise TurnbenchError(
            f"no worker joined the Dask scheduler at {scheduler} within {WORKER_WAIT_S} s",
            hint=f"start workers on it (`dask worker {address}`), or use --workers N",
        ) from None
    return client


@contextlib.contextmanager
def connect(*, workers: int | None, scheduler: str | None) -> Iterator[Any]:
    """A ``dask.distributed.Client`` on ``scheduler``, else on a local cluster of ``workers``
    processes; closed (and the local cluster with its workers ended) on the way out,
    whatever stops the block, without Dask's logs of the interrupted tasks."""
    cluster = None
    if scheduler:
        client = _join(scheduler)
    else:
        from dask.distributed import Client

        cluster = local_cluster(workers or 1)
        try:
            client = Client(cluster)
        except Exception as exc:
            with _quiet(), contextlib.suppress(Exception):
                cluster.close()
            raise TurnbenchError(
                f"cannot connect to the local Dask cluster: {_one_line(exc)}", hint=_SETUP_HINT
            ) from None
    try:
        yield client
    finally:
        with _quiet():
            with contextlib.suppress(Exception):
                client.close()
            if cluster is not None:
                with contextlib.suppress(Exception):
                    cluster.close()
