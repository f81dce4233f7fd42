"""One function over many files: serially, or mapped over a Dask cluster, with the same result.

Used by ``turn-eval detect`` (skeleton streams) and ``turn-eval estimate`` (videos); the
command gives the per-file function, this folder does the rest:

- :mod:`~turn_eval.mapping.files`: :func:`map_files`, which hashes every file here, sends its
  absolute path and sha256 to the worker, has the worker check the copy it can see before
  reading it, and hands back each file's result (or a :class:`Failure`) in input order;
- :mod:`~turn_eval.mapping.cluster`: the cluster itself (``--workers N`` starts a local
  one, ``--scheduler tcp://HOST:PORT`` joins a running one), with one-line errors for what
  goes wrong in setting it up, a time-out when no worker joins, and worker processes that
  leave Ctrl-C to the command.
"""

from turn_eval.mapping.cluster import (
    SCHEDULER_TIMEOUT_S,
    WORKER_WAIT_S,
    check_scheduler_address,
    connect,
    local_cluster,
)
from turn_eval.mapping.files import Failure, map_files

__all__ = [
    "SCHEDULER_TIMEOUT_S",
    "WORKER_WAIT_S",
    "Failure",
    "check_scheduler_address",
    "connect",
    "local_cluster",
    "map_files",
]
