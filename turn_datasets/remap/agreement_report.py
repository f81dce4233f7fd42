"""The agreement audit as people read it: Markdown tables and the confusion-matrix PNG.

Percentages with one decimal and kappas with three, rounded as every table of turnbench
(:mod:`turn_datasets.render.numbers`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from turn_datasets.fileio import atomic_path
from turn_datasets.remap.matching import UNMATCHED
from turn_datasets.render.markdown import markdown_table
from turn_datasets.render.numbers import fixed, format_deg, signed

if TYPE_CHECKING:
    from turn_datasets.remap.agreement import AgreementAudit, PairStats

__all__ = ["agreement_markdown", "write_confusion_png"]


def _pct(value: float | None) -> str:
    return "n/a" if value is None else fixed(100 * value, 1) + "%"


def _k(value: float | None) -> str:
    return "n/a" if value is None else fixed(value, 3)


def _k_ci(value: float | None, ci: tuple[float, float] | None, n: int | None = None) -> str:
    """Kappa with its interval; an interval of no width (every resample of a few pairs
    agreeing) says how many pairs it rests on, so that 1.000 (1.000 to 1.000) is not read
    as certainty."""
    if value is None:
        return "n/a"
    if ci is None:
        return _k(value)
    size = f"; n = {n}" if n is not None and _k(ci[0]) == _k(ci[1]) else ""
    return f"{_k(value)} ({_k(ci[0])} to {_k(ci[1])}{size})"


def _s(value: float | None) -> str:
    return "n/a" if value is None else signed(fixed(value, 3))


def _stats_row(st: PairStats) -> list[str]:
    a, b = st.raters
    return [
        str(st.annotations[a]),
        str(st.annotations[b]),
        str(st.matched),
        str(st.unmatched[a]),
        str(st.unmatched[b]),
        _pct(st.percent_agreement),
        _k_ci(st.kappa, st.kappa_ci95, st.matched),
        _k_ci(st.kappa_linear, st.kappa_linear_ci95, st.matched),
        _k(st.kappa_with_unmatched),
        _s(st.median_start_diff_s),
        _s(st.median_end_diff_s),
    ]


_STATS_HEADER = [
    "turns A",
    "turns B",
    "matched",
    "unmatched A",
    "unmatched B",
    "agreement",
    "kappa (95% CI)",
    "linear kappa (95% CI)",
    "kappa incl. unmatched",
    "median start B-A (s)",
    "median end B-A (s)",
]


def agreement_markdown(audit: AgreementAudit) -> str:
    """The audit as Markdown (percentages with one decimal, as the paper prints them)."""
    st = audit.overall
    a, b = st.raters
    s = audit.settings
    lines = [
        f"# Inter-rater agreement: {a} (A) vs {b} (B)",
        "",
        f"Turns of the same participant linked when overlap / longer duration >= "
        f"{s['min_overlap']:g}, greedily (as ELAN); kappa over matched pairs, 95% CI by "
        f"percentile bootstrap ({s['bootstrap']} resamples, seed {s['seed']}).",
        "",
    ]
    lines += markdown_table(["", *_STATS_HEADER], [["all", *_stats_row(st)]])
    lines.append("")
    notes = []
    if st.kappa_undefined_reason:
        notes.append(f"Kappa: {st.kappa_undefined_reason}.")
    if st.kappa_with_unmatched_undefined_reason:
        notes.append(f"Kappa incl. unmatched: {st.kappa_with_unmatched_undefined_reason}.")
    if st.bootstrap_undefined:
        notes.append(
            f"{st.bootstrap_undefined} bootstrap resamples had an undefined kappa and were "
            "left out of the interval."
        )
    single = sum(st.single_annotated.values())
    if single:
        notes.append(
            f"Not compared (labelled by one rater only): turns of {a}: "
            f"{st.single_annotated[a]}, of {b}: {st.single_annotated[b]}."
        )
    if notes:
        lines += [*notes, ""]

    lines += ["## Confusion matrix (rows A, columns B)", ""]
    labels = [format_deg(x) + "°" for x in st.labels_deg]
    lines += markdown_table(
        [f"{a} \\ {b}", *labels],
        [[labels[i], *(str(int(c)) for c in row)] for i, row in enumerate(st.confusion)],
    )
    lines.append("")
    if audit.by_session:
        lines += ["## Per session", ""]
        lines += markdown_table(
            ["session", *_STATS_HEADER],
            [[sess, *_stats_row(x)] for sess, x in audit.by_session.items()],
        )
        lines.append("")
    lines += ["## Per pair of raters", ""]
    lines += markdown_table(
        ["A", "B", *_STATS_HEADER],
        [[x.raters[0], x.raters[1], *_stats_row(x)] for x in audit.by_rater_pair],
    )
    lines.append("")
    n_angle = int((audit.disagreements["kind"] == "angle").sum())
    n_un = int((audit.disagreements["kind"] == UNMATCHED).sum())
    lines.append(f"Disagreements to review: {n_angle} with different angles, {n_un} unmatched.")
    return "\n".join(lines) + "\n"


def write_confusion_png(audit: AgreementAudit, path: str | os.PathLike[str]) -> Path:
    """The confusion matrix as a heat map with counts (PNG, reproducible bytes)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    st = audit.overall
    a, b = st.raters
    labels = [format_deg(x) + "°" for x in st.labels_deg]
    conf = st.confusion
    fig = Figure(figsize=(1.0 + 0.6 * len(labels), 0.8 + 0.6 * len(labels)), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.imshow(conf, cmap="Blues", vmin=0, vmax=max(1, int(conf.max())))
    ax.set_xticks(range(len(labels)), labels=labels, rotation=45)
    ax.set_yticks(range(len(labels)), labels=labels)
    ax.set_xlabel(f"{b} (B)")
    ax.set_ylabel(f"{a} (A)")
    kappa = "undefined" if st.kappa is None else f"{st.kappa:.3f}"
    ax.set_title(f"matched turns: {st.matched}, kappa {kappa}", fontsize=9)
    half = conf.max() / 2 if conf.size else 0
    for i in range(conf.shape[0]):
        for j in range(conf.shape[1]):
            if conf[i, j]:
                ax.text(
                    j,
                    i,
                    str(int(conf[i, j])),
                    ha="center",
                    va="center",
                    fontsize=8,
                    color="white" if conf[i, j] > half else "black",
                )
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", metadata={"Software": None})
    return Path(path)
