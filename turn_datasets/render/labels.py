"""The metrics' labels and kinds, declared once for every table, page and figure."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

__all__ = ["METRIC_LABELS", "EVENT_LABELS", "MetricLabel"]


@dataclass(frozen=True)
class MetricLabel:
    """How one metric is named and printed.

    Attributes
    ----------
    short
        The row label of the paper's Tables 4 and 5 (``Acc. (%)``).
    long
        The label where there is room (``Accuracy (%)``: ``turn-eval compare``).
    kind
        ``percent`` (a fraction 0 to 1 printed times 100, as the paper prints it),
        ``decimal`` (printed as it is, in its unit), ``count`` (a whole number, or an
        average of counts) or ``seconds``.
    """

    short: str
    long: str
    kind: str

    @property
    def scale(self) -> float:
        """The factor from the stored value to the printed one."""
        return 100.0 if self.kind == "percent" else 1.0


#: The aggregate metrics of the harness in the paper's row order (Tables 4 and 5).
METRIC_LABELS: Mapping[str, MetricLabel] = MappingProxyType(
    {
        "accuracy": MetricLabel("Acc. (%)", "Accuracy (%)", "percent"),
        "mae_deg": MetricLabel("MAE (°)", "MAE (°)", "decimal"),
        "wprec": MetricLabel("WPrec (%)", "WPrec (%)", "percent"),
        "mae_speed_deg_s": MetricLabel("MAE speed (°/s)", "MAE speed (°/s)", "decimal"),
    }
)


def _same(label: str, kind: str) -> MetricLabel:
    return MetricLabel(label, label, kind)


#: Every number of ``score-events``' tables: the detection counts and rates, the matched
#: pairs' count (``n``), the angle metrics with their one label (:data:`METRIC_LABELS`), and
#: the matched pairs' extras.
EVENT_LABELS: Mapping[str, MetricLabel] = MappingProxyType(
    {
        "tp": _same("# TP", "count"),
        "fp": _same("# FP", "count"),
        "fn": _same("# FN", "count"),
        "precision": _same("Precision (%)", "percent"),
        "recall": _same("Recall (%)", "percent"),
        "f1": _same("F1 (%)", "percent"),
        "n": _same("# Matched", "count"),
        **METRIC_LABELS,
        "direction_agreement": _same("Direction agreement (%)", "percent"),
        "median_abs_dstart_s": _same("Median |Δstart| (s)", "seconds"),
        "median_abs_dend_s": _same("Median |Δend| (s)", "seconds"),
    }
)
