"""The agreement gate: does an audit's Cohen's kappa reach ``--min-kappa``?

Kappa over matched turns alone (the paper's figure) leaves out the turns one rater marked
and the other missed: a rater who misses many turns but agrees on the rest passes. Kappa
with "unmatched" as a category (:mod:`turn_datasets.remap.agreement`) counts them. The gate
checks both by default, and ``matched`` keeps the older rule of matched turns alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from turn_datasets.render.numbers import fixed

__all__ = ["GATE_ON", "GateResult", "check_gate"]

#: What the gate checks: ``both`` kappas (the default) or ``matched`` turns alone.
GATE_ON = ("both", "matched")

#: The two kappas, as the gate names them: the audit's field and its words.
_KAPPAS = (
    ("kappa", "kappa over matched turns"),
    ("kappa_with_unmatched", "kappa counting missed turns"),
)


@dataclass(frozen=True)
class GateResult:
    """The gate's verdict: each kappa checked (None where undefined) and those that failed."""

    min_kappa: float
    on: str
    values: dict[str, float | None]
    failed: list[str]
    undefined_reasons: dict[str, str | None]

    @property
    def passed(self) -> bool:
        return not self.failed

    def to_dict(self) -> dict[str, Any]:
        return {
            "min_kappa": self.min_kappa,
            "on": self.on,
            "passed": self.passed,
            "kappa": self.values.get("kappa"),
            "kappa_with_unmatched": self.values.get("kappa_with_unmatched"),
            "failed": list(self.failed),
        }

    def line(self) -> str:
        """The Markdown line: every kappa printed, each checked one passed or FAILED."""
        words = dict(_KAPPAS)
        parts = []
        for key, value in self.values.items():
            shown = "undefined" if value is None else fixed(value, 3)
            checked = key == "kappa" or self.on == "both"
            verdict = ("FAILED" if key in self.failed else "passed") if checked else "not gated"
            parts.append(f"{words[key]} {shown} ({verdict})")
        overall = "passed" if self.passed else "FAILED"
        details = "; ".join(parts)
        return f"Gate: kappa >= {self.min_kappa:g} {overall}. {details[0].upper()}{details[1:]}."

    def failure(self) -> str:
        """Why the gate failed, one line naming each failed kappa."""
        words = {
            "kappa": "Cohen's kappa",
            "kappa_with_unmatched": "Cohen's kappa counting missed turns",
        }
        reasons = []
        for key in self.failed:
            value = self.values[key]
            if value is None:
                why = self.undefined_reasons.get(key) or "undefined"
                reasons.append(
                    f"{words[key]} is undefined ({why}), so --min-kappa {self.min_kappa:g} "
                    "is not met"
                )
            else:
                reasons.append(
                    f"{words[key]} {fixed(value, 3)} is below --min-kappa {self.min_kappa:g}"
                )
        return "; ".join(reasons)


def check_gate(overall: Any, min_kappa: float, on: str = "both") -> GateResult:
    """Check an audit's overall kappas (an object with ``kappa``, ``kappa_with_unmatched`` and
    their ``*_undefined_reason``) against ``min_kappa``; an undefined kappa fails.

    Parameters
    ----------
    overall
        :class:`turn_datasets.remap.agreement.AgreementStats` of the whole audit.
    min_kappa
        The threshold.
    on
        ``both`` (matched turns, and counting missed turns) or ``matched`` (matched alone).
    """
    if on not in GATE_ON:
        raise ValueError(f"on must be one of {GATE_ON}, got {on!r}")
    values = {key: getattr(overall, key) for key, _ in _KAPPAS}
    reasons = {key: getattr(overall, f"{key}_undefined_reason", None) for key, _ in _KAPPAS}
    checked = [key for key, _ in _KAPPAS if key == "kappa" or on == "both"]
    failed = [k for k in checked if values[k] is None or values[k] < min_kappa]
    return GateResult(float(min_kappa), on, values, failed, reasons)
