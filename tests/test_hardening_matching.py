"""Matching two raters' annotations by sweeping sorted intervals (issue 10, #10).

The sweep must give exactly what pairing every annotation with every other gave (the rule:
same session and participant, overlap / longer duration >= min_overlap, greedy by ratio,
then smaller start difference, then row order), while looking only at overlapping pairs.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pandas as pd
from _eaf_builder import Tier, two_raters
from conftest import run_turn_datasets
from hypothesis import given, settings
from hypothesis import strategies as st

from turn_datasets.remap.matching import match_annotations


def _all_pairs(a: pd.DataFrame, b: pd.DataFrame, min_overlap: float) -> list[tuple]:
    """The old rule, by hand: every pair of a participant's annotations, best ratio first."""
    candidates = []
    for i, ra in enumerate(a.itertuples()):
        for j, rb in enumerate(b.itertuples()):
            if (ra.session, ra.participant) != (rb.session, rb.participant):
                continue
            da, db = ra.end_s - ra.start_s, rb.end_s - rb.start_s
            if da <= 0 or db <= 0:
                continue
            overlap = min(ra.end_s, rb.end_s) - max(ra.start_s, rb.start_s)
            ratio = overlap / max(da, db)
            if overlap > 0 and ratio >= min_overlap - 1e-9:
                candidates.append((-ratio, abs(ra.start_s - rb.start_s), i, j, ratio))
    candidates.sort()
    used_a, used_b, links = set(), set(), []
    for _, _, i, j, ratio in candidates:
        if i in used_a or j in used_b:
            continue
        used_a.add(i)
        used_b.add(j)
        links.append((a.index[i], b.index[j], min(ratio, 1.0)))
    return sorted(links, key=lambda t: (list(a.index).index(t[0]), t[1]))


_interval = st.tuples(
    st.sampled_from(["s1", "s2"]),
    st.sampled_from(["P1", "P2"]),
    st.integers(0, 40),
    st.integers(-2, 12),
)


def _frame(rows, offset: int) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "session": [r[0] for r in rows],
            "participant": [r[1] for r in rows],
            # a coarse grid in seconds makes ties in ratio and start difference common
            "start_s": [r[2] * 0.5 for r in rows],
            "end_s": [(r[2] + r[3]) * 0.5 for r in rows],
        },
        index=range(offset, offset + len(rows)),
    )


@settings(max_examples=300, deadline=None)
@given(
    st.lists(_interval, max_size=25),
    st.lists(_interval, max_size=25),
    st.sampled_from([0.05, 0.2, 0.5, 0.6, 0.75, 1.0]),
)
def test_sweep_matching_equals_all_pairs_matching(rows_a, rows_b, min_overlap):
    a, b = _frame(rows_a, 100), _frame(rows_b, 500)
    got = match_annotations(a, b, min_overlap=min_overlap)
    expected = _all_pairs(a, b, min_overlap)
    assert list(got["index_a"]) == [e[0] for e in expected]
    assert list(got["index_b"]) == [e[1] for e in expected]
    np.testing.assert_allclose(got["overlap_ratio"], [e[2] for e in expected])


def _session(n: int, seed: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    rng = np.random.default_rng(seed)
    starts = np.arange(n) * 5.0
    a = pd.DataFrame({"session": "s", "participant": "P", "start_s": starts, "end_s": starts + 2.0})
    jitter = rng.uniform(-0.3, 0.3, n)
    b = pd.DataFrame(
        {
            "session": "s",
            "participant": "P",
            "start_s": starts + jitter,
            "end_s": starts + 2.0 + jitter,
        }
    )
    return a, b


def test_matching_ten_thousand_per_rater_takes_linear_memory():
    # all-pairs held 10,000 x 10,000 candidate rows (11 GB); the sweep holds a few per turn
    a, b = _session(10_000, 0)
    tracemalloc.start()
    links = match_annotations(a, b, min_overlap=0.6)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert len(links) == 10_000
    assert (links["index_a"].to_numpy() == links["index_b"].to_numpy()).all()
    # about 5 MB here; the all-pairs matching peaked at 427 MB for only 2,000 per rater
    assert peak < 5_000 * len(a)


# -- #6: overlapping labels of one participant after adjudication --------------------------


def _two_raters(tmp_path, consensus=()):
    more = []
    if consensus:
        more.append(
            Tier("Turn consensus", annotator="consensus", participant="PD01", annotations=consensus)
        )
    eaf = tmp_path / "eaf"
    eaf.mkdir()
    # bob's overlaps alice's by 0.4 s of the longer 2 s: ratio 0.2, too little to be one turn
    two_raters(eaf / "S01.eaf", [(1000, 2000, "90")], [(1600, 3600, "90")], *more)
    parts = tmp_path / "p.csv"
    parts.write_text("subject,cohort,pair,sex,age,years_since_diagnosis\nPD01,PD,a,F,60,4\n")
    return eaf, parts


def _labels(args, capsys):
    code, _, err = run_turn_datasets(["remap", "labels", *args], capsys)
    return code, err


def test_two_raters_turns_overlapping_too_little_are_unresolved_not_two_labels(tmp_path, capsys):
    eaf, parts = _two_raters(tmp_path)
    out = tmp_path / "o" / "labels.csv"
    code, err = _labels([eaf, "--participants", parts, "--out", out], capsys)
    assert code == 2 and not out.exists()
    assert (
        "unresolved: " + str(eaf / "S01.eaf") + ", tier 'Turn alice', participant PD01, "
        "1.000-3.600 s: overlapping turns: alice 90 (1.000-2.000 s), bob 90 (1.600-3.600 s)"
    ) in err


def test_overlapping_turns_take_the_consensus_or_the_first_rater(tmp_path, capsys):
    eaf, parts = _two_raters(tmp_path, consensus=[(1100, 3000, "135")])
    out = tmp_path / "o" / "labels.csv"
    code, err = _labels([eaf, "--participants", parts, "--out", out], capsys)
    assert code == 0, err
    labels = pd.read_csv(out)
    assert labels[["annotator", "start_s", "end_s", "angle_deg"]].values.tolist() == [
        ["consensus", 1.1, 3.0, 135.0]
    ]
    eaf2, parts2 = _two_raters(tmp_path / "x" if (tmp_path / "x").mkdir() is None else None)
    code, err = _labels(
        [eaf2, "--participants", parts2, "--out", out, "--resolve", "first-rater"], capsys
    )
    assert code == 0, err
    labels = pd.read_csv(out)
    assert labels[["annotator", "start_s", "end_s"]].values.tolist() == [["alice", 1.0, 2.0]]
