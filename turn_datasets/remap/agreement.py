"""Inter-rater agreement on Turn-REMAP turn labels: the audit.

In the paper (Cheng et al., Section 3.2, Turn-REMAP) two clinicians labelled each turn in
ELAN with its angle from a controlled vocabulary (90° to 360° in 45° steps); about half of
the turns were labelled by both, and Cohen's kappa (0.96) backed the labels before the
disagreements were resolved. This module reproduces that check on any set of annotations.

Matching follows ELAN's own inter-annotator reliability ("modified kappa", Holle & Rein
2015), in :mod:`turn_datasets.remap.matching`; the kappas and their bootstrap are in
:mod:`turn_datasets.remap.kappa`; the Markdown and the PNG of an audit in
:mod:`turn_datasets.remap.agreement_report`, its ELAN review copies in
:mod:`turn_datasets.remap.review_eaf`.

The audit (:func:`audit_agreement`) compares two raters over the (session, participant) units
that both labelled, and reports, overall, per session and for every pair of raters present:

- annotations per rater, matched pairs, unmatched annotations per rater;
- percent agreement and Cohen's kappa, unweighted and linearly weighted (scikit-learn's
  ``cohen_kappa_score``, the angle bins in order, so two bins apart costs twice one bin
  apart), over matched pairs, each with a seeded percentile bootstrap 95% CI over the pairs;
- kappa with "unmatched" as an extra category (each unmatched annotation is an item one
  rater labelled and the other did not), as ELAN and Holle & Rein report it;
- the confusion matrix and the median start and end differences of matched pairs;
- the disagreements (different angles, or unmatched) for review.

A unit labelled by one rater only (a session the other did not annotate) is not a
disagreement: its annotations are counted as ``single_annotated`` and left out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd
from sklearn.metrics import confusion_matrix

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.remap.kappa import bootstrap_kappa_ci, kappa_score, kappa_undefined_reason
from turn_datasets.remap.matching import (
    UNMATCHED,
    check_annotations,
    default_raters,
    disagreements,
    pair_items,
)
from turn_datasets.render.numbers import format_deg

__all__ = [
    "AgreementAudit",
    "PairStats",
    "audit_agreement",
    "pair_stats",
]


# ---------------------------------------------------------------------------------------
# Statistics of a set of compared items


def _median(values: np.ndarray) -> float | None:
    values = values[np.isfinite(values)]
    # ELAN stores milliseconds; rounding to microseconds drops float noise of ms / 1000.
    return None if len(values) == 0 else round(float(np.median(values)), 6)


@dataclass(frozen=True)
class PairStats:
    """Agreement of two raters over a set of items (all, one session, ...).

    Fractions are 0 to 1; ``None`` where undefined (with a reason for the kappas); times in
    seconds; start and end differences are rater B minus rater A over matched pairs.
    """

    raters: tuple[str, str]
    annotations: dict[str, int]
    single_annotated: dict[str, int]
    matched: int
    unmatched: dict[str, int]
    percent_agreement: float | None
    kappa: float | None
    kappa_linear: float | None
    kappa_ci95: tuple[float, float] | None
    kappa_linear_ci95: tuple[float, float] | None
    bootstrap_undefined: int
    kappa_undefined_reason: str | None
    kappa_with_unmatched: float | None
    kappa_with_unmatched_undefined_reason: str | None
    median_start_diff_s: float | None
    median_end_diff_s: float | None
    median_abs_start_diff_s: float | None
    median_abs_end_diff_s: float | None
    labels_deg: tuple[float, ...]
    confusion: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the keys of ``turn-datasets remap agreement --format json``."""
        a, b = self.raters
        return {
            "raters": [a, b],
            "annotations": dict(self.annotations),
            "single_annotated": dict(self.single_annotated),
            "matched": self.matched,
            "unmatched": dict(self.unmatched),
            "percent_agreement": self.percent_agreement,
            "kappa": self.kappa,
            "kappa_linear": self.kappa_linear,
            "kappa_ci95": None if self.kappa_ci95 is None else list(self.kappa_ci95),
            "kappa_linear_ci95": (
                None if self.kappa_linear_ci95 is None else list(self.kappa_linear_ci95)
            ),
            "bootstrap_undefined": self.bootstrap_undefined,
            "kappa_undefined_reason": self.kappa_undefined_reason,
            "kappa_with_unmatched": self.kappa_with_unmatched,
            "kappa_with_unmatched_undefined_reason": self.kappa_with_unmatched_undefined_reason,
            "median_start_diff_s": self.median_start_diff_s,
            "median_end_diff_s": self.median_end_diff_s,
            "median_abs_start_diff_s": self.median_abs_start_diff_s,
            "median_abs_end_diff_s": self.median_abs_end_diff_s,
            "labels_deg": list(self.labels_deg),
            "confusion": self.confusion.astype(int).tolist(),
        }


def pair_stats(
    items: pd.DataFrame,
    *,
    raters: tuple[str, str],
    labels_deg: Sequence[float],
    single_annotated: Mapping[str, int] | None = None,
    n_bootstrap: int = 1000,
    seed: int = 0,
) -> PairStats:
    """Agreement statistics of the items of :func:`pair_items` (or a subset of them).

    Parameters
    ----------
    items
        :data:`PAIR_COLUMNS` rows.
    raters
        Rater A and rater B, in the order of the ``_a``/``_b`` columns.
    labels_deg
        The ordered angle categories (the vocabulary); angles found outside it are added in
        order. Linear weights count steps in this list, so with the paper's 45° vocabulary
        two bins apart weighs twice one bin apart.
    single_annotated
        Carried into the result (see :func:`pair_items`).
    n_bootstrap, seed
        Percentile bootstrap over matched pairs (:func:`bootstrap_kappa_ci`); 0 for none.
    """
    a, b = raters
    matched = items[items["status"] == "matched"]
    n_ua = int((items["status"] == "unmatched_a").sum())
    n_ub = int((items["status"] == "unmatched_b").sum())
    observed = pd.concat([items["angle_a_deg"], items["angle_b_deg"]]).dropna().unique()
    labels = sorted({float(x) for x in labels_deg} | {float(x) for x in observed})
    position = {x: i for i, x in enumerate(labels)}

    ya = [float(x) for x in matched["angle_a_deg"]]
    yb = [float(x) for x in matched["angle_b_deg"]]
    kappa = kappa_score(ya, yb, labels, None)
    kappa_linear = kappa_score(ya, yb, labels, "linear")
    reason = (
        None
        if kappa is not None
        else kappa_undefined_reason(
            [format_deg(x) for x in ya], [format_deg(x) for x in yb], "matched pairs"
        )
    )
    codes_a = np.array([position[x] for x in ya], dtype=np.int64)
    codes_b = np.array([position[x] for x in yb], dtype=np.int64)
    ci = ci_linear = None
    n_undefined = 0
    if kappa is not None:
        ci, n_undefined = bootstrap_kappa_ci(
            codes_a, codes_b, n_labels=len(labels), n_bootstrap=n_bootstrap, seed=seed
        )
        ci_linear, _ = bootstrap_kappa_ci(
            codes_a,
            codes_b,
            n_labels=len(labels),
            weights="linear",
            n_bootstrap=n_bootstrap,
            seed=seed,
        )

    # Holle & Rein / ELAN: an unmatched annotation is an item the other rater put in the
    # extra category "unmatched".
    text_labels = [format_deg(x) for x in labels] + [UNMATCHED]

    def _cat(v: float) -> str:
        return UNMATCHED if not np.isfinite(v) else format_deg(v)

    y1u = [_cat(v) for v in items["angle_a_deg"]]
    y2u = [_cat(v) for v in items["angle_b_deg"]]
    kappa_u = kappa_score(y1u, y2u, text_labels, None)
    reason_u = None if kappa_u is not None else kappa_undefined_reason(y1u, y2u, "items")

    conf = (
        confusion_matrix(ya, yb, labels=labels)
        if len(ya)
        else np.zeros((len(labels), len(labels)), dtype=int)
    )
    d_start = (matched["start_b_s"] - matched["start_a_s"]).to_numpy(dtype=float)
    d_end = (matched["end_b_s"] - matched["end_a_s"]).to_numpy(dtype=float)
    n_matched = int(len(matched))
    return PairStats(
        raters=(a, b),
        annotations={a: n_matched + n_ua, b: n_matched + n_ub},
        single_annotated=dict(single_annotated or {a: 0, b: 0}),
        matched=n_matched,
        unmatched={a: n_ua, b: n_ub},
        percent_agreement=(float(np.mean(np.asarray(ya) == np.asarray(yb))) if n_matched else None),
        kappa=kappa,
        kappa_linear=kappa_linear,
        kappa_ci95=ci,
        kappa_linear_ci95=ci_linear,
        bootstrap_undefined=n_undefined,
        kappa_undefined_reason=reason,
        kappa_with_unmatched=kappa_u,
        kappa_with_unmatched_undefined_reason=reason_u,
        median_start_diff_s=_median(d_start),
        median_end_diff_s=_median(d_end),
        median_abs_start_diff_s=_median(np.abs(d_start)),
        median_abs_end_diff_s=_median(np.abs(d_end)),
        labels_deg=tuple(labels),
        confusion=np.asarray(conf, dtype=int),
    )


# ---------------------------------------------------------------------------------------
# The audit


@dataclass(frozen=True)
class AgreementAudit:
    """Result of :func:`audit_agreement`.

    Attributes
    ----------
    overall
        The two audited raters over every unit both labelled.
    by_session
        Session -> the same, for the sessions with items.
    by_rater_pair
        Every pair of non-consensus raters present (the audited pair included).
    items
        :data:`PAIR_COLUMNS` rows of the audited pair (``pairs.csv``).
    disagreements
        :data:`DISAGREEMENT_COLUMNS` rows of the audited pair (``disagreements.csv``).
    settings
        ``min_overlap, bootstrap, seed, ci, consensus_annotator`` as used.
    """

    overall: PairStats
    by_session: dict[str, PairStats]
    by_rater_pair: list[PairStats]
    items: pd.DataFrame
    disagreements: pd.DataFrame
    settings: dict[str, Any]

    @property
    def raters(self) -> tuple[str, str]:
        return self.overall.raters

    def to_dict(self) -> dict[str, Any]:
        """The JSON document of ``--format json`` (fractions, not percentages)."""
        out = self.overall.to_dict()
        out["by_session"] = {s: st.to_dict() for s, st in self.by_session.items()}
        out["by_rater_pair"] = [st.to_dict() for st in self.by_rater_pair]
        out["settings"] = dict(self.settings)
        return out

    def summary_table(self, by: str) -> pd.DataFrame:
        """One row per session (``by="session"``) or per rater pair (``"rater_pair"``)."""
        if by == "session":
            keyed = [({"session": s}, st) for s, st in self.by_session.items()]
        elif by == "rater_pair":
            keyed = [
                ({"rater_a": st.raters[0], "rater_b": st.raters[1]}, st)
                for st in self.by_rater_pair
            ]
        else:
            raise ValueError(f"by must be 'session' or 'rater_pair', not {by!r}")
        rows = []
        for key, st in keyed:
            a, b = st.raters
            ci = st.kappa_ci95 or (np.nan, np.nan)
            rows.append(
                {
                    **key,
                    "annotations_a": st.annotations[a],
                    "annotations_b": st.annotations[b],
                    "matched": st.matched,
                    "unmatched_a": st.unmatched[a],
                    "unmatched_b": st.unmatched[b],
                    "percent_agreement": _nan(st.percent_agreement),
                    "kappa": _nan(st.kappa),
                    "kappa_ci95_lo": ci[0],
                    "kappa_ci95_hi": ci[1],
                    "kappa_linear": _nan(st.kappa_linear),
                    "kappa_with_unmatched": _nan(st.kappa_with_unmatched),
                    "median_start_diff_s": _nan(st.median_start_diff_s),
                    "median_end_diff_s": _nan(st.median_end_diff_s),
                }
            )
        key_cols = (
            {"session": "object"} if by == "session" else {"rater_a": "object", "rater_b": "object"}
        )
        dtypes = {
            **key_cols,
            "annotations_a": "int64",
            "annotations_b": "int64",
            "matched": "int64",
            "unmatched_a": "int64",
            "unmatched_b": "int64",
            "percent_agreement": "float64",
            "kappa": "float64",
            "kappa_ci95_lo": "float64",
            "kappa_ci95_hi": "float64",
            "kappa_linear": "float64",
            "kappa_with_unmatched": "float64",
            "median_start_diff_s": "float64",
            "median_end_diff_s": "float64",
        }
        return typed_frame(pd.DataFrame(rows, columns=list(dtypes)), dtypes)

    def confusion_table(self) -> pd.DataFrame:
        """The confusion matrix as a table: rows rater A's angle, columns rater B's."""
        a, b = self.raters
        labels = [format_deg(x) for x in self.overall.labels_deg]
        table = pd.DataFrame(self.overall.confusion, columns=labels).astype("int64")
        table.insert(0, f"{a} (rows) / {b} (columns)", labels)
        return table


def _nan(value: float | None) -> float:
    return np.nan if value is None else float(value)


def audit_agreement(
    annotations: pd.DataFrame,
    *,
    raters: Sequence[str] | None = None,
    labels_deg: Sequence[float] = (90, 135, 180, 225, 270, 315, 360),
    consensus_annotator: str = "consensus",
    min_overlap: float = 0.6,
    n_bootstrap: int = 1000,
    seed: int = 0,
) -> AgreementAudit:
    """Inter-rater agreement of turn labels, as the paper's kappa check (Section 3.2).

    Parameters
    ----------
    annotations
        Every rater's annotations (``eaf.read_annotations``: ``session, file, annotator,
        participant, start_s, end_s, angle_deg``).
    raters
        The two raters to audit; default: the two raters present other than
        ``consensus_annotator`` (an error if there are not exactly two).
    labels_deg
        The ordered angle vocabulary (the schema's ``turn_angle``); it fixes the linear
        weights and the rows and columns of the confusion matrix.
    consensus_annotator
        The adjudicating rater, never audited by default nor in ``by_rater_pair``.
    min_overlap
        Matching threshold, overlap over the longer duration (ELAN's default, 0.6).
    n_bootstrap, seed
        Percentile bootstrap 95% CI of the kappas over matched pairs; 0 for none.

    Raises
    ------
    TurnbenchError
        A named rater is absent, the two are the same, or there are not exactly two raters
        to choose by default.
    """
    check_annotations(annotations)
    if not 0.0 < float(min_overlap) <= 1.0:
        raise TurnbenchError(f"--min-overlap must be in (0, 1], not {min_overlap}")
    present = sorted({str(r) for r in annotations["annotator"].dropna().unique()})
    if raters is None:
        rater_a, rater_b = default_raters(annotations, consensus_annotator=consensus_annotator)
    else:
        if len(raters) != 2:
            raise TurnbenchError(f"name exactly two raters, not {len(raters)}")
        rater_a, rater_b = str(raters[0]), str(raters[1])
        if rater_a == rater_b:
            raise TurnbenchError(f"the two raters are the same ({rater_a!r})")
        for r in (rater_a, rater_b):
            if r not in present:
                raise TurnbenchError(
                    f"rater {r!r} has no annotations; raters found: "
                    f"{', '.join(repr(p) for p in present) or 'none'}"
                )

    items, single = pair_items(
        annotations, rater_a=rater_a, rater_b=rater_b, min_overlap=min_overlap
    )

    def stats(its: pd.DataFrame, raters: tuple[str, str], sing=None) -> PairStats:
        return pair_stats(
            its,
            raters=raters,
            single_annotated=sing,
            labels_deg=labels_deg,
            n_bootstrap=n_bootstrap,
            seed=seed,
        )

    overall = stats(items, (rater_a, rater_b), single)
    by_session = {
        str(session): stats(group, (rater_a, rater_b))
        for session, group in items.groupby("session", sort=True)
    }
    others = [r for r in present if r.casefold().strip() != consensus_annotator.casefold().strip()]
    pairs = [tuple(p) for p in combinations(sorted(others, key=lambda r: (r.casefold(), r)), 2)]
    if (rater_a, rater_b) not in pairs and (rater_b, rater_a) not in pairs:
        pairs.insert(0, (rater_a, rater_b))
    by_pair: list[PairStats] = []
    for ra, rb in pairs:
        if {ra, rb} == {rater_a, rater_b}:
            # the audited pair, in the order asked for
            by_pair.append(overall)
            continue
        its, sing = pair_items(annotations, rater_a=ra, rater_b=rb, min_overlap=min_overlap)
        by_pair.append(stats(its, (ra, rb), sing))
    return AgreementAudit(
        overall=overall,
        by_session=by_session,
        by_rater_pair=by_pair,
        items=items,
        disagreements=disagreements(items, rater_a=rater_a, rater_b=rater_b),
        settings={
            "min_overlap": float(min_overlap),
            "bootstrap": int(n_bootstrap),
            "seed": int(seed),
            "ci": "percentile bootstrap over matched pairs, 95%",
            "consensus_annotator": consensus_annotator,
        },
    )
