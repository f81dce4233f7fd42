"""The bootstrap every scorer shares: seeded draws, unit resampling, percentile intervals.

Draws
    :func:`resample_indices` is ``scipy.stats.bootstrap``'s index matrix,
    ``numpy.random.default_rng(seed).integers(0, n, (n_resamples, n))``, drawn a chunk of rows
    at a time (:func:`chunk_rows`) to bound memory; the generator's stream is the same.
Intervals
    :func:`percentile_interval` is scipy's ``method="percentile"``: the 2.5th and 97.5th
    percentiles of the resampled statistic (linear interpolation), undefined resamples left
    out.
The engine (pyannote.metrics' model)
    A metric is a set of additive components per unit (true positives, errors, counts) and
    one function that combines their sums into the metric. Resampling is then generic: draw
    units with replacement, sum the drawn units' components (a resample's sums are its draw
    counts times the per-unit sums: one matrix product for all the resamples of a chunk), and
    combine (:func:`unit_sums`, :func:`unit_bootstrap`). Events resample (session, subject)
    units this way. Clips resample through :mod:`turn_eval.clips.metrics`' sparse engine on
    the same draws: with each clip a unit, the generic engine's per-unit sums are dense
    (clips x groups x one-hot bins: 1.4 GB for 100,000 clips in five groupings), and on
    10,000 clips it is 5 to 7 times slower than the sparse path, which gives the same numbers
    (``benchmarks/bench_score.py`` measures both).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from functools import cache

import numpy as np
from threadpoolctl import ThreadpoolController

from turn_datasets.errors import TurnbenchError

__all__ = [
    "CONFIDENCE",
    "CHUNK_CELLS",
    "chunk_rows",
    "resample_indices",
    "percentile_interval",
    "unit_sums",
    "unit_bootstrap",
]

#: Two-sided confidence level of every interval.
CONFIDENCE = 0.95
#: Index-matrix cells per chunk of resamples: a few arrays of this many 4- or 8-byte values.
CHUNK_CELLS = 1 << 21


def chunk_rows(n: int) -> int:
    """Resamples drawn and evaluated together for ``n`` units: bounds memory to a few arrays
    of :data:`CHUNK_CELLS` values whatever ``n``."""
    return max(1, CHUNK_CELLS // max(n, 1))


def resample_indices(
    n: int, *, n_resamples: int = 1000, seed: int = 0, rows_per_chunk: int | None = None
) -> Iterator[np.ndarray]:
    """The bootstrap index matrix of ``scipy.stats.bootstrap``, in chunks of rows.

    ``numpy.random.default_rng(seed).integers(0, n, (n_resamples, n))`` is what scipy draws
    for one sample, or for paired samples (whose common index it resamples); drawing it a
    chunk of rows at a time takes the same values from the generator's stream. The values are
    ``uint32``: for any ``n`` below 2**32 the generator draws 32-bit values whatever the
    requested type, so they equal scipy's ``int64`` draws (tested).

    Yields
    ------
    ndarray
        ``(rows, n)`` chunks, ``n_resamples`` rows in all.
    """
    if n < 1:
        raise TurnbenchError("cannot resample an empty set of clips")
    if n >= 2**32:
        raise TurnbenchError(f"too many clips to resample ({n})")
    if n_resamples < 0:
        raise TurnbenchError(f"the number of resamples must be 0 or more, got {n_resamples}")
    rows = rows_per_chunk if rows_per_chunk is not None else chunk_rows(n)
    rng = np.random.default_rng(seed)
    for start in range(0, n_resamples, rows):
        count = min(rows, n_resamples - start)
        yield rng.integers(0, n, (count, n), dtype=np.uint32)


def percentile_interval(
    values: np.ndarray, *, confidence: float = CONFIDENCE
) -> tuple[float, float] | None:
    """The percentile interval of a bootstrap distribution (linear interpolation, as scipy).

    Undefined (NaN) resamples are left out; None when none is defined.
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    alpha = (1 - confidence) / 2
    low, high = np.percentile(v, [100 * alpha, 100 * (1 - alpha)])
    return float(low), float(high)


def unit_sums(
    unit: np.ndarray, group: np.ndarray, values: np.ndarray, n_units: int, n_groups: int
) -> np.ndarray:
    """Per (unit, group) sums of per-item components: ``(n_units, n_groups, components)``.

    ``unit`` and ``group`` give each item's unit and group number; ``values`` its
    components (``(items, components)``).
    """
    k = values.shape[1]
    cell = unit * n_groups + group
    size = n_units * n_groups
    out = np.empty((size, k))
    # One bincount per component (each adds its items in order, as one over every
    # component would): reads a column-stored ``values`` in order.
    for j in range(k):
        out[:, j] = np.bincount(cell, weights=values[:, j], minlength=size)
    return out.reshape(n_units, n_groups, k)


@cache
def _blas() -> ThreadpoolController:
    """The BLAS libraries numpy and scipy loaded (found once: the search reads every one)."""
    return ThreadpoolController()


def unit_bootstrap(
    sums: Mapping[str, np.ndarray],
    combine: Callable[[np.ndarray], dict[str, np.ndarray]],
    *,
    n_resamples: int = 1000,
    seed: int = 0,
    indices: Iterable[np.ndarray] | None = None,
    progress: Callable[[Iterable[np.ndarray], int], Iterable[np.ndarray]] | None = None,
) -> dict[str, dict[str, np.ndarray]]:
    """Every metric of every group on every bootstrap resample of the units.

    Parameters
    ----------
    sums
        Per grouping, the per-unit sums of :func:`unit_sums` (``(units, groups, components)``;
        the same units in every grouping).
    combine
        The metrics from summed components: takes ``(..., components)`` sums, returns each
        metric as an array of the leading shape.
    n_resamples, seed
        As :func:`resample_indices` over the units.
    indices
        Chunks of a unit index matrix to use instead (tests).
    progress
        Wraps the chunks (and their number) to show progress.

    Returns
    -------
    dict
        Per grouping, each metric of ``combine`` as ``(n_resamples, groups)``.
    """
    names = list(sums)
    n_units = next(iter(sums.values())).shape[0]
    flat = np.concatenate([sums[n].reshape(n_units, -1) for n in names], axis=1)
    widths = [sums[n].shape[1] * sums[n].shape[2] for n in names]
    if indices is None:
        chunks: Iterable[np.ndarray] = resample_indices(n_units, n_resamples=n_resamples, seed=seed)
        if progress is not None:
            chunks = progress(chunks, -(-n_resamples // chunk_rows(n_units)))
    else:
        chunks = indices
    totals = []
    # One BLAS thread: a chunk's product is a few tens of milliseconds, and OpenBLAS's other
    # threads spin for as long again after it, busy on a core for nothing (measured: a
    # quarter of score-events' CPU time). Nor do the sums then depend on the thread count.
    with _blas().limit(limits=1, user_api="blas"):
        for chunk in chunks:
            # How often each resample drew each unit: one bincount over the whole chunk, each
            # row's draws offset into its own block of n_units counts.
            rows = chunk.shape[0]
            cells = chunk.astype(np.int64) + (np.arange(rows, dtype=np.int64) * n_units)[:, None]
            counts = np.bincount(cells.ravel(), minlength=rows * n_units).reshape(rows, n_units)
            totals.append(counts.astype(np.float64) @ flat)
    drawn = np.concatenate(totals, axis=0) if totals else np.zeros((0, flat.shape[1]))
    out: dict[str, dict[str, np.ndarray]] = {}
    start = 0
    for name, width in zip(names, widths, strict=True):
        block = drawn[:, start : start + width].reshape(drawn.shape[0], *sums[name].shape[1:])
        out[name] = combine(block)
        start += width
    return out
