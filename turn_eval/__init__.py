"""turn_eval: score turning-angle predictions against Turn-H3.6M or Turn-REMAP.

Predictions validation, the paper's metrics (accuracy after 45° quantisation, MAE, weighted
precision, MAE of angular speed), group tables, bootstrap confidence intervals, paired
comparison of two submissions, and the paper's angle estimator as ``turn-eval predict``.
"""

from __future__ import annotations

from turn_datasets import __version__
from turn_datasets.errors import GateFailed, TurnbenchError

__all__ = ["GateFailed", "TurnbenchError", "__version__"]
