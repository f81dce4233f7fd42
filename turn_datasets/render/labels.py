"""The metrics' labels and kinds, declared once for every table, page and figure."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

__all__ = ["METRIC_LABELS", "MetricLabel"]


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
        ``percent`` (a fraction 0 to 1 printed times 100, as the paper prints it) or
        ``decimal`` (printed as it is, in its unit).
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
