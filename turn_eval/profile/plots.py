"""The figures of ``turn-eval profile --plots``, as PNG.

- ``heatmaps/NNNN_<subject>.png``, one per participant with a known start time: turns per
  recorded hour, local date (rows) by hour of day (columns); grey where nothing was recorded.
- ``distributions.png``: each measure's values per group, one panel per measure (points over a
  box), so a reader sees the spread behind a contrast.
- ``forest.png``: Hedges' g and the AUC of every measure with their 95% intervals, and, where a
  study reports the same contrast, the published value beside it (:data:`PUBLISHED`).

Drawn as the harness's other figures (matplotlib's object API on the Agg canvas, no software
tag), so the same profile gives the same bytes; matplotlib is imported only to draw.
"""

from __future__ import annotations

import re
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from turn_eval.profile.run import ProfileResult

__all__ = ["PROFILE_PLOT_FILES", "HEATMAP_DIR", "PUBLISHED", "write_profile_plots"]

PROFILE_PLOT_FILES = ("distributions.png", "forest.png")
HEATMAP_DIR = "heatmaps"
#: Published PD-versus-control contrasts of a measure of this profile, on this module's scale
#: (AUC > 0.5: higher in PD). Shah et al. (2020), "Quantity and quality of gait and turning in
#: people with multiple sclerosis, Parkinson's disease and matched controls during daily
#: living", J Neurol 267:1188-1196: over a week of wearing inertial sensors, the mean turn angle
#: told PD from controls with an AUC of 0.90, smaller in PD, which is 0.10 on this scale.
PUBLISHED = MappingProxyType(
    {"mean_angle_deg": {"auc": 0.10, "source": "Shah et al. 2020 (AUC 0.90, smaller in PD)"}}
)
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


def _figure(**kwargs):
    from matplotlib.figure import Figure

    return Figure(**kwargs)


def _save(fig, path: Path) -> Path:
    from turn_eval.scoring.figures import save_figure

    return save_figure(fig, path)


def _heatmap(rows: pd.DataFrame, subject: str, path: Path) -> Path:
    dates = sorted(rows["date"].unique())
    grid = np.full((len(dates), 24), np.nan)
    where = {d: i for i, d in enumerate(dates)}
    recorded = rows["recorded_min"].to_numpy()
    rate = np.where(recorded > 0, rows["turns"].to_numpy() / np.maximum(recorded, 1e-9) * 60, 0)
    grid[[where[d] for d in rows["date"]], rows["hour"].to_numpy()] = rate
    fig = _figure(figsize=(8.0, 1.2 + 0.3 * len(dates)))
    ax = fig.add_subplot()
    image = ax.imshow(np.ma.masked_invalid(grid), aspect="auto", cmap="viridis", vmin=0)
    ax.set_facecolor("#dddddd")
    ax.set_xticks(range(0, 24, 3))
    ax.set_yticks(range(len(dates)), dates, fontsize=7)
    ax.set_xlabel("local hour")
    ax.set_title(f"{subject}: turns per recorded hour")
    fig.colorbar(image, ax=ax, label="turns / h")
    fig.tight_layout()
    return _save(fig, path)


def _distributions(result: ProfileResult, path: Path) -> Path:
    doc = result.doc
    by, levels = doc["by"], (doc["groups"]["pd"], doc["groups"]["hc"])
    measures = list(result.contrasts["measure"])
    cols = 4
    n_rows = max(1, -(-len(measures) // cols))
    fig = _figure(figsize=(3.0 * cols, 2.4 * n_rows))
    for k, measure in enumerate(measures):
        ax = fig.add_subplot(n_rows, cols, k + 1)
        data = []
        for level in levels:
            values = result.profile.loc[result.profile[by] == level, measure].to_numpy(float)
            data.append(values[np.isfinite(values)])
        if all(d.size for d in data):
            ax.boxplot(data, showfliers=False)
        for j, values in enumerate(data):
            jitter = np.linspace(-0.15, 0.15, values.size) if values.size > 1 else [0.0]
            ax.plot(np.add(j + 1, jitter), values, "o", ms=3, alpha=0.6)
        ax.set_xticks([1, 2], list(levels))
        ax.set_title(measure, fontsize=8)
        ax.tick_params(labelsize=7)
    fig.tight_layout()
    return _save(fig, path)


def _forest(contrasts: pd.DataFrame, path: Path) -> Path:
    n = contrasts.shape[0]
    fig = _figure(figsize=(9.0, 1.0 + 0.3 * n))
    y = np.arange(n)[::-1]
    for col, (stat, centre) in enumerate((("hedges_g", 0.0), ("auc", 0.5))):
        ax = fig.add_subplot(1, 2, col + 1)
        est = contrasts[stat].to_numpy(float)
        low = est - contrasts[f"{stat}_lo"].to_numpy(float)
        high = contrasts[f"{stat}_hi"].to_numpy(float) - est
        err = np.nan_to_num(np.vstack([low, high]), nan=0.0)
        ax.errorbar(est, y, xerr=err, fmt="o", ms=4, capsize=2, label="this profile")
        shown = False
        for i, measure in enumerate(contrasts["measure"]):
            published = PUBLISHED.get(measure, {}).get(stat)
            if published is not None:
                ax.plot(
                    [published],
                    [y[i]],
                    "D",
                    color="#d62728",
                    ms=6,
                    label=None if shown else "published",
                )
                shown = True
        ax.axvline(centre, color="grey", lw=0.8)
        ax.set_yticks(y, list(contrasts["measure"]) if col == 0 else [""] * n, fontsize=7)
        ax.set_xlabel("Hedges' g (PD - HC)" if stat == "hedges_g" else "AUC (> 0.5: higher in PD)")
        ax.legend(loc="lower right", fontsize=7)
    fig.tight_layout()
    return _save(fig, path)


def write_profile_plots(result: ProfileResult, folder: Path) -> list[Path]:
    """Every figure of the module docstring into ``folder``; their paths."""
    folder = Path(folder)
    paths = [_distributions(result, folder / PROFILE_PLOT_FILES[0])]
    paths.append(_forest(result.contrasts, folder / PROFILE_PLOT_FILES[1]))
    by_hour = result.by_hour
    if by_hour.shape[0]:
        (folder / HEATMAP_DIR).mkdir(exist_ok=True)
        for k, (subject, rows) in enumerate(by_hour.groupby("subject", sort=False)):
            name = f"{k:04d}_{_UNSAFE.sub('-', str(subject)).strip('-') or 'x'}.png"
            paths.append(_heatmap(rows, str(subject), folder / HEATMAP_DIR / name))
    return paths
