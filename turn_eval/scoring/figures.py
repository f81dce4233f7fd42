"""How every scorer's figure is written: one PNG rule, so the same figure gives the same bytes.

matplotlib's object API on the Agg canvas (no pyplot state, no display); the PNG carries no
``Software`` metadata, whose matplotlib version would change the bytes between installs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["DPI", "save_figure"]

#: Resolution of every figure.
DPI = 110


def save_figure(fig: Any, path: Path) -> Path:
    """Draw ``fig`` (a ``matplotlib.figure.Figure``) on an Agg canvas, write it to ``path``
    as PNG, and free its artists; returns ``path``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    fig.savefig(path, format="png", dpi=DPI, metadata={"Software": None})
    fig.clear()
    return path
