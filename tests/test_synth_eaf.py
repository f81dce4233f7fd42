"""The synthetic Turn-REMAP generator: deterministic, in the default convention, truthful."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import sha256_file
from turn_datasets.remap.eaf import load_eaf, read_annotations
from turn_datasets.synthetic.eaf import (
    ANGLES_DEG,
    PARTICIPANT_COLUMNS,
    TRUTH_COLUMNS,
    WRITTEN_COLUMNS,
    Raters,
    write_sessions,
)

SMALL = {
    "n_pairs": 3,
    "sessions_per_pair": 2,
    "turns_per_subject": 30,
    "raters": Raters(disagreement_rate=0.10, missed_rate=0.06, shifted_rate=0.05),
}


@pytest.fixture(scope="module")
def synth(tmp_path_factory):
    return write_sessions(tmp_path_factory.mktemp("synth"), seed=7, **SMALL)


def test_same_seed_same_bytes_other_seed_other_bytes(tmp_path, synth):
    again = write_sessions(tmp_path / "again", seed=7, **SMALL)
    assert [p.name for p in again.paths] == [p.name for p in synth.paths]
    for a, b in zip(again.paths, synth.paths, strict=True):
        assert sha256_file(a) == sha256_file(b)
    assert sha256_file(again.participants_path) == sha256_file(synth.participants_path)
    pd.testing.assert_frame_equal(again.truth, synth.truth)
    other = write_sessions(tmp_path / "other", seed=8, **SMALL)
    assert sha256_file(other.paths[0]) != sha256_file(synth.paths[0])


def test_layout_and_counts(synth):
    # 3 pairs x 2 sessions; 6 people x 30 turns; half of the 6 sessions double-annotated.
    assert [p.name for p in synth.paths] == [
        f"pair{p:02d}_day{d}.eaf" for p in (1, 2, 3) for d in (1, 2)
    ]
    assert len(synth.truth) == 6 * 30
    assert synth.truth.groupby("subject").size().eq(30).all()
    sessions = synth.truth.groupby("session")["double_annotated"].first()
    assert sessions.sum() == 3
    assert list(synth.truth.columns) == list(TRUTH_COLUMNS)
    assert list(synth.written.columns) == list(WRITTEN_COLUMNS)
    assert synth.truth["turn_id"].is_unique
    assert set(synth.truth["angle_deg"]) <= set(map(float, ANGLES_DEG))


def test_participants_table(synth):
    p = synth.participants
    assert list(p.columns) == list(PARTICIPANT_COLUMNS)
    assert p["subject"].tolist() == ["PD01", "HC01", "PD02", "HC02", "PD03", "HC03"]
    assert (p["cohort"] == p["subject"].str[:2]).all()
    assert p.groupby("pair").size().eq(2).all()
    assert p.loc[p["cohort"] == "HC", "years_since_diagnosis"].isna().all()
    assert p.loc[p["cohort"] == "PD", "years_since_diagnosis"].between(1, 15).all()
    assert p["age"].between(55, 80).all()
    on_disk = pd.read_csv(synth.participants_path)
    assert on_disk["subject"].tolist() == p["subject"].tolist()


def test_files_follow_the_default_convention(synth):
    eaf = load_eaf(synth.paths[0])
    turn_tiers = [t for t in eaf.tiers if t.lower().startswith("turn")]
    assert turn_tiers
    for tier in turn_tiers:
        attrs = eaf.tiers[tier][2]
        assert attrs["ANNOTATOR"] in (*synth.raters, synth.consensus)
        assert attrs["PARTICIPANT"] in ("PD01", "HC01")
        assert eaf.linguistic_types[attrs["LINGUISTIC_TYPE_REF"]]["CONTROLLED_VOCABULARY_REF"] == (
            "turn_angle"
        )
    entries = [v[0][0][0] for v in eaf.controlled_vocabularies["turn_angle"][1].values()]
    assert entries == ["90", "135", "180", "225", "270", "315", "360"]
    assert "Scenario" in eaf.tiers and "Location PD01" in eaf.tiers
    assert eaf.tiers["Location HC01"][2]["PARTICIPANT"] == "HC01"


def test_reader_returns_exactly_what_was_written(synth):
    # The labels helper's reader (default schema) must see every annotation with the
    # scenario and room the generator planted: the context tiers are laid out right.
    got = read_annotations(synth.paths)
    key = ["session", "tier", "start_s", "end_s"]
    got = got.sort_values(key).reset_index(drop=True)
    want = synth.written.sort_values(key).reset_index(drop=True)
    assert len(got) == len(want)
    for col in ("session", "tier", "annotator", "participant", "scenario", "location", "value"):
        assert got[col].astype(str).tolist() == want[col].astype(str).tolist(), col
    np.testing.assert_allclose(
        got[["start_s", "end_s", "angle_deg"]], want[["start_s", "end_s", "angle_deg"]]
    )


def test_truth_kinds_are_what_they_say(synth):
    t = synth.truth
    double = t[t["double_annotated"]]
    assert set(double["kind"]) <= {"agree", "disagree", "missed_a", "missed_b", "shifted"}
    assert (t.loc[~t["double_annotated"], "kind"] == "single").all()
    for kind in ("agree", "disagree", "missed_a", "missed_b", "shifted"):
        assert (double["kind"] == kind).any(), kind

    agree = t[t["kind"] == "agree"]
    assert (agree["a_angle_deg"] == agree["angle_deg"]).all()
    assert (agree["b_angle_deg"] == agree["angle_deg"]).all()

    dis = t[t["kind"] == "disagree"]
    gap = (dis["a_angle_deg"] - dis["b_angle_deg"]).abs()
    assert gap.isin([45.0, 90.0]).all()  # one bin apart, sometimes two
    # exactly one of the two raters is wrong, and the consensus writes the truth
    wrong_a = dis["a_angle_deg"] != dis["angle_deg"]
    wrong_b = dis["b_angle_deg"] != dis["angle_deg"]
    assert (wrong_a ^ wrong_b).all()
    assert (dis["consensus_angle_deg"] == dis["angle_deg"]).all()
    # a shifted pair (two overlapping turns of one person) is adjudicated too (issue 10 #6)
    shifted = t[t["kind"] == "shifted"]
    assert (shifted["consensus_angle_deg"] == shifted["angle_deg"]).all()
    assert t.loc[~t["kind"].isin(["disagree", "shifted"]), "consensus_angle_deg"].isna().all()

    assert t.loc[t["kind"] == "missed_a", "a_angle_deg"].isna().all()
    assert t.loc[t["kind"] == "missed_a", "b_angle_deg"].notna().all()
    assert t.loc[t["kind"] == "missed_b", "b_angle_deg"].isna().all()

    # boundaries jittered by a few hundred ms, never more than 2 x 0.15 s
    both = t[t["kind"].isin(["agree", "disagree"])]
    for side in ("a", "b"):
        assert (both[f"{side}_start_s"] - both["start_s"]).abs().max() <= 0.3 + 1e-9
        assert (both[f"{side}_end_s"] - both["end_s"]).abs().max() <= 0.3 + 1e-9
    assert (both["a_start_s"] != both["b_start_s"]).mean() > 0.9
    # ... and really a few hundred ms, not a token millisecond: for errors drawn with sd
    # 0.15 s the median |error| is 0.674 x 0.15 = 0.10 s (half-normal), the sd about 0.15 s.
    errors = np.concatenate(
        [
            (both[f"{side}_{edge}_s"] - both[f"{edge}_s"]).to_numpy()
            for side in ("a", "b")
            for edge in ("start", "end")
        ]
    )
    assert 0.07 < np.median(np.abs(errors)) < 0.15
    assert 0.10 < errors.std() < 0.20
    # Angle slips are mostly to the next bin (far_disagreement_fraction 0.25 by default).
    assert (gap == 45.0).sum() > (gap == 90.0).sum()


def _ratio(a0, a1, b0, b1):
    overlap = np.clip(np.minimum(a1, b1) - np.maximum(a0, b0), 0, None)
    return overlap / np.maximum(a1 - a0, b1 - b0)


def test_truth_ratios_and_no_crosstalk_between_turns(synth):
    t = synth.truth
    both = t[t["a_angle_deg"].notna() & t["b_angle_deg"].notna()]
    ratio = _ratio(both["a_start_s"], both["a_end_s"], both["b_start_s"], both["b_end_s"])
    np.testing.assert_allclose(ratio, both["ratio_ab"])
    kinds = both["kind"]
    assert (both.loc[kinds.isin(["agree", "disagree"]), "ratio_ab"] >= 0.7).all()
    shifted = both.loc[kinds == "shifted", "ratio_ab"]
    assert ((shifted >= 0.29) & (shifted < 0.5)).all()

    # An annotation of rater A overlaps no annotation of rater B but its own turn's: the
    # truth's pairing is the only possible one.
    for (_session, _subject), g in t.groupby(["session", "subject"]):
        a = g.dropna(subset=["a_start_s"])
        b = g.dropna(subset=["b_start_s"])
        ov = (
            np.minimum(a["a_end_s"].to_numpy()[:, None], b["b_end_s"].to_numpy()[None, :])
            - np.maximum(a["a_start_s"].to_numpy()[:, None], b["b_start_s"].to_numpy()[None, :])
        ) > 0
        same = a["turn_id"].to_numpy()[:, None] == b["turn_id"].to_numpy()[None, :]
        assert not (ov & ~same).any()


def test_single_annotated_sessions_alternate_between_raters(synth):
    w = synth.written
    t = synth.truth
    singles = sorted(t.loc[~t["double_annotated"], "session"].unique())
    owners = [sorted(set(w.loc[w["session"] == s, "annotator"])) for s in singles]
    assert owners == [[synth.raters[i % 2]] for i in range(len(singles))]


def test_paper_sized_corpus_has_the_papers_shape(tmp_path):
    # Defaults: 12 pairs, 58 turns each (1392 ~ the paper's 1386), mostly 90 and 180 degrees.
    r = write_sessions(tmp_path, seed=0)
    t = r.truth
    assert len(t) == 24 * 58
    assert t["subject"].nunique() == 24
    share = t["angle_deg"].value_counts(normalize=True)
    assert share[90.0] > share[135.0] and share[180.0] > share[135.0]
    assert share[[225.0, 270.0, 315.0, 360.0]].sum() < 0.2
    assert set(t["scenario"]) == {"scripted", "clinical", "free-living"}
    assert 0.4 < t["double_annotated"].mean() < 0.6
    assert all(Path(p).exists() for p in r.paths)


def test_bad_parameters(tmp_path):
    with pytest.raises(TurnbenchError, match="two different raters"):
        write_sessions(tmp_path, seed=0, raters=Raters(names=("x", "x")))
    with pytest.raises(TurnbenchError, match="consensus rater must differ"):
        write_sessions(tmp_path, seed=0, raters=Raters(names=("x", "consensus")))
    with pytest.raises(TurnbenchError, match="add up to more than 1"):
        write_sessions(tmp_path, seed=0, raters=Raters(disagreement_rate=0.6, missed_rate=0.6))
    with pytest.raises(TurnbenchError, match="outside the vocabulary"):
        write_sessions(tmp_path, seed=0, angle_mix={100: 1.0})
