"""The figures of ``turn-eval score --plots``, as PNG.

- ``confusion_matrix.png``: reference bin against predicted bin, each cell's count, shaded
  by the fraction of its reference bin (over 40 bins, runs of neighbouring bins are merged).
- ``predicted_by_bin.png``: the distribution of predicted angles for each reference bin, as
  the paper's Figure 5a shows it, with the line where prediction equals reference.
- ``abs_error.png``: the distribution of absolute angle errors (the paper's Figure 5b), with
  the MAE and half a bin width marked.
- ``bland_altman.png``: difference (predicted minus reference) against the mean of the two,
  with the mean difference and its 95% limits of agreement (mean ± 1.96 SD).

Drawn with matplotlib's object API on the Agg canvas (no pyplot state, no display needed),
saved without a software tag so the same scores give the same bytes.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from turn_datasets.geometry import quantise_deg
from turn_datasets.render.numbers import fixed
from turn_eval.scoring.figures import save_figure
from turn_eval.scoring.groups import group_label

__all__ = ["PLOT_FILES", "write_plots"]

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


def _confusion(
    pred_bins: np.ndarray, ref_bins: np.ndarray, bin_width_deg: float, path: Path
) -> Path:
    labels, position = np.unique(np.concatenate([ref_bins, pred_bins]), return_inverse=True)
    position = position.reshape(-1)
    k = labels.shape[0]
    # Beyond _MAX_MATRIX_BINS bins (predictions in the wrong unit spread over hundreds), runs
    # of neighbouring bins share a row and a column, so the matrix stays bounded and legible.
    m = min(k, _MAX_MATRIX_BINS)
    merged = position * m // k
    starts = np.searchsorted(np.arange(k) * m // k, np.arange(m))
    ends = np.append(starts[1:], k) - 1
    names = [
        group_label(labels[a]) if a == b else f"{group_label(labels[a])}–{group_label(labels[b])}"
        for a, b in zip(starts, ends, strict=True)
    ]
    n_ref = ref_bins.shape[0]
    counts = np.bincount(merged[:n_ref] * m + merged[n_ref:], minlength=m * m).reshape(m, m)
    with np.errstate(divide="ignore", invalid="ignore"):
        share = counts / counts.sum(axis=1, keepdims=True)
    share = np.nan_to_num(share)
    size = min(1.6 + 0.55 * m, _MAX_INCHES)
    fig = Figure(figsize=(size + 1.2, size))
    ax = fig.add_subplot()
    image = ax.imshow(share, cmap="Blues", vmin=0.0, vmax=1.0)
    ticks = np.arange(0, m, -(-m // _MAX_TICKS))
    ax.set_xticks(ticks, [names[t] for t in ticks], rotation=45)
    ax.set_yticks(ticks, [names[t] for t in ticks])
    ax.set_xlabel("predicted bin (°)")
    ax.set_ylabel("reference bin (°)")
    # Counts are written in the cells only while they stay legible.
    for i in range(m if m <= _MAX_COUNTED_CELLS else 0):
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
    fig.colorbar(image, ax=ax, label="fraction of the reference bin")
    title = f"Confusion matrix of {bin_width_deg:g}° bins"
    ax.set_title(title if m == k else f"{title} ({k} bins in {m} runs)")
    fig.tight_layout()
    return save_figure(fig, path)


def _predicted_by_bin(
    pred_deg: np.ndarray, ref_bins: np.ndarray, bin_width_deg: float, path: Path
) -> Path:
    bins = np.unique(ref_bins)
    groups = [pred_deg[ref_bins == b] for b in bins]
    fig = Figure(figsize=(min(max(5.0, 1.0 + 0.7 * bins.shape[0]), _MAX_INCHES), 4.2))
    ax = fig.add_subplot()
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
    return _finish(
        fig,
        ax,
        path,
        xlabel="reference bin (°)",
        ylabel="predicted angle (°)",
        title="Predicted angles per reference bin",
        legend_loc="upper left",
    )


def _abs_error(error_deg: np.ndarray, bin_width_deg: float, path: Path) -> Path:
    # 5° bars, wider when the errors spread so far that there would be over _MAX_BARS.
    largest = float(error_deg.max())
    step = 5.0 * max(1.0, float(np.ceil(largest / (5.0 * _MAX_BARS))))
    top = max(step, float(np.ceil(largest / step) * step))
    fig = Figure(figsize=(5.5, 3.8))
    ax = fig.add_subplot()
    ax.hist(error_deg, bins=np.arange(0.0, top + step, step).tolist(), color="#4c78a8")
    mae = float(error_deg.mean())
    ax.axvline(mae, color="black", linewidth=1.2, label=f"MAE {fixed(mae, 1)}°")
    ax.axvline(
        bin_width_deg / 2,
        color="#d62728",
        linestyle="--",
        linewidth=1,
        label=f"half a bin ({bin_width_deg / 2:g}°)",
    )
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


def _bland_altman(pred_deg: np.ndarray, ref_deg: np.ndarray, path: Path) -> Path:
    mean = (pred_deg + ref_deg) / 2
    diff = pred_deg - ref_deg
    bias = float(diff.mean())
    sd = float(diff.std(ddof=1)) if diff.shape[0] > 1 else 0.0
    fig = Figure(figsize=(5.5, 4.0))
    ax = fig.add_subplot()
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
    bin_width_deg: float = 45.0,
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
