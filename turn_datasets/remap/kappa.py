"""Cohen's kappa over angle bins, vectorised over bootstrap resamples, with its percentile CI.

The paper (Cheng et al., Section 3.2) backs the Turn-REMAP labels with Cohen's kappa (0.96).
scikit-learn's ``cohen_kappa_score`` gives the point value; :func:`bootstrap_kappa_ci`
computes the same formula on every resample's confusion matrix at once.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
from sklearn.metrics import cohen_kappa_score

__all__ = [
    "bootstrap_kappa_ci",
]


def _kappa_from_counts(counts: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Cohen's kappa of confusion matrices ``counts[..., k, k]`` (NaN where undefined).

    The same formula as scikit-learn's ``cohen_kappa_score`` (1 - sum(w O) / sum(w E), with
    E the outer product of the marginals over n), vectorised over the bootstrap resamples;
    a test checks it against scikit-learn.
    """
    counts = counts.astype(float)
    n = counts.sum(axis=(-2, -1))
    rows = counts.sum(axis=-1)
    cols = counts.sum(axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        expected = rows[..., :, None] * cols[..., None, :] / n[..., None, None]
        observed_cost = (weights * counts).sum(axis=(-2, -1))
        expected_cost = (weights * expected).sum(axis=(-2, -1))
        kappa = 1.0 - observed_cost / expected_cost
    return np.where(expected_cost > 0, kappa, np.nan)


def _weights(n_labels: int, kind: str | None) -> np.ndarray:
    idx = np.arange(n_labels)
    if kind is None:
        return 1.0 - np.eye(n_labels)
    return np.abs(idx[:, None] - idx[None, :]).astype(float)


def bootstrap_kappa_ci(
    codes_a: np.ndarray,
    codes_b: np.ndarray,
    *,
    n_labels: int,
    weights: str | None = None,
    n_bootstrap: int = 1000,
    seed: int = 0,
    confidence: float = 0.95,
) -> tuple[tuple[float, float] | None, int]:
    """Percentile bootstrap CI of Cohen's kappa over paired items.

    Parameters
    ----------
    codes_a, codes_b
        Each item's category for the two raters, as positions ``0 .. n_labels - 1`` in the
        ordered label list (the order is what linear weights count).
    n_labels
        Number of categories.
    weights
        ``None`` (unweighted) or ``"linear"``.
    n_bootstrap
        Resamples of the items, with replacement, each the size of the data.
    seed
        Seed of ``numpy.random.default_rng``: the same seed gives the same interval.
    confidence
        Coverage of the interval (0.95: the 2.5th and 97.5th percentiles).

    Returns
    -------
    ci : (float, float) or None
        The interval; ``None`` without items, without resamples, or when kappa is undefined
        in every resample.
    n_undefined : int
        Resamples in which kappa is undefined (a single category); they are left out, so the
        interval describes the resamples where kappa exists.
    """
    codes_a = np.asarray(codes_a, dtype=np.int64)
    codes_b = np.asarray(codes_b, dtype=np.int64)
    n = len(codes_a)
    if n == 0 or n_bootstrap <= 0:
        return None, 0
    rng = np.random.default_rng(seed)
    k = n_labels
    w = _weights(k, weights)
    values: list[np.ndarray] = []
    # Chunks keep the (resamples x items) index array small for large audits.
    chunk = max(1, min(n_bootstrap, 2_000_000 // max(n, 1)))
    done = 0
    while done < n_bootstrap:
        m = min(chunk, n_bootstrap - done)
        idx = rng.integers(0, n, size=(m, n))
        cell = codes_a[idx] * k + codes_b[idx] + (np.arange(m)[:, None] * k * k)
        counts = np.bincount(cell.ravel(), minlength=m * k * k).reshape(m, k, k)
        values.append(_kappa_from_counts(counts, w))
        done += m
    kappas = np.concatenate(values)
    ok = kappas[np.isfinite(kappas)]
    n_undefined = int(len(kappas) - len(ok))
    if len(ok) == 0:
        return None, n_undefined
    alpha = (1.0 - confidence) / 2.0
    lo, hi = np.percentile(ok, [100 * alpha, 100 * (1 - alpha)])
    return (float(lo), float(hi)), n_undefined


def kappa_score(y1: Sequence[Any], y2: Sequence[Any], labels: Sequence[Any], weights: str | None):
    if len(y1) == 0:
        return None
    with warnings.catch_warnings():
        # scikit-learn warns and returns NaN when kappa is undefined; we report a reason.
        warnings.simplefilter("ignore")
        value = cohen_kappa_score(y1, y2, labels=list(labels), weights=weights)
    return None if not np.isfinite(value) else float(value)


def kappa_undefined_reason(y1: Sequence[Any], y2: Sequence[Any], what: str) -> str:
    if len(y1) == 0:
        return f"no {what}"
    used = sorted({str(v) for v in (*y1, *y2)})
    return (
        f"every one of the {len(y1)} {what} has the same label ({used[0]}), so agreement "
        "expected by chance is 1 and kappa is undefined"
    )
