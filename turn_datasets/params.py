"""Parameter dataclasses declared once: each field carries its unit (in its name), its
default, its bounds and a one-sentence help.

A parameter class (the miner's :class:`turn_datasets.h36m.miner.MinerParams`, a detector's)
declares each field with :func:`param`; the command line makes its options from the fields
(:func:`turn_datasets.cli.common.params_options`), the class checks its values with
:func:`check_params` and documents them with :func:`describe_params`, so the name, default,
bounds and help of a parameter are written in one place.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, Field, field, fields
from typing import Any

from turn_datasets.errors import TurnbenchError

__all__ = ["param", "check_params", "describe_params", "param_fields"]


def param(
    default: float,
    help: str,
    *,
    min: float | None = None,
    max: float | None = None,
    min_open: bool = False,
) -> Any:
    """A dataclass field with its help and bounds in its metadata.

    Parameters
    ----------
    default
        The paper's value (or the documented choice where the paper gives none).
    help
        One sentence, with the unit: the option's ``--help`` and the class's documentation.
    min, max, min_open
        Bounds (``None``: unbounded on that side); ``min_open`` excludes ``min`` itself (a
        positive number). The class checks ``min``; the command line checks both, with
        ``max`` from :mod:`turn_datasets.limits` against typos and unit mix-ups.
    """
    return field(
        default=default,
        metadata={"help": help, "min": min, "max": max, "min_open": min_open},
    )


def param_fields(cls: type) -> list[Field]:
    """The fields of a parameter class declared with :func:`param`, in declaration order."""
    return [f for f in fields(cls) if "help" in f.metadata]


def check_params(obj: Any) -> None:
    """Raise :class:`TurnbenchError` naming the first field that is not a finite number
    within its lower bound (positive where ``min_open``, else at least ``min``)."""
    for f in param_fields(type(obj)):
        value = getattr(obj, f.name)
        lo, is_open = f.metadata["min"], f.metadata["min_open"]
        ok = math.isfinite(value)
        if lo is not None:
            ok = ok and (value > lo if is_open else value >= lo)
        if not ok:
            if lo == 0:
                kind = "positive" if is_open else "non-negative"
            else:
                kind = f"{'>' if is_open else '>='} {lo:g}"
            raise TurnbenchError(f"{f.name} must be a finite {kind} number, got {value}")


def describe_params(cls: type) -> str:
    """A NumPy-style ``Attributes`` section of the fields: name, help and default."""
    lines = ["Attributes", "----------"]
    for f in param_fields(cls):
        default = "" if f.default is MISSING else f" (default {f.default:g})"
        lines += [f.name, f"    {f.metadata['help']}{default}"]
    return "\n".join(lines)
