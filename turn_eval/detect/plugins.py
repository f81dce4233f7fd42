"""A user's own detector (``turn-eval detect --detector MODULE:NAME``): loaded, called and
sent to workers so that whatever it does wrong is one line naming it, never a traceback.

A plug-in is code we do not control. Each way it can fail is caught where we call it and
turned into a :class:`~turn_datasets.errors.TurnbenchError` (exit 2, the input's fault):

Loading (:func:`load_detector`)
    The module raises or has a syntax error at import, or calls ``sys.exit`` there (whose
    code would otherwise become ours: ``sys.exit(3)`` is the failed-gate code); the name is
    missing; the class or factory raises or needs arguments; the object has no ``name`` and
    ``detect``.
Calling (:func:`call_detector`)
    ``detect`` raises, calls ``sys.exit`` (``sys.exit(0)`` would end the run with exit 0 and
    no output) or raises ``KeyboardInterrupt`` itself on a worker thread (a real Ctrl-C only
    ever reaches the main thread, so there it passes); or it returns anything but a
    :class:`pandas.DataFrame`. What a DataFrame holds is the contract's
    (:func:`turn_eval.detect.protocol.checked_turns`).
Sending (:func:`check_picklable`, :func:`worker_result`)
    A cluster's workers get the detector pickled: one that cannot be pickled is named before
    any file is sent. A worker process that dies while running it (``sys.exit`` from a
    thread Dask cannot catch, a ``SIGKILL`` as the out-of-memory killer sends) makes Dask
    give up on that file (``KilledWorker``); that file is then one error like any other,
    skipped with ``--skip-bad``.
"""

from __future__ import annotations

import importlib
import inspect
import logging
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.skeleton import Layout
from turn_eval.detect.protocol import TurnDetector

__all__ = [
    "call_detector",
    "check_picklable",
    "detector_name",
    "hush_worker_deaths",
    "load_detector",
    "worker_result",
]

_SPEC_HINT = "give MODULE:NAME, the module importable (on PYTHONPATH) and NAME a detector"


def _what_went_wrong(exc: BaseException) -> str:
    """``ValueError: bad`` (or ``sys.exit(3)``): one line however long the message."""
    if isinstance(exc, SystemExit):
        return f"sys.exit({exc.code!r})"
    text = " ".join(str(exc).split())
    if len(text) > 200:
        text = text[:197] + "..."
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _import(spec: str) -> object:
    module_name, sep, attr = spec.partition(":")
    if not sep or not module_name or not attr:
        raise TurnbenchError(
            f"cannot load detector {spec!r}: it is not MODULE:NAME", hint=_SPEC_HINT
        )
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name is not None and module_name.startswith(exc.name):
            raise TurnbenchError(
                f"cannot load detector {spec!r}: no module named {exc.name!r}", hint=_SPEC_HINT
            ) from None
        raise TurnbenchError(
            f"cannot load detector {spec!r}: importing its module failed ({_what_went_wrong(exc)})"
        ) from None
    except (Exception, SystemExit) as exc:  # the plug-in's own code ran: anything is possible
        raise TurnbenchError(
            f"cannot load detector {spec!r}: importing its module failed ({_what_went_wrong(exc)})"
        ) from None
    try:
        return getattr(module, attr)
    except AttributeError:
        raise TurnbenchError(
            f"cannot load detector {spec!r}: module {module_name!r} has no {attr!r}",
            hint=_SPEC_HINT,
        ) from None


def load_detector(spec: str) -> TurnDetector:
    """The detector ``MODULE:NAME`` names: an object with ``name`` and ``detect``, or a class
    or factory that, called without arguments, returns one.

    Raises
    ------
    TurnbenchError
        Any failure of the import, the constructor or the object (module docstring), naming
        ``spec``.
    """
    obj = _import(spec)
    if inspect.isclass(obj) or (callable(obj) and not hasattr(obj, "detect")):
        try:
            obj = obj()
        except (Exception, SystemExit) as exc:
            raise TurnbenchError(
                f"cannot load detector {spec!r}: calling it without arguments failed "
                f"({_what_went_wrong(exc)})",
                hint="a detector class must construct with no arguments (give defaults), "
                "or name an instance",
            ) from None
    if not isinstance(obj, TurnDetector) or not isinstance(getattr(obj, "name", None), str):
        raise TurnbenchError(
            f"cannot load detector {spec!r}: it is not a turn detector; it needs a name (a string) and "
            "detect(positions, fps_hz, layout)"
        )
    return obj


def detector_name(detector: object) -> str:
    """The detector's ``name``, or its class's when it has none that is a string."""
    name = getattr(detector, "name", None)
    return name if isinstance(name, str) else type(detector).__name__


def call_detector(
    detector: TurnDetector, positions: np.ndarray, fps_hz: float, layout: Layout
) -> pd.DataFrame:
    """``detector.detect(positions, fps_hz, layout)``, its failures one :class:`TurnbenchError`
    naming the detector (the caller adds the file and the stream).

    A ``KeyboardInterrupt`` on the main thread is the user's Ctrl-C and passes; elsewhere
    (a cluster's worker thread) only the detector can have raised it.
    """
    name = detector_name(detector)
    try:
        table = detector.detect(positions, fps_hz, layout)
    except TurnbenchError as exc:
        raise TurnbenchError(f"detector {name!r}: {exc.message}", hint=exc.hint) from None
    except KeyboardInterrupt as exc:
        if threading.current_thread() is threading.main_thread():
            raise
        raise TurnbenchError(f"detector {name!r} failed ({_what_went_wrong(exc)})") from None
    except (Exception, SystemExit) as exc:
        raise TurnbenchError(f"detector {name!r} failed ({_what_went_wrong(exc)})") from None
    if not isinstance(table, pd.DataFrame):
        kind = "None" if table is None else type(table).__name__
        raise TurnbenchError(
            f"detector {name!r} returned {kind}, not a pandas DataFrame of turns",
            hint="return a DataFrame with start_s, end_s, angle_deg (and optional columns)",
        )
    return table


def check_picklable(detector: TurnDetector) -> None:
    """Refuse a detector a cluster's workers cannot receive, before any file is sent.

    Pickled the way Dask sends it (:func:`distributed.protocol.pickle.dumps`: pickle, then
    cloudpickle, which also takes classes and functions defined in ``__main__``), without
    Dask's logging of the failure.
    """
    import pickle

    import cloudpickle

    try:
        try:
            pickle.dumps(detector, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:
            cloudpickle.dumps(detector, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:
        raise TurnbenchError(
            f"detector {detector_name(detector)!r} cannot be sent to the workers: it cannot "
            f"be pickled ({_what_went_wrong(exc)})",
            hint="run without --workers/--scheduler, or keep only picklable attributes "
            "(no open files, locks or sessions)",
        ) from None


class _NoDeathNotice(logging.Filter):
    """Drops the scheduler's log line about a task whose workers died: :func:`worker_result`
    reports that file in our own words (one line, or a skipped file)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "workers died while trying to run it" not in record.getMessage()


_NO_DEATH_NOTICE = _NoDeathNotice()


def hush_worker_deaths() -> None:
    """Keep the scheduler's own notice of a dead worker off stderr (idempotent)."""
    logging.getLogger("distributed.scheduler").addFilter(_NO_DEATH_NOTICE)


def worker_result(future: Any, path: str, dead: Callable[[str, str], Any]) -> Any:
    """``future.result()``, or ``dead(path, message)`` when the worker running it died.

    ``KilledWorker`` is Dask's word for a task whose worker process died each time it ran
    (by default it tries on more than one): the detector called ``os._exit``, or the process
    was killed (``SIGKILL``, as the out-of-memory killer sends).
    """
    from distributed.scheduler import KilledWorker

    try:
        return future.result()
    except KilledWorker:
        return dead(
            path,
            "the worker process died while detecting turns in this file (the detector "
            "exited the process, or it was killed: out of memory?)",
        )
