"""Number formatting: one rounding rule for every table, page and report of turnbench.

Python's own formatting rounds the binary value of a float, so ``f"{6.25:.1f}"`` prints
``6.2`` (6.25 is exact in binary and rounds half to even) while ``f"{0.15:.1f}"`` prints
``0.1`` (0.15 is a hair below in binary). A reader rounds the printed decimal, half up:
6.3 and 0.2. :func:`fixed` does that, on the shortest decimal form of the float (its
``repr``), so the same value prints the same digits in Markdown, HTML and CSV summaries.
"""

from __future__ import annotations

import math
import numbers
from decimal import ROUND_HALF_UP, Context, Decimal
from typing import Any

from turn_datasets.render.labels import METRIC_LABELS

__all__ = [
    "counted",
    "MISSING",
    "fixed",
    "format_deg",
    "format_metric",
    "is_missing",
    "one_decimal",
    "signed",
]

#: The text of an empty cell (a null, or a value that is not finite).
MISSING = "–"

#: Enough digits for any finite float (the largest has 309 before the point).
_DECIMALS = Context(prec=400, rounding=ROUND_HALF_UP)


def counted(n: int, noun: str) -> str:
    """``1 clip``, ``2 clips``: a count with its noun, in the singular for one."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def is_missing(value: Any) -> bool:
    """``None``, or a float that is NaN or infinite: printed as :data:`MISSING`."""
    return value is None or (isinstance(value, float) and not math.isfinite(value))


def fixed(value: float, digits: int = 1) -> str:
    """``value`` with ``digits`` decimals, rounded half up on its shortest decimal form.

    ``fixed(6.25) == "6.3"``, ``fixed(0.15) == "0.2"``, ``fixed(2.0, 2) == "2.00"``; a value
    that is not finite prints as Python prints it (``nan``, ``inf``).
    """
    value = float(value)
    if not math.isfinite(value):
        return f"{value:.{digits}f}"
    return str(Decimal(repr(value)).quantize(Decimal(1).scaleb(-digits), context=_DECIMALS))


def one_decimal(value: float) -> str:
    """``value`` with one decimal, half up (6.25 -> 6.3): every Markdown table of turnbench."""
    return fixed(value, 1)


def signed(text: str) -> str:
    """A formatted number with an explicit ``+`` unless it already starts with ``-``."""
    return text if text.startswith("-") else "+" + text


def format_deg(angle: float) -> str:
    """An angle of the vocabulary as its label: ``90``, ``112.5`` (no trailing zeros)."""
    return f"{angle:g}"


def format_metric(key: str, value: Any) -> str:
    """One metric value as the paper prints it; :data:`MISSING` for a null.

    ``accuracy`` 0.735 -> ``73.5`` (fractions as percentages, :data:`METRIC_LABELS`);
    ``mae_deg`` 18.46 -> ``18.5``; ``n`` 619 -> ``619`` (an Avg. column's count, a mean over
    groups, with one decimal). A metric not in :data:`METRIC_LABELS` prints with up to three
    decimals. Everything rounds half up (:func:`fixed`).
    """
    if is_missing(value):
        return MISSING
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return str(value)
    integral = isinstance(value, numbers.Integral)
    x = float(value)
    if key == "n" or key.startswith("n_"):
        return f"{int(x)}" if integral or x.is_integer() else one_decimal(x)
    label = METRIC_LABELS.get(key)
    if label is not None:
        return one_decimal(label.scale * x)
    if integral:
        return str(value)
    if abs(x) >= 1e6:
        return f"{x:.4g}"
    return fixed(x, 3).rstrip("0").rstrip(".")
