"""Agreement audit: matching as ELAN's reliability check, kappa, the report."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from _eaf_builder import REAL_FILES

from turn_datasets.errors import TurnbenchError
from turn_datasets.remap.matching import MATCH_COLUMNS, match_annotations


def _ann(rows, index=None):
    return pd.DataFrame(rows, columns=["session", "participant", "start_s", "end_s"], index=index)


def test_match_links_by_ratio_to_longer_duration():
    a = _ann([("s1", "P1", 0.0, 2.0), ("s1", "P1", 10.0, 11.0)])
    # b0 overlaps a0 by 1.5 s; longer is a0 (2.0 s): ratio 0.75 -> linked.
    # b1 overlaps a1 by 0.5 s; both last 1.0 s: ratio 0.5 < 0.6 -> not linked.
    b = _ann([("s1", "P1", 0.5, 2.5), ("s1", "P1", 10.5, 11.5)])
    m = match_annotations(a, b)
    assert list(m.columns) == list(MATCH_COLUMNS)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0]]
    assert m["overlap_ratio"].tolist() == pytest.approx([0.75])
    # with a lower threshold the second pair is linked at 0.5
    m = match_annotations(a, b, min_overlap=0.5)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0], [1, 1]]
    assert m["overlap_ratio"].tolist() == pytest.approx([0.75, 0.5])


def test_match_ratio_uses_longer_not_shorter():
    # b lies inside a: overlap 1.0 s = all of b, but a lasts 2.0 s: ratio 0.5, not 1.0.
    a = _ann([("s1", "P1", 0.0, 2.0)])
    b = _ann([("s1", "P1", 0.5, 1.5)])
    assert match_annotations(a, b).empty
    assert match_annotations(a, b, min_overlap=0.5)["overlap_ratio"].tolist() == [0.5]


def test_match_threshold_inclusive_despite_float_rounding():
    # overlap 0.6 of 1.0 s: 0.6 >= 0.6 must link although 10.6 - 10.0 != 0.6 exactly.
    a = _ann([("s1", "P1", 10.0, 11.0)])
    b = _ann([("s1", "P1", 9.6, 10.6)])
    m = match_annotations(a, b)
    assert len(m) == 1 and m["overlap_ratio"].iloc[0] == pytest.approx(0.6)


def test_match_only_same_session_and_participant():
    a = _ann([("s1", "P1", 0.0, 1.0), ("s1", "P2", 0.0, 1.0), ("s2", "P1", 0.0, 1.0)])
    b = _ann([("s2", "P2", 0.0, 1.0), ("s1", "P2", 0.0, 1.0), ("s2", "P1", 0.0, 1.0)])
    m = match_annotations(a, b)
    # a1 <-> b1 (s1, P2) and a2 <-> b2 (s2, P1); a0 (s1, P1) and b0 (s2, P2) have no partner.
    assert m[["index_a", "index_b"]].values.tolist() == [[1, 1], [2, 2]]


def test_match_greedy_highest_ratio_first():
    # a0 = [0, 2], a1 = [1.2, 3.2]; b0 = [0.2, 2.2], b1 = [1.0, 3.0].
    # ratios (all durations 2 s): a0-b0 1.8/2 = 0.9, a0-b1 1.0/2 = 0.5,
    #                             a1-b0 1.0/2 = 0.5, a1-b1 1.8/2 = 0.9.
    a = _ann([("s", "P", 0.0, 2.0), ("s", "P", 1.2, 3.2)])
    b = _ann([("s", "P", 0.2, 2.2), ("s", "P", 1.0, 3.0)])
    m = match_annotations(a, b, min_overlap=0.4)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0], [1, 1]]
    assert m["overlap_ratio"].tolist() == pytest.approx([0.9, 0.9])

    # Two candidates for one b: a0 = [0, 2] with b0 = [0.1, 2.1] overlaps 1.9 of 2.0 s (0.95),
    # a1 = [0.3, 2.5] overlaps 1.8 of its 2.2 s (0.818); the higher ratio wins, a1 stays alone.
    a = _ann([("s", "P", 0.0, 2.0), ("s", "P", 0.3, 2.5)])
    b = _ann([("s", "P", 0.1, 2.1)])
    m = match_annotations(a, b)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0]]
    assert m["overlap_ratio"].tolist() == pytest.approx([0.95])


def test_match_greedy_can_leave_a_feasible_pair_unlinked():
    # a0 = [0, 10], a1 = [2, 10]; b0 = [1, 10], b1 = [0, 6].
    # a0-b0: 9/10 = 0.9, a0-b1: 6/10 = 0.6, a1-b0: 8/9 = 0.889, a1-b1: 4/8 = 0.5.
    # Greedy takes a0-b0 (0.9); a1 is left with b1 at 0.5 < 0.6: one link only, as ELAN does
    # (an optimal assignment would have linked a0-b1 and a1-b0).
    a = _ann([("s", "P", 0.0, 10.0), ("s", "P", 2.0, 10.0)])
    b = _ann([("s", "P", 1.0, 10.0), ("s", "P", 0.0, 6.0)])
    m = match_annotations(a, b)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0]]


def test_match_tie_break_is_deterministic():
    # a0 = [0, 2] is equally good (ratio 0.75) with b0 = [0.5, 2.5] and b1 = [-0.5, 1.5];
    # equal start gaps (0.5 s), so the earlier row of b wins: b0.
    a = _ann([("s", "P", 0.0, 2.0)])
    b = _ann([("s", "P", 0.5, 2.5), ("s", "P", -0.5, 1.5)])
    assert match_annotations(a, b)[["index_a", "index_b"]].values.tolist() == [[0, 0]]
    # reversed order of b: the earlier row is now the other one.
    b2 = b.iloc[::-1]
    assert match_annotations(a, b2)[["index_a", "index_b"]].values.tolist() == [[0, 1]]


def test_match_keeps_index_labels_and_skips_zero_durations():
    a = _ann([("s", "P", 5.0, 5.0), ("s", "P", 0.0, 1.0)], index=[40, 41])
    b = _ann([("s", "P", 0.0, 1.0), ("s", "P", 5.0, 5.0)], index=[7, 8])
    m = match_annotations(a, b)
    assert m[["index_a", "index_b"]].values.tolist() == [[41, 7]]
    assert m.dtypes.astype(str).to_dict() == MATCH_COLUMNS


def test_match_empty_and_bad_arguments():
    empty = _ann([])
    m = match_annotations(empty, empty)
    assert m.empty and list(m.columns) == list(MATCH_COLUMNS)
    with pytest.raises(TurnbenchError, match="min_overlap"):
        match_annotations(empty, empty, min_overlap=0.0)
    with pytest.raises(ValueError):
        match_annotations(empty.drop(columns="participant"), empty)


# ---------------------------------------------------------------------------------------
# Kappa, by hand


def _annotations(rows):
    """rows: (annotator, session, participant, start_s, end_s, angle_deg)."""
    df = pd.DataFrame(
        rows, columns=["annotator", "session", "participant", "start_s", "end_s", "angle_deg"]
    )
    df["file"] = df["session"] + ".eaf"
    return df


# Five matched turns (A, B) = (90, 90), (90, 135), (180, 180), (180, 180), (135, 135), then
# one turn only A labelled (180) and one only B labelled (90).
HAND = _annotations(
    [
        ("ann", "s1", "P1", 10.0, 12.0, 90),
        ("bob", "s1", "P1", 10.2, 12.0, 90),  # start diff +0.2, end diff 0
        ("ann", "s1", "P1", 20.0, 22.0, 90),
        ("bob", "s1", "P1", 20.0, 22.4, 135),  # start 0, end +0.4
        ("ann", "s1", "P1", 30.0, 33.0, 180),
        ("bob", "s1", "P1", 29.7, 33.0, 180),  # start -0.3, end 0
        ("ann", "s2", "P1", 40.0, 43.0, 180),
        ("bob", "s2", "P1", 40.1, 43.1, 180),  # start +0.1, end +0.1
        ("ann", "s2", "P1", 50.0, 52.0, 135),
        ("bob", "s2", "P1", 50.0, 51.8, 135),  # start 0, end -0.2
        ("ann", "s2", "P1", 60.0, 62.0, 180),  # A only
        ("bob", "s2", "P1", 70.0, 72.0, 90),  # B only
    ]
)


def test_pair_stats_by_hand():
    from turn_datasets.remap.agreement import audit_agreement

    audit = audit_agreement(HAND, n_bootstrap=200, seed=1)
    st = audit.overall
    assert st.raters == ("ann", "bob")
    assert st.matched == 5
    assert st.unmatched == {"ann": 1, "bob": 1}
    assert st.annotations == {"ann": 6, "bob": 6}
    assert st.percent_agreement == pytest.approx(4 / 5)
    # p_o = 4/5; A's marginals 90:2, 135:1, 180:2, B's 90:1, 135:2, 180:2;
    # p_e = (2*1 + 1*2 + 2*2) / 25 = 8/25; kappa = (0.8 - 0.32) / 0.68.
    assert st.kappa == pytest.approx((0.8 - 0.32) / 0.68)
    # Linear weights |i - j| over the bins 90 (0), 135 (1), 180 (2), ...: the one
    # disagreement costs 1; expected cost = sum |i-j| rowA_i colB_j / n
    #   = (2*(0*1 + 1*2 + 2*2) + 1*(1*1 + 0*2 + 1*2) + 2*(2*1 + 1*2 + 0*2)) / 5 = 23/5.
    assert st.kappa_linear == pytest.approx(1 - 1 / (23 / 5))
    # With "unmatched" as a category, 7 items: p_o = 4/7; A: 90:2, 135:1, 180:3, U:1;
    # B: 90:2, 135:2, 180:2, U:1; p_e = (4 + 2 + 6 + 1) / 49 = 13/49; kappa = 15/36.
    assert st.kappa_with_unmatched == pytest.approx(15 / 36)
    # B minus A over matched pairs: starts +0.2, 0, -0.3, +0.1, 0 -> median 0;
    # ends 0, +0.4, 0, +0.1, -0.2 -> median 0; absolute starts .2 0 .3 .1 0 -> 0.1.
    assert st.median_start_diff_s == pytest.approx(0.0)
    assert st.median_end_diff_s == pytest.approx(0.0)
    assert st.median_abs_start_diff_s == pytest.approx(0.1)
    assert st.median_abs_end_diff_s == pytest.approx(0.1)
    assert st.kappa_undefined_reason is None
    lo, hi = st.kappa_ci95
    assert lo <= st.kappa <= hi
    # confusion: rows A, columns B, bins in angle order
    assert st.confusion[:3, :3].tolist() == [[1, 1, 0], [0, 1, 0], [0, 0, 2]]
    assert st.confusion.sum() == 5
    # per session: s1 has 3 matched pairs (2 agree), s2 has 2 matched + 2 unmatched
    assert audit.by_session["s1"].matched == 3
    assert audit.by_session["s1"].percent_agreement == pytest.approx(2 / 3)
    assert audit.by_session["s2"].unmatched == {"ann": 1, "bob": 1}
    # s2's matched pairs (180, 180), (135, 135): p_o = 1, p_e = 1/2 -> kappa 1
    assert audit.by_session["s2"].kappa == pytest.approx(1.0)


def test_disagreements_list_angles_and_unmatched():
    from turn_datasets.remap.agreement import audit_agreement
    from turn_datasets.remap.matching import DISAGREEMENT_COLUMNS

    d = audit_agreement(HAND, n_bootstrap=0).disagreements
    assert list(d.columns) == list(DISAGREEMENT_COLUMNS)
    assert d["kind"].tolist() == ["angle", "unmatched", "unmatched"]
    assert d[["start_a_s", "angle_a_deg", "angle_b_deg"]].iloc[0].tolist() == [20.0, 90.0, 135.0]
    assert d["angle_a_deg"].iloc[1] == 180.0 and np.isnan(d["angle_b_deg"].iloc[1])
    assert np.isnan(d["angle_a_deg"].iloc[2]) and d["angle_b_deg"].iloc[2] == 90.0
    assert set(d["rater_a"]) == {"ann"} and set(d["rater_b"]) == {"bob"}


def test_units_labelled_by_one_rater_are_left_out():
    from turn_datasets.remap.matching import pair_items

    extra = _annotations(
        [
            ("ann", "s3", "P1", 1.0, 2.0, 90),  # session s3: ann only
            ("bob", "s1", "P2", 1.0, 2.0, 90),  # participant P2 of s1: bob only
            ("bob", "s1", "P2", 5.0, 6.0, 180),
        ]
    )
    items, single = pair_items(
        pd.concat([HAND, extra], ignore_index=True), rater_a="ann", rater_b="bob"
    )
    assert single == {"ann": 1, "bob": 2}
    assert len(items) == 7  # HAND's 5 matched + 2 unmatched only
    assert set(items["session"]) == {"s1", "s2"}


def test_kappa_undefined_is_null_with_a_reason():
    from turn_datasets.remap.agreement import audit_agreement

    same = _annotations(
        [
            ("ann", "s", "P", 0.0, 2.0, 90),
            ("bob", "s", "P", 0.0, 2.0, 90),
            ("ann", "s", "P", 5.0, 7.0, 90),
            ("bob", "s", "P", 5.0, 7.0, 90),
        ]
    )
    st = audit_agreement(same, n_bootstrap=100).overall
    assert st.matched == 2 and st.percent_agreement == 1.0
    assert st.kappa is None and st.kappa_linear is None and st.kappa_ci95 is None
    assert "90" in st.kappa_undefined_reason and "chance" in st.kappa_undefined_reason

    apart = _annotations([("ann", "s", "P", 0.0, 2.0, 90), ("bob", "s", "P", 5.0, 7.0, 90)])
    st = audit_agreement(apart, n_bootstrap=100).overall
    assert st.matched == 0 and st.percent_agreement is None
    assert st.kappa is None and st.kappa_undefined_reason == "no matched pairs"
    # items (90, U) and (U, 90): p_o = 0, p_e = 1/2 -> kappa -1
    assert st.kappa_with_unmatched == pytest.approx(-1.0)


def test_rater_choice():
    from turn_datasets.errors import TurnbenchError
    from turn_datasets.remap.agreement import audit_agreement
    from turn_datasets.remap.matching import default_raters

    cons = _annotations([("Consensus", "s1", "P1", 20.0, 22.0, 135)])
    with_cons = pd.concat([HAND, cons], ignore_index=True)
    assert default_raters(with_cons) == ("ann", "bob")
    third = _annotations([("cy", "s1", "P1", 10.0, 12.0, 90)])
    three = pd.concat([HAND, third], ignore_index=True)
    with pytest.raises(TurnbenchError, match="found 3"):
        default_raters(three)
    with pytest.raises(TurnbenchError, match="'zed' has no annotations"):
        audit_agreement(HAND, raters=["ann", "zed"])
    with pytest.raises(TurnbenchError, match="same"):
        audit_agreement(HAND, raters=["ann", "ann"])
    audit = audit_agreement(three, raters=["bob", "ann"], n_bootstrap=0)
    assert audit.raters == ("bob", "ann")
    assert audit.overall.unmatched == {"bob": 1, "ann": 1}
    # every pair of raters: (ann, bob) is the audited one, in the order asked for
    pairs = [st.raters for st in audit.by_rater_pair]
    assert pairs == [("bob", "ann"), ("ann", "cy"), ("bob", "cy")]
    ann_cy = audit.by_rater_pair[1]
    # cy's one turn [10, 12] 90 matches ann's [10, 12] 90; only s1/P1 is shared: ann has 3
    # turns there, so 2 unmatched.
    assert ann_cy.matched == 1 and ann_cy.unmatched == {"ann": 2, "cy": 0}
    assert ann_cy.single_annotated == {"ann": 3, "cy": 0}


def test_vectorised_kappa_equals_scikit_learn():
    from sklearn.metrics import cohen_kappa_score

    from turn_datasets.remap.kappa import _kappa_from_counts, _weights

    rng = np.random.default_rng(3)
    for _ in range(20):
        k = int(rng.integers(2, 8))
        a = rng.integers(0, k, size=60)
        b = np.where(rng.random(60) < 0.7, a, rng.integers(0, k, size=60))
        counts = np.zeros((k, k))
        np.add.at(counts, (a, b), 1)
        for w in (None, "linear"):
            want = cohen_kappa_score(a, b, labels=list(range(k)), weights=w)
            assert _kappa_from_counts(counts, _weights(k, w)) == pytest.approx(want)


def test_bootstrap_ci_is_seeded_and_agrees_with_scipy():
    from scipy.stats import bootstrap
    from sklearn.metrics import cohen_kappa_score

    from turn_datasets.remap.kappa import bootstrap_kappa_ci

    rng = np.random.default_rng(0)
    a = rng.integers(0, 4, size=300)
    b = np.where(rng.random(300) < 0.8, a, rng.integers(0, 4, size=300))
    ci1, bad = bootstrap_kappa_ci(a, b, n_labels=4, n_bootstrap=2000, seed=5)
    ci2, _ = bootstrap_kappa_ci(a, b, n_labels=4, n_bootstrap=2000, seed=5)
    ci3, _ = bootstrap_kappa_ci(a, b, n_labels=4, n_bootstrap=2000, seed=6)
    assert ci1 == ci2 and ci1 != ci3 and bad == 0
    # scipy's percentile bootstrap of scikit-learn's kappa, another resampling stream:
    # the intervals agree to Monte Carlo error.
    ref = bootstrap(
        (a, b),
        lambda x, y: cohen_kappa_score(x, y, labels=[0, 1, 2, 3]),
        paired=True,
        vectorized=False,
        n_resamples=2000,
        method="percentile",
        rng=np.random.default_rng(1),
    ).confidence_interval
    assert ci1[0] == pytest.approx(ref.low, abs=0.02)
    assert ci1[1] == pytest.approx(ref.high, abs=0.02)
    assert bootstrap_kappa_ci(a[:0], b[:0], n_labels=4)[0] is None
    assert bootstrap_kappa_ci(a, b, n_labels=4, n_bootstrap=0)[0] is None


def test_bootstrap_drops_resamples_with_undefined_kappa():
    from turn_datasets.remap.kappa import bootstrap_kappa_ci

    # 9 pairs (0, 0) and one (1, 1): a resample without the (1, 1) pair has one category,
    # probability (9/10)^10 = 0.35; those are counted and left out.
    a = np.array([0] * 9 + [1])
    ci, bad = bootstrap_kappa_ci(a, a.copy(), n_labels=2, n_bootstrap=1000, seed=0)
    assert ci == (1.0, 1.0)
    assert 0.30 * 1000 < bad < 0.40 * 1000


# ---------------------------------------------------------------------------------------
# Synthetic sessions: the expected kappa from the generator's truth, worked out here


@pytest.fixture(scope="module")
def synth(tmp_path_factory):
    from turn_datasets.synthetic.eaf import Raters, write_sessions

    raters = Raters(
        disagreement_rate=0.08, far_disagreement_fraction=0.4, missed_rate=0.05, shifted_rate=0.04
    )
    return write_sessions(
        tmp_path_factory.mktemp("synth"), seed=11, n_pairs=4, turns_per_subject=40, raters=raters
    )


def _kappa_by_hand(a_deg, b_deg, *, linear=False):
    bins = [90, 135, 180, 225, 270, 315, 360]
    i = np.array([bins.index(int(x)) for x in a_deg])
    j = np.array([bins.index(int(x)) for x in b_deg])
    n = len(i)
    obs = np.zeros((7, 7))
    np.add.at(obs, (i, j), 1.0)
    obs /= n
    exp = np.outer(obs.sum(axis=1), obs.sum(axis=0))
    w = np.abs(np.subtract.outer(np.arange(7), np.arange(7))) if linear else 1 - np.eye(7)
    # kappa = 1 - observed disagreement / expected disagreement (= (p_o - p_e)/(1 - p_e)
    # for the unweighted case)
    return 1 - (w * obs).sum() / (w * exp).sum()


def test_synthetic_audit_matches_the_truth(synth):
    from turn_datasets.remap.agreement import audit_agreement
    from turn_datasets.remap.eaf import read_annotations

    t = synth.truth
    both = t[t["a_angle_deg"].notna() & t["b_angle_deg"].notna()]
    matched = both[both["ratio_ab"] >= 0.6]  # agree + disagree; shifted pairs are below 0.5
    assert set(matched["kind"]) == {"agree", "disagree"}
    a, b = synth.raters
    double = t[t["double_annotated"]]
    want_unmatched = {
        a: int(double["a_angle_deg"].notna().sum() - len(matched)),
        b: int(double["b_angle_deg"].notna().sum() - len(matched)),
    }
    # p_o and p_e by hand from the planted angles
    p_o = float((matched["a_angle_deg"] == matched["b_angle_deg"]).mean())
    pa = matched["a_angle_deg"].value_counts(normalize=True)
    pb = matched["b_angle_deg"].value_counts(normalize=True)
    p_e = float(sum(pa.get(x, 0.0) * pb.get(x, 0.0) for x in set(pa.index) | set(pb.index)))
    want_kappa = (p_o - p_e) / (1 - p_e)

    audit = audit_agreement(read_annotations(synth.paths), n_bootstrap=500, seed=0)
    st = audit.overall
    assert st.raters == (a, b)
    assert st.matched == len(matched)
    assert st.unmatched == want_unmatched
    assert st.single_annotated == {
        a: int((~t["double_annotated"] & t["a_angle_deg"].notna()).sum()),
        b: int((~t["double_annotated"] & t["b_angle_deg"].notna()).sum()),
    }
    assert st.percent_agreement == pytest.approx(p_o)
    assert st.kappa == pytest.approx(want_kappa)
    assert st.kappa == pytest.approx(_kappa_by_hand(matched["a_angle_deg"], matched["b_angle_deg"]))
    assert st.kappa_linear == pytest.approx(
        _kappa_by_hand(matched["a_angle_deg"], matched["b_angle_deg"], linear=True)
    )
    # far disagreements (two bins) were planted, so linear weighting forgives less than
    # it would with one-bin slips only, but still more than unweighted
    assert st.kappa_linear > st.kappa
    assert st.kappa_ci95[0] < st.kappa < st.kappa_ci95[1]

    # kappa with "unmatched" as a category: every double-annotated planted turn is an item,
    # a shifted pair counting twice (A's with U, U with B's)
    ya, yb = [], []
    for r in double.itertuples():
        if r.kind == "shifted":
            ya += [str(int(r.a_angle_deg)), "U"]
            yb += ["U", str(int(r.b_angle_deg))]
        else:
            ya.append("U" if np.isnan(r.a_angle_deg) else str(int(r.a_angle_deg)))
            yb.append("U" if np.isnan(r.b_angle_deg) else str(int(r.b_angle_deg)))
    ya, yb = np.array(ya), np.array(yb)
    p_o_u = float((ya == yb).mean())
    cats = sorted(set(ya) | set(yb))
    p_e_u = sum(float((ya == c).mean()) * float((yb == c).mean()) for c in cats)
    assert st.kappa_with_unmatched == pytest.approx((p_o_u - p_e_u) / (1 - p_e_u))

    # disagreements: the planted angle disagreements, then every unmatched annotation
    d = audit.disagreements
    assert (d["kind"] == "angle").sum() == (matched["kind"] == "disagree").sum()
    assert (d["kind"] == "unmatched").sum() == sum(want_unmatched.values())

    # per session, one of them by hand
    session = sorted(double["session"].unique())[0]
    ms = matched[matched["session"] == session]
    assert audit.by_session[session].matched == len(ms)
    assert audit.by_session[session].percent_agreement == pytest.approx(
        float((ms["a_angle_deg"] == ms["b_angle_deg"]).mean())
    )
    assert audit.by_session[session].kappa == pytest.approx(
        _kappa_by_hand(ms["a_angle_deg"], ms["b_angle_deg"])
    )
    assert set(audit.by_session) == set(double["session"])


def test_synthetic_lower_min_overlap_matches_the_shifted_pairs(synth):
    from turn_datasets.remap.agreement import audit_agreement
    from turn_datasets.remap.eaf import read_annotations

    t = synth.truth
    both = t[t["a_angle_deg"].notna() & t["b_angle_deg"].notna()]
    n_shifted = int((both["kind"] == "shifted").sum())
    assert n_shifted > 0
    ann = read_annotations(synth.paths)
    at_06 = audit_agreement(ann, n_bootstrap=0).overall.matched
    at_02 = audit_agreement(ann, min_overlap=0.25, n_bootstrap=0).overall.matched
    assert at_02 == at_06 + n_shifted == len(both)


# ---------------------------------------------------------------------------------------
# Review copies of real ELAN exports


@pytest.mark.parametrize("name", REAL_FILES)
def test_review_copy_of_real_exports_keeps_everything(real_eaf_dir, tmp_path, name):
    from turn_datasets.fileio import sha256_file
    from turn_datasets.remap.eaf import load_eaf
    from turn_datasets.remap.review_eaf import write_review_eaf

    src = real_eaf_dir / name
    digest = sha256_file(src)
    rows = pd.DataFrame(
        {
            "session": [src.stem] * 2,
            "participant": ["P1"] * 2,
            "kind": ["angle", "unmatched"],
            "rater_a": ["ann"] * 2,
            "start_a_s": [1.0, 3.0],
            "end_a_s": [2.0, 4.0],
            "angle_a_deg": [90.0, 180.0],
            "rater_b": ["bob"] * 2,
            "start_b_s": [1.1, np.nan],
            "end_b_s": [2.2, np.nan],
            "angle_b_deg": [135.0, np.nan],
            "overlap_ratio": [0.8, np.nan],
            "file": [str(src)] * 2,
        }
    )
    out = write_review_eaf(src, tmp_path / name, rows, rater_a="ann", rater_b="bob")
    assert sha256_file(src) == digest
    original, copy = load_eaf(src), load_eaf(out)
    for tier, (aligned, refs, attrs, _) in original.tiers.items():
        assert len(copy.tiers[tier][0]) == len(aligned), tier
        assert len(copy.tiers[tier][1]) == len(refs), tier
        assert copy.tiers[tier][2] == attrs
    assert set(copy.tiers) - set(original.tiers) == {"Disagreement"}
    assert copy.tiers["Disagreement"][2]["PARTICIPANT"] == "P1"
    assert sorted(copy.get_annotation_data_for_tier("Disagreement")) == [
        (1000, 2200, "ann: 90 / bob: 135"),
        (3000, 4000, "ann: 180 / bob: none (unmatched)"),
    ]
    # what pympi does not keep is kept too: ELAN 3.0 links of values to vocabulary entries
    text_src = src.read_text(encoding="utf-8")
    text_out = out.read_text(encoding="utf-8")
    assert text_out.count("CVE_REF=") == text_src.count("CVE_REF=")
    assert "MEDIA_DESCRIPTOR" not in text_out

    # Privacy: no header field of the source is left, read with the standard library.
    import xml.etree.ElementTree as ET

    src_root, out_root = ET.parse(src).getroot(), ET.parse(out).getroot()
    urls = [
        v
        for el in src_root.iter()
        if el.tag in ("MEDIA_DESCRIPTOR", "LINKED_FILE_DESCRIPTOR")
        for k, v in el.attrib.items()
        if k.endswith("URL") or k == "EXTRACTED_FROM"
    ]
    assert all(u not in text_out for u in urls)
    assert out_root.get("AUTHOR") == "" and out_root.get("DATE") == "1970-01-01T00:00:00+00:00"
    header = out_root.find("HEADER")
    assert header is None or not header.get("MEDIA_FILE")
    counters = [] if header is None else header.findall("PROPERTY")
    # Only ELAN's (or pympi's) annotation counter stays, past every id in the copy, so ELAN
    # never hands out one of the new ids again.
    assert {p.get("NAME") for p in counters} <= {"lastUsedAnnotationId", "lastUsedAnnotation"}
    ids = [
        el.get("ANNOTATION_ID")
        for el in out_root.iter()
        if el.tag in ("ALIGNABLE_ANNOTATION", "REF_ANNOTATION")
    ]
    assert len(ids) == len(set(ids))
    numeric = [int(i[1:]) for i in ids if i[:1] == "a" and i[1:].isdigit()]
    assert all(int(p.text) >= max(numeric) for p in counters)
    src_counters = {
        p.get("NAME"): int(p.text)
        for p in src_root.iter("PROPERTY")
        if p.get("NAME") in ("lastUsedAnnotationId", "lastUsedAnnotation")
    }
    # The two new annotations take the next ids after the source's ids and counter.
    new_ids = sorted(
        int(el.get("ANNOTATION_ID")[1:])
        for t in out_root.iter("TIER")
        if t.get("TIER_ID") == "Disagreement"
        for el in t.iter("ALIGNABLE_ANNOTATION")
    )
    src_ids = [
        int(el.get("ANNOTATION_ID")[1:])
        for el in src_root.iter()
        if el.tag in ("ALIGNABLE_ANNOTATION", "REF_ANNOTATION")
        and el.get("ANNOTATION_ID")[1:].isdigit()
    ]
    first = max([*src_ids, *src_counters.values()]) + 1
    assert new_ids == [first, first + 1]
    assert {p.get("NAME"): int(p.text) for p in counters} == {k: first + 1 for k in src_counters}

    # With keep_media_paths the header is the source's (its counter moved on). The 2.8 and
    # 3.0 samples have a header of the same kind as 2.7's (2.4 MB each): once is enough.
    if name in ("pympi_sample_2.8.eaf", "pympi_sample_3.0.eaf"):
        return
    kept = write_review_eaf(
        src, tmp_path / ("kept_" + name), rows, rater_a="ann", rater_b="bob", keep_media_paths=True
    )
    kept_root = ET.parse(kept).getroot()
    assert all(u in kept.read_text(encoding="utf-8") for u in urls)
    for key in ("AUTHOR", "DATE"):
        assert kept_root.get(key) == src_root.get(key)
    kept_props = [
        (p.get("NAME"), p.text)
        for p in kept_root.iter("PROPERTY")
        if p.get("NAME") not in src_counters
    ]
    assert kept_props == [
        (p.get("NAME"), p.text)
        for p in src_root.iter("PROPERTY")
        if p.get("NAME") not in src_counters
    ]


def test_markdown_tables_survive_pipes_in_names():
    import re

    from turn_datasets.remap.agreement import audit_agreement
    from turn_datasets.remap.agreement_report import agreement_markdown

    odd = HAND.replace({"annotator": {"ann": "ann|x"}, "session": {"s1": "s|1"}})
    md = agreement_markdown(audit_agreement(odd, n_bootstrap=0))
    assert "ann\\|x" in md and "s\\|1" in md
    # Every row of a table has as many cell separators (unescaped "|") as its header.
    for block in md.split("\n\n"):
        rows = [line for line in block.splitlines() if line.startswith("|")]
        if rows:
            counts = {len(re.findall(r"(?<!\\)\|", line)) for line in rows}
            assert len(counts) == 1, block
