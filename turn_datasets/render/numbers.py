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
    "COLUMN_WORDS",
    "P_FLOOR",
    "column_words",
    "counted",
    "elan_time",
    "MISSING",
    "fixed",
    "format_p",
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


#: Below this a p-value prints as a bound: a bootstrap of 1000 resamples cannot resolve
#: smaller values (its smallest is 1/1001 = 0.000999, which is no finding of 0.000999).
P_FLOOR = 0.001


def format_p(p: float) -> str:
    """A p-value as a reader takes it: ``< 0.001`` below :data:`P_FLOOR`, else three
    decimals (``0.008``, ``0.250``); :data:`MISSING` for a null."""
    if is_missing(p):
        return MISSING
    return f"< {P_FLOOR:g}" if p < P_FLOOR else fixed(p, 3)


#: Words for the raw column names a results page shows (``bin_deg`` is "bin (°)").
COLUMN_WORDS = {
    "bin_deg": "bin (°)",
    "clip_id": "clip",
    "angle_deg": "angle (°)",
    "start_s": "start (s)",
    "end_s": "end (s)",
    "duration_s": "duration (s)",
    "start_a_s": "start A",
    "end_a_s": "end A",
    "start_b_s": "start B",
    "end_b_s": "end B",
    "angle_a": "angle A (°)",
    "angle_b": "angle B (°)",
    "angle_a_deg": "angle A (°)",
    "angle_b_deg": "angle B (°)",
    "overlap_ratio": "overlap ratio",
    "scenario": "scenario",
    "location": "location",
    "cohort": "cohort",
    "subject": "subject",
    "session": "session",
    "action": "action",
    "split": "split",
    "participant": "participant",
    "kind": "disagreement",
}


def column_words(name: str) -> str:
    """A column name in words (:data:`COLUMN_WORDS`, else underscores as spaces and a unit
    suffix as the unit: ``speed_deg_s`` is "speed (°/s)")."""
    if name in COLUMN_WORDS:
        return COLUMN_WORDS[name]
    for suffix, unit in (("_deg_s", " (°/s)"), ("_deg", " (°)"), ("_s", " (s)")):
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)].replace("_", " ") + unit
    return name.replace("_", " ")


def elan_time(seconds: float) -> str:
    """Seconds in ELAN's own time format, ``h:mm:ss.mmm`` (what its media player shows)."""
    if is_missing(seconds):
        return MISSING
    ms = int(round(float(seconds) * 1000))
    h, rest = divmod(ms, 3_600_000)
    m, rest = divmod(rest, 60_000)
    s, ms = divmod(rest, 1000)
    return f"{h}:{m:02d}:{s:02d}.{ms:03d}"
