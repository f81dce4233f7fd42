"""The figures of ``turn-eval score --plots``, as PNG.

- ``confusion_matrix.png``: reference bin against predicted bin, each cell's count, shaded
  by the fraction of its reference bin; rows are the reference's bins, columns every bin of
  either table, each one labelled (over 40 bins, runs of neighbouring bins are merged).
- ``predicted_by_bin.png``: the distribution of predicted angles for each reference bin, as
  the paper's Figure 5a shows it, with the line where prediction equals reference.
- ``abs_error.png``: the distribution of absolute angle errors (the paper's Figure 5b), with
  the MAE and half a bin width marked.
- ``bland_altman.png``: difference (predicted minus reference) against the mean of the two,
  with the mean difference and its 95% limits of agreement (mean ± 1.96 SD).

:func:`side_by_side` draws one of these for two submissions on the same clips (``turn-eval
compare --plots-dir``), one panel each, on shared axes: the same limits and ticks on both
(``sharex``/``sharey``), the same histogram bars and the same matrix bins, so that heights
are compared by eye.

Drawn with matplotlib's object API on the Agg canvas (no pyplot state, no display needed),
saved without a software tag so the same scores give the same bytes.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from turn_datasets.geometry import BIN_WIDTH_DEG, quantise_deg
from turn_datasets.render.numbers import fixed
from turn_eval.scoring.figures import save_figure
from turn_eval.scoring.groups import group_label

__all__ = ["PLOT_FILES", "side_by_side", "write_plots", "write_side_by_side"]

#: File names of the figures, in the order :func:`write_plots` writes them.
PLOT_FILES = ("confusion_matrix.png", "predicted_by_bin.png", "abs_error.png", "bland_altman.png")
#: Beyond these, a figure stops growing with its bins (a submission in the wrong unit can
#: reach hundreds of bins; the figure must still fit in memory and on a screen).
_MAX_INCHES = 14.0
_MAX_TICKS = 30
_MAX_COUNTED_CELLS = 20
_MAX_MATRIX_BINS = 40
_MAX_BARS = 100


def _finish(
    fig: Figure, ax, path: Path, *, xlabel: str, ylabel: str, title: str, legend_loc: str
) -> Path:
    """Axis labels, title and legend (at a fixed place), laid out and saved."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc=legend_loc, fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def _bin_runs(labels: np.ndarray) -> tuple[int, list[str]]:
    """How many rows/columns ``labels`` (sorted bins) take, and their names: beyond
    _MAX_MATRIX_BINS bins (predictions in the wrong unit spread over hundreds), runs of
    neighbouring bins share a row and a column, so the matrix stays bounded and legible."""
    k = labels.shape[0]
    m = min(k, _MAX_MATRIX_BINS)
    starts = np.searchsorted(np.arange(k) * m // k, np.arange(m))
    ends = np.append(starts[1:], k) - 1
    names = [
        group_label(labels[a]) if a == b else f"{group_label(labels[a])}–{group_label(labels[b])}"
        for a, b in zip(starts, ends, strict=True)
    ]
    return m, names


def _matrix(
    pred_bins: np.ndarray, ref_bins: np.ndarray, labels: np.ndarray, rows: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Counts and row shares of ``rows`` (reference runs) against every run of ``labels``."""
    k = labels.shape[0]
    m = min(k, _MAX_MATRIX_BINS)
    run = np.searchsorted(labels, np.concatenate([ref_bins, pred_bins])) * m // k
    n_ref = ref_bins.shape[0]
    counts = np.bincount(run[:n_ref] * m + run[n_ref:], minlength=m * m).reshape(m, m)[rows]
    with np.errstate(divide="ignore", invalid="ignore"):
        share = counts / counts.sum(axis=1, keepdims=True)
    return counts, np.nan_to_num(share)


def _draw_confusion(ax, counts: np.ndarray, share: np.ndarray, names, rows: np.ndarray):
    m = len(names)
    image = ax.imshow(share, cmap="Blues", vmin=0.0, vmax=1.0, aspect="auto")
    tick_size = 8 if m <= 20 else 6
    ax.set_xticks(np.arange(m), names, rotation=45, fontsize=tick_size, ha="right")
    ax.set_yticks(np.arange(rows.shape[0]), [names[i] for i in rows], fontsize=tick_size)
    ax.set_xlabel("predicted bin (°)")
    # Counts are written in the cells only while they stay legible.
    for i in range(rows.shape[0] if m <= _MAX_COUNTED_CELLS else 0):
        for j in range(m):
            if counts[i, j]:
                ax.text(
                    j,
                    i,
                    str(counts[i, j]),
                    ha="center",
                    va="center",
                    fontsize=8,
                    color="white" if share[i, j] > 0.6 else "black",
                )
    return image


def _confusion(
    pred_bins: np.ndarray, ref_bins: np.ndarray, bin_width_deg: float, path: Path
) -> Path:
    labels = np.unique(np.concatenate([ref_bins, pred_bins]))
    k = labels.shape[0]
    m, names = _bin_runs(labels)
    # Rows: the reference's bins (a bin only predicted would be an empty row); columns:
    # every bin of either table. Every row and column is labelled (none skipped).
    rows = np.unique(np.searchsorted(labels, ref_bins) * m // k)
    counts, share = _matrix(pred_bins, ref_bins, labels, rows)
    width = min(1.6 + 0.55 * m, _MAX_INCHES)
    height = min(1.6 + 0.55 * rows.shape[0], _MAX_INCHES)
    fig = Figure(figsize=(width + 1.2, max(height, 3.0)))
    ax = fig.add_subplot()
    image = _draw_confusion(ax, counts, share, names, rows)
    ax.set_ylabel("reference bin (°)")
    fig.colorbar(image, ax=ax, label="fraction of the reference bin")
    title = f"Confusion matrix of {bin_width_deg:g}° bins"
    ax.set_title(title if m == k else f"{title} ({k} bins in {m} runs)")
    fig.tight_layout()
    return save_figure(fig, path)


def _draw_predicted_by_bin(
    ax, pred_deg: np.ndarray, ref_bins: np.ndarray, bins: np.ndarray, bin_width_deg: float
) -> None:
    groups = [pred_deg[ref_bins == b] for b in bins]
    ax.boxplot(
        groups,
        positions=bins,
        widths=0.6 * bin_width_deg,
        showfliers=True,
        flierprops={"markersize": 2, "alpha": 0.5},
    )
    low, high = bins[0] - bin_width_deg, bins[-1] + bin_width_deg
    ax.plot(
        [low, high],
        [low, high],
        linestyle="--",
        color="grey",
        linewidth=1,
        label="predicted = reference",
    )
    ax.set_xlim(low, high)
    ticks = bins[:: -(-bins.shape[0] // _MAX_TICKS)]
    ax.set_xticks(ticks, [group_label(b) for b in ticks])


def _predicted_by_bin(
    pred_deg: np.ndarray, ref_bins: np.ndarray, bin_width_deg: float, path: Path
) -> Path:
    bins = np.unique(ref_bins)
    fig = Figure(figsize=(min(max(5.0, 1.0 + 0.7 * bins.shape[0]), _MAX_INCHES), 4.2))
    ax = fig.add_subplot()
    _draw_predicted_by_bin(ax, pred_deg, ref_bins, bins, bin_width_deg)
    return _finish(
        fig,
        ax,
        path,
        xlabel="reference bin (°)",
        ylabel="predicted angle (°)",
        title="Predicted angles per reference bin",
        legend_loc="upper left",
    )


def _error_edges(largest_deg: float) -> list[float]:
    """5° bars from 0, wider when the errors spread so far that there would be over
    _MAX_BARS."""
    step = 5.0 * max(1.0, float(np.ceil(largest_deg / (5.0 * _MAX_BARS))))
    top = max(step, float(np.ceil(largest_deg / step) * step))
    return np.arange(0.0, top + step, step).tolist()


def _draw_abs_error(ax, error_deg: np.ndarray, edges: list[float], bin_width_deg: float) -> None:
    ax.hist(error_deg, bins=edges, color="#4c78a8")
    mae = float(error_deg.mean())
    ax.axvline(mae, color="black", linewidth=1.2, label=f"MAE {fixed(mae, 1)}°")
    ax.axvline(
        bin_width_deg / 2,
        color="#d62728",
        linestyle="--",
        linewidth=1,
        label=f"half a bin ({bin_width_deg / 2:g}°)",
    )


def _abs_error(error_deg: np.ndarray, bin_width_deg: float, path: Path) -> Path:
    fig = Figure(figsize=(5.5, 3.8))
    ax = fig.add_subplot()
    _draw_abs_error(ax, error_deg, _error_edges(float(error_deg.max())), bin_width_deg)
    # a fixed place: "best" searches every bar (slow, and matplotlib warns about it)
    return _finish(
        fig,
        ax,
        path,
        xlabel="absolute error (°)",
        ylabel="clips",
        title="Absolute angle error",
        legend_loc="upper right",
    )


def _draw_bland_altman(ax, pred_deg: np.ndarray, ref_deg: np.ndarray) -> None:
    mean = (pred_deg + ref_deg) / 2
    diff = pred_deg - ref_deg
    bias = float(diff.mean())
    sd = float(diff.std(ddof=1)) if diff.shape[0] > 1 else 0.0
    ax.scatter(mean, diff, s=6, alpha=0.5, color="#4c78a8", linewidths=0, rasterized=True)
    ax.axhline(bias, color="black", linewidth=1.2, label=f"mean difference {fixed(bias, 1)}°")
    for sign in (-1, 1):
        ax.axhline(
            bias + sign * 1.96 * sd,
            color="#d62728",
            linestyle="--",
            linewidth=1,
            label="± 1.96 SD" if sign > 0 else None,
        )


def _bland_altman(pred_deg: np.ndarray, ref_deg: np.ndarray, path: Path) -> Path:
    fig = Figure(figsize=(5.5, 4.0))
    ax = fig.add_subplot()
    _draw_bland_altman(ax, pred_deg, ref_deg)
    return _finish(
        fig,
        ax,
        path,
        xlabel="mean of predicted and reference angle (°)",
        ylabel="predicted − reference (°)",
        title="Bland–Altman",
        legend_loc="lower right",
    )


def write_plots(
    pred_deg,
    ref_deg,
    out_dir: str | os.PathLike[str],
    *,
    bin_width_deg: float = BIN_WIDTH_DEG,
) -> list[Path]:
    """Write the four figures of the module docstring into ``out_dir``.

    Parameters
    ----------
    pred_deg, ref_deg
        Predicted and reference angles (degrees) of the scored clips, same order.
    out_dir
        An existing folder (``turn-eval score`` passes its staging folder, so the figures
        appear together with the scores or not at all).
    bin_width_deg
        Bin width of the quantisation.

    Returns
    -------
    list of Path
        The files written, in :data:`PLOT_FILES` order.
    """
    pred = np.asarray(pred_deg, dtype=np.float64)
    ref = np.asarray(ref_deg, dtype=np.float64)
    folder = Path(out_dir)
    pred_bins = np.asarray(quantise_deg(pred, bin_width_deg), dtype=np.float64).reshape(-1)
    ref_bins = np.asarray(quantise_deg(ref, bin_width_deg), dtype=np.float64).reshape(-1)
    names = dict(zip(("confusion", "by_bin", "error", "ba"), PLOT_FILES, strict=True))
    return [
        _confusion(pred_bins, ref_bins, bin_width_deg, folder / names["confusion"]),
        _predicted_by_bin(pred, ref_bins, bin_width_deg, folder / names["by_bin"]),
        _abs_error(np.abs(pred - ref), bin_width_deg, folder / names["error"]),
        _bland_altman(pred, ref, folder / names["ba"]),
    ]


#: Titles of the figures :func:`side_by_side` draws, by file name.
_TITLES = {
    "confusion_matrix.png": "Confusion matrix of {w:g}° bins (rows: reference, shade: share of "
    "its row)",
    "predicted_by_bin.png": "Predicted angles per reference bin",
    "abs_error.png": "Absolute angle error",
    "bland_altman.png": "Bland–Altman",
}


def _panels(n: int, width_each: float, height: float, *, extra: float = 0.0):
    """A figure of ``n`` panels in a row sharing both axes (limits, ticks, tick labels, shown
    on every panel), no wider than a single figure may grow."""
    width = min(n * width_each + extra, _MAX_INCHES + 1.2)
    fig = Figure(figsize=(width, height), layout="constrained")
    axes = fig.subplots(1, n, sharex=True, sharey=True, squeeze=False)[0]
    for ax in axes:
        # each panel is read on its own too: the shared values written on every one
        ax.tick_params(labelleft=True)
    return fig, list(axes)


def _confusion_panels(binned: dict[str, tuple[np.ndarray, np.ndarray]], title: str) -> Figure:
    ref_bins = np.concatenate([ref for _, ref in binned.values()])
    labels = np.unique(np.concatenate([ref_bins, *(pred for pred, _ in binned.values())]))
    k = labels.shape[0]
    m, names = _bin_runs(labels)
    # One set of rows (the reference's bins) and columns (every bin any panel has) for all
    rows = np.unique(np.searchsorted(labels, ref_bins) * m // k)
    n = len(binned)
    fig, axes = _panels(
        n,
        # cells narrow enough for two panels to stay legible at a page's width
        min(max(3.2, 0.8 + 0.3 * m), _MAX_INCHES / n),
        max(min(1.8 + 0.42 * rows.shape[0], _MAX_INCHES), 3.2),
        extra=1.6,
    )
    image = None
    for ax, (name, (pred_bins, ref)) in zip(axes, binned.items(), strict=True):
        counts, share = _matrix(pred_bins, ref, labels, rows)
        image = _draw_confusion(ax, counts, share, names, rows)
        ax.set_title(name)
    axes[0].set_ylabel("reference bin (°)")
    fig.colorbar(image, ax=axes, label="fraction of the reference bin", shrink=0.9)
    fig.suptitle(title if m == k else f"{title} ({k} bins in {m} runs)")
    return fig


def side_by_side(
    name: str,
    panels: Mapping[str, tuple[np.ndarray, np.ndarray]],
    *,
    bin_width_deg: float = BIN_WIDTH_DEG,
) -> Figure:
    """Figure ``name`` (one of :data:`PLOT_FILES`) of several submissions on the same clips,
    one panel each, left to right, on shared axes.

    Parameters
    ----------
    name
        Which figure: ``confusion_matrix.png``, ``predicted_by_bin.png``, ``abs_error.png``
        or ``bland_altman.png``.
    panels
        Panel title (the submission's name) -> (predicted, reference) angles in degrees.
    bin_width_deg
        Bin width of the quantisation.

    Returns
    -------
    matplotlib.figure.Figure
        The panels share x and y (the same limits and ticks); the histograms the same bars,
        the matrices the same rows (the reference's bins) and columns (every bin of any).
    """
    if name not in _TITLES:
        raise ValueError(f"no figure {name!r}; the figures are {', '.join(PLOT_FILES)}")
    angles = {
        title: (np.asarray(p, dtype=np.float64), np.asarray(r, dtype=np.float64))
        for title, (p, r) in panels.items()
    }
    title = _TITLES[name].format(w=bin_width_deg)
    if name == "confusion_matrix.png":
        binned = {
            t: tuple(
                np.asarray(quantise_deg(a, bin_width_deg), dtype=np.float64).reshape(-1)
                for a in pair
            )
            for t, pair in angles.items()
        }
        return _confusion_panels(binned, title)  # type: ignore[arg-type]
    n = len(angles)
    if name == "predicted_by_bin.png":
        ref_bins = {
            t: np.asarray(quantise_deg(r, bin_width_deg), dtype=np.float64).reshape(-1)
            for t, (_, r) in angles.items()
        }
        bins = np.unique(np.concatenate(list(ref_bins.values())))
        fig, axes = _panels(n, min(max(4.2, 0.8 + 0.5 * bins.shape[0]), _MAX_INCHES / n), 4.2)
        for ax, (t, (pred, _)) in zip(axes, angles.items(), strict=True):
            _draw_predicted_by_bin(ax, pred, ref_bins[t], bins, bin_width_deg)
        labels, legend_loc = ("reference bin (°)", "predicted angle (°)"), "upper left"
    elif name == "abs_error.png":
        errors = {t: np.abs(p - r) for t, (p, r) in angles.items()}
        # the same bars in every panel: edges from the largest error of any
        edges = _error_edges(max(float(e.max()) for e in errors.values()))
        fig, axes = _panels(n, 4.6, 3.8)
        for ax, error in zip(axes, errors.values(), strict=True):
            _draw_abs_error(ax, error, edges, bin_width_deg)
        labels, legend_loc = ("absolute error (°)", "clips"), "upper right"
    else:
        fig, axes = _panels(n, 4.6, 4.0)
        for ax, (pred, ref) in zip(axes, angles.values(), strict=True):
            _draw_bland_altman(ax, pred, ref)
        labels = ("mean of predicted and reference angle (°)", "predicted − reference (°)")
        legend_loc = "lower right"
    for ax, t in zip(axes, angles, strict=True):
        ax.set_title(t)
        ax.set_xlabel(labels[0])
        ax.legend(loc=legend_loc, fontsize=8)
    axes[0].set_ylabel(labels[1])
    fig.suptitle(title)
    return fig


def write_side_by_side(
    panels: Mapping[str, tuple[np.ndarray, np.ndarray]],
    out_dir: str | os.PathLike[str],
    *,
    bin_width_deg: float = BIN_WIDTH_DEG,
) -> list[Path]:
    """Each figure of :data:`PLOT_FILES` as :func:`side_by_side` draws it, into ``out_dir``
    (an existing folder); returns the files written, in that order."""
    folder = Path(out_dir)
    return [
        save_figure(side_by_side(name, panels, bin_width_deg=bin_width_deg), folder / name)
        for name in PLOT_FILES
    ]
