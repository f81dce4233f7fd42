"""Inter-rater agreement on Turn-REMAP turn labels: matching, kappa, the audit.

In the paper (Cheng et al., Section 3.2, Turn-REMAP) two clinicians labelled each turn in
ELAN with its angle from a controlled vocabulary (90° to 360° in 45° steps); about half of
the turns were labelled by both, and Cohen's kappa (0.96) backed the labels before the
disagreements were resolved. This module reproduces that check on any set of annotations.

Matching follows ELAN's own inter-annotator reliability ("modified kappa", Holle & Rein
2015): two annotations of the same participant in the same session are linked when their
overlap divided by the duration of the *longer* one is at least ``min_overlap``; links are
made greedily, highest ratio first, each annotation used at most once.
"""

from __future__ import annotations

import pandas as pd

__all__ = ["MATCH_COLUMNS", "match_annotations"]

#: Column contract of :func:`match_annotations`.
MATCH_COLUMNS = {"index_a": "int64", "index_b": "int64", "overlap_ratio": "float64"}

#: Overlap ratios are computed in floating point; a ratio meant to equal ``min_overlap``
#: exactly (0.6 s of a 1.0 s turn) can come out a hair below it, so the test allows this.
_RATIO_TOLERANCE = 1e-9

_KEYS = ("session", "participant")


def _check_columns(df: pd.DataFrame, name: str) -> None:
    missing = [c for c in (*_KEYS, "start_s", "end_s") if c not in df.columns]
    if missing:
        raise ValueError(f"annotations {name} lack columns {missing}")


def match_annotations(
    a: pd.DataFrame, b: pd.DataFrame, *, min_overlap: float = 0.6
) -> pd.DataFrame:
    """Link annotations of rater A to those of rater B, as ELAN's reliability check does.

    Parameters
    ----------
    a, b
        One rater's annotations each, with columns ``session``, ``participant``, ``start_s``
        and ``end_s`` (seconds). Their index labels identify the annotations and must be
        unique; any other column is ignored.
    min_overlap
        Smallest ``overlap / max(duration_a, duration_b)`` for a link, in ``(0, 1]``
        (ELAN's default and the issue's: 0.6).

    Returns
    -------
    pandas.DataFrame
        ``index_a, index_b, overlap_ratio`` (:data:`MATCH_COLUMNS`), one row per link, each
        index label at most once, sorted by ``index_a``.

    Notes
    -----
    Only annotations with the same ``session`` and ``participant`` can be linked. Candidate
    pairs are taken in order of decreasing ratio; ties are broken by the smaller absolute
    start difference, then by the position of the annotations in ``a`` and in ``b``, so the
    result never depends on hash order. An annotation with zero or negative duration is
    never linked (its ratio is undefined).
    """
    if not 0.0 < float(min_overlap) <= 1.0:
        raise ValueError(f"min_overlap must be in (0, 1], got {min_overlap}")
    _check_columns(a, "a")
    _check_columns(b, "b")
    for df, name in ((a, "a"), (b, "b")):
        if not df.index.is_unique:
            raise ValueError(f"annotations {name} have duplicate index labels")

    def _side(df: pd.DataFrame, suffix: str) -> pd.DataFrame:
        out = pd.DataFrame(
            {
                "session": df["session"].to_numpy(dtype=object),
                "participant": df["participant"].to_numpy(dtype=object),
                f"start{suffix}": df["start_s"].to_numpy(dtype="float64"),
                f"end{suffix}": df["end_s"].to_numpy(dtype="float64"),
                f"pos{suffix}": range(len(df)),
            }
        )
        return out[out[f"end{suffix}"] > out[f"start{suffix}"]]

    left = _side(a, "_a")
    right = _side(b, "_b")
    pairs = left.merge(right, on=list(_KEYS), how="inner", sort=False)
    overlap = (pairs[["end_a", "end_b"]].min(axis=1) - pairs[["start_a", "start_b"]].max(axis=1))
    longer = pd.concat(
        [pairs["end_a"] - pairs["start_a"], pairs["end_b"] - pairs["start_b"]], axis=1
    ).max(axis=1)
    pairs = pairs.assign(
        ratio=(overlap / longer) if len(pairs) else pd.Series([], dtype="float64"),
        start_gap=(pairs["start_a"] - pairs["start_b"]).abs(),
    )
    pairs = pairs[(overlap > 0) & (pairs["ratio"] >= float(min_overlap) - _RATIO_TOLERANCE)]
    pairs = pairs.sort_values(
        ["ratio", "start_gap", "pos_a", "pos_b"],
        ascending=[False, True, True, True],
        kind="mergesort",
    )

    used_a: set[int] = set()
    used_b: set[int] = set()
    rows: list[tuple[int, int, float]] = []
    for pos_a, pos_b, ratio in zip(
        pairs["pos_a"].to_numpy(),
        pairs["pos_b"].to_numpy(),
        pairs["ratio"].to_numpy(),
        strict=True,
    ):
        if pos_a in used_a or pos_b in used_b:
            continue
        used_a.add(int(pos_a))
        used_b.add(int(pos_b))
        rows.append((int(pos_a), int(pos_b), float(min(ratio, 1.0))))
    rows.sort()

    out = pd.DataFrame(
        {
            "index_a": [a.index[r[0]] for r in rows],
            "index_b": [b.index[r[1]] for r in rows],
            "overlap_ratio": [r[2] for r in rows],
        }
    )
    # Index labels are usually the integer row numbers of the annotations table; keep other
    # labels (strings) as they are rather than failing the int64 contract.
    dtypes = dict(MATCH_COLUMNS)
    for col, df in (("index_a", a), ("index_b", b)):
        if not pd.api.types.is_integer_dtype(df.index.dtype):
            dtypes[col] = "object"
    return out.astype(dtypes).reset_index(drop=True)
