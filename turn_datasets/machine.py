"""What this machine can hold: its free memory, and how many local worker processes fit in it.

Checked before work starts, so that a run too big for the machine is one line naming what it
needs and what there is, instead of the system's out-of-memory killer ending it (or every
other process on the machine) halfway.
"""

from __future__ import annotations

import os

from turn_datasets import limits
from turn_datasets.errors import TurnbenchError

__all__ = ["WORKER_BYTES", "available_memory_bytes", "check_local_workers", "gigabytes"]

#: Resident memory of one local Dask worker process once turnbench is imported, before any
#: file: 203 MB measured (Python 3.11, NumPy 2, pandas, SciPy, h5py, distributed); the
#: issue's sweep saw 1.3 GB for 8 workers.
WORKER_BYTES = 200_000_000


def available_memory_bytes() -> int | None:
    """The memory this machine can give a new allocation now, in bytes (Linux's
    ``MemAvailable``; elsewhere the free physical pages), or None when it cannot tell."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, OSError, ValueError):
        return None


def gigabytes(n_bytes: float) -> str:
    """``8.2 GB``: decimal gigabytes, one decimal, as messages give sizes."""
    return f"{n_bytes / 1e9:.1f} GB"


def check_local_workers(n_workers: int) -> None:
    """Refuse more local worker processes than :data:`turn_datasets.limits.MAX_LOCAL_WORKERS`
    or than the free memory holds at :data:`WORKER_BYTES` each (before any file's arrays).

    Raises
    ------
    TurnbenchError
        Naming the count, what it needs and what there is.
    """
    if n_workers > limits.MAX_LOCAL_WORKERS:
        raise TurnbenchError(
            f"--workers {n_workers} is more than {limits.MAX_LOCAL_WORKERS} local processes",
            hint="for more, start a Dask cluster and give --scheduler",
        )
    free = available_memory_bytes()
    need = n_workers * WORKER_BYTES
    if free is not None and need > free:
        raise TurnbenchError(
            f"--workers {n_workers} needs about {gigabytes(need)} before reading any file "
            f"({gigabytes(WORKER_BYTES)} per worker process) and this machine has "
            f"{gigabytes(free)} free",
            hint=f"use at most {max(free // WORKER_BYTES - 1, 1)} workers",
        )
