"""The figures of ``turn-eval score --plots``, as PNG.

- ``confusion_matrix.png``: reference bin against predicted bin (scikit-learn's
  ``confusion_matrix``), each cell's count, shaded by the fraction of its reference bin.
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
import warnings
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from sklearn.metrics import confusion_matrix

from turn_datasets.geometry import quantise_deg
from turn_eval.predictions import group_label

__all__ = ["PLOT_FILES", "write_plots"]

#: File names of the figures, in the order :func:`write_plots` writes them.
PLOT_FILES = ("confusion_matrix.png", "predicted_by_bin.png", "abs_error.png", "bland_altman.png")
_DPI = 110


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.savefig(path, format="png", dpi=_DPI, metadata={"Software": None})
    fig.clear()
    return path


def _confusion(
    pred_bins: np.ndarray, ref_bins: np.ndarray, bin_width_deg: float, path: Path
) -> Path:
    labels = np.unique(np.concatenate([ref_bins, pred_bins]))
    with warnings.catch_warnings():
        # One bin on both sides is a fine 1 x 1 matrix; scikit-learn warns about it anyway.
        warnings.filterwarnings("ignore", message="A single label was found", category=UserWarning)
        counts = confusion_matrix(ref_bins, pred_bins, labels=labels)
    with np.errstate(divide="ignore", invalid="ignore"):
        share = counts / counts.sum(axis=1, keepdims=True)
    share = np.nan_to_num(share)
    size = 1.6 + 0.55 * labels.shape[0]
    fig = Figure(figsize=(size + 1.2, size))
    ax = fig.add_subplot()
    image = ax.imshow(share, cmap="Blues", vmin=0.0, vmax=1.0)
    names = [group_label(b) for b in labels]
    ax.set_xticks(range(labels.shape[0]), names, rotation=45)
    ax.set_yticks(range(labels.shape[0]), names)
    ax.set_xlabel("predicted bin (°)")
    ax.set_ylabel("reference bin (°)")
    for i in range(labels.shape[0]):
        for j in range(labels.shape[0]):
            if counts[i, j]:
                ax.text(
                    j, i, str(counts[i, j]), ha="center", va="center", fontsize=8,
                    color="white" if share[i, j] > 0.6 else "black",
                )
    fig.colorbar(image, ax=ax, label="fraction of the reference bin")
    ax.set_title(f"Confusion matrix of {bin_width_deg:g}° bins")
    fig.tight_layout()
    return _save(fig, path)


def _predicted_by_bin(
    pred_deg: np.ndarray, ref_bins: np.ndarray, bin_width_deg: float, path: Path
) -> Path:
    bins = np.unique(ref_bins)
    groups = [pred_deg[ref_bins == b] for b in bins]
    fig = Figure(figsize=(max(5.0, 1.0 + 0.7 * bins.shape[0]), 4.2))
    ax = fig.add_subplot()
    ax.boxplot(
        groups,
        positions=bins,
        widths=0.6 * bin_width_deg,
        showfliers=True,
        flierprops={"markersize": 2, "alpha": 0.5},
    )
    low, high = bins[0] - bin_width_deg, bins[-1] + bin_width_deg
    ax.plot([low, high], [low, high], linestyle="--", color="grey", linewidth=1,
            label="predicted = reference")
    ax.set_xlim(low, high)
    ax.set_xticks(bins, [group_label(b) for b in bins])
    ax.set_xlabel("reference bin (°)")
    ax.set_ylabel("predicted angle (°)")
    ax.set_title("Predicted angles per reference bin")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def _abs_error(error_deg: np.ndarray, bin_width_deg: float, path: Path) -> Path:
    step = 5.0
    top = max(step, float(np.ceil(error_deg.max() / step) * step))
    fig = Figure(figsize=(5.5, 3.8))
    ax = fig.add_subplot()
    ax.hist(error_deg, bins=np.arange(0.0, top + step, step), color="#4c78a8")
    mae = float(error_deg.mean())
    ax.axvline(mae, color="black", linewidth=1.2, label=f"MAE {mae:.1f}°")
    ax.axvline(bin_width_deg / 2, color="#d62728", linestyle="--", linewidth=1,
               label=f"half a bin ({bin_width_deg / 2:g}°)")
    ax.set_xlabel("absolute error (°)")
    ax.set_ylabel("clips")
    ax.set_title("Absolute angle error")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def _bland_altman(pred_deg: np.ndarray, ref_deg: np.ndarray, path: Path) -> Path:
    mean = (pred_deg + ref_deg) / 2
    diff = pred_deg - ref_deg
    bias = float(diff.mean())
    sd = float(diff.std(ddof=1)) if diff.shape[0] > 1 else 0.0
    fig = Figure(figsize=(5.5, 4.0))
    ax = fig.add_subplot()
    ax.scatter(mean, diff, s=6, alpha=0.5, color="#4c78a8", linewidths=0, rasterized=True)
    ax.axhline(bias, color="black", linewidth=1.2, label=f"mean difference {bias:.1f}°")
    for sign in (-1, 1):
        ax.axhline(bias + sign * 1.96 * sd, color="#d62728", linestyle="--", linewidth=1,
                   label="± 1.96 SD" if sign > 0 else None)
    ax.set_xlabel("mean of predicted and reference angle (°)")
    ax.set_ylabel("predicted − reference (°)")
    ax.set_title("Bland–Altman")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


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
