"""``turn_datasets.synthetic.demo_corpus``: the bundled corpus is what the issue asks for, and repeatable.

A small corpus (two subjects, two actions) is written once per module; the checks read it
back through the project's readers, as the miner does, and compare with what the issue and
the paper ask for (subjects, action names, layouts, 50 Hz, 32 joints, turn range, bin shape),
and the estimator skeletons against the labels' angles through the foundation's geometry.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import write_npz
from turn_datasets.geometry import turning_angle
from turn_datasets.mocap.arrays import iter_arrays
from turn_datasets.mocap.readers import discover, read_source
from turn_datasets.skeleton import H36M17, to_z_up
from turn_datasets.synthetic.degrade import degrade_skeleton
from turn_datasets.synthetic.demo_corpus import (
    DEMO_SEED,
    H36M_BIN_MIX,
    camera_axes_m,
    write_h36m_corpus,
    write_h36m_estimates,
    write_remap_corpus,
    write_remap_estimates,
)
from turn_datasets.synthetic.eaf import ANGLE_MIX, SCENARIO_MIX

SMALL = {"Walking": (4, 5), "Directions": (1, 1)}


@pytest.fixture(scope="module")
def h36m(tmp_path_factory):
    root = tmp_path_factory.mktemp("h36m")
    return write_h36m_corpus(root, seed=5, subjects=("S1", "S5", "S9", "S11"), actions=SMALL)


def test_three_layouts_with_the_release_names(h36m) -> None:
    rel = sorted(str(p.relative_to(h36m.root)) for p in h36m.files)
    assert rel == [
        "S1/MyPoseFeatures/D3_Positions/Directions 1.cdf",
        "S1/MyPoseFeatures/D3_Positions/Directions.cdf",
        "S1/MyPoseFeatures/D3_Positions/Walking 1.cdf",
        "S1/MyPoseFeatures/D3_Positions/Walking.cdf",
        "S5/MyPoses/3D_positions/Directions 1.h5",
        "S5/MyPoses/3D_positions/Directions.h5",
        "S5/MyPoses/3D_positions/Walking 1.h5",
        "S5/MyPoses/3D_positions/Walking.h5",
        "data_3d_h36m.npz",
    ]
    formats = sorted({s.fmt for s in discover([h36m.root])})
    assert formats == ["cdf", "h36m-h5", "videopose-npz"]


def test_sequences_read_back_as_h36m(h36m) -> None:
    seen = set()
    for src in discover([h36m.root]):
        for seq in read_source(src):
            seen.add((seq.subject, seq.action, seq.subaction))
            assert seq.fps == 50.0
            assert seq.positions.shape[1:] == (32, 3)
            # VideoPose3D stores metres, the two others millimetres; a standing pelvis is
            # about 0.965 m high either way
            scale = 1000.0 if seq.units == "m" else 1.0
            pelvis_z = np.nanmedian(seq.positions[:, 0, 2]) * scale
            assert 850.0 < pelvis_z < 1050.0
            # a few capture dropouts: whole NaN frames
            assert np.isnan(seq.positions).all(axis=(1, 2)).any()
    # S11 lacks "Directions 1" as some copies of the release do; everyone else has two trials
    assert ("S11", "Directions", "1") not in seen
    assert len(seen) == 4 * 2 * 2 - 1
    assert ("S1", "Walking", "1") in seen and ("S9", "Directions", "") in seen


def test_s1_keeps_its_own_spellings(tmp_path: Path) -> None:
    corpus = write_h36m_corpus(
        tmp_path, seed=1, subjects=("S1",), actions={"WalkDog": (1, 1), "Photo": (1, 1)}
    )
    names = sorted(p.name for p in corpus.files)
    assert names == ["TakingPhoto 1.cdf", "TakingPhoto.cdf", "WalkingDog 1.cdf", "WalkingDog.cdf"]
    actions = {seq.action for src in discover([tmp_path]) for seq in read_source(src)}
    assert actions == {"Photo", "WalkDog"}


def test_planted_turns_span_the_papers_range(h36m) -> None:
    p = h36m.planted
    # the paper's clips run from 45.2° to 234.7°; the planted ones stay inside
    assert p["angle_deg"].between(45.0, 235.0).all()
    assert set(p["direction"]) == {"left", "right"}
    assert (p["bin_deg"] == 45 * np.floor(p["angle_deg"] / 45 + 0.5)).all()
    # the planted file is what the dataclass holds
    back = pd.read_csv(h36m.planted_path, keep_default_na=False, dtype={"subaction": str})
    assert len(back) == len(p)


def test_bin_mix_follows_the_requested_shares(tmp_path: Path) -> None:
    corpus = write_h36m_corpus(
        tmp_path, seed=3, subjects=("S6", "S7", "S8"), actions={"Walking": (9, 9)}
    )
    shares = corpus.planted["bin_deg"].value_counts(normalize=True)
    # 3 subjects x 2 trials x 9 turns = 54 turns; the heading asked for is drawn per bin, the
    # hip angle differs from it by the sway (a few degrees), so a few turns change bin:
    # each share is within 0.15 of the requested one (binomial sd <= 0.07 at n = 54)
    assert len(corpus.planted) == 54
    for bin_deg, share in H36M_BIN_MIX.items():
        assert abs(shares.get(bin_deg, 0.0) - share) < 0.15


def test_same_seed_same_bytes(tmp_path: Path) -> None:
    a = write_h36m_corpus(tmp_path / "a", seed=9, subjects=("S1", "S5", "S9"), actions=SMALL)
    b = write_h36m_corpus(tmp_path / "b", seed=9, subjects=("S1", "S5", "S9"), actions=SMALL)
    for fa, fb in zip(sorted(a.files), sorted(b.files), strict=True):
        assert fa.read_bytes() == fb.read_bytes(), fa.name
    assert a.planted_path.read_bytes() == b.planted_path.read_bytes()


def test_camera_axes_invert_to_z_up() -> None:
    world = np.random.default_rng(0).normal(size=(4, 17, 3)) * 1000.0
    cam = camera_axes_m(world)
    assert cam.dtype == np.float32
    # y down in the camera frame: a point 1 m up in the world has camera y = -1 m
    np.testing.assert_allclose(
        to_z_up(cam.astype(float), "-y") * 1000.0, world, rtol=1e-6, atol=1e-3
    )


def test_clip_npz_is_reproducible_and_readable(tmp_path: Path) -> None:
    arrays = {"b": np.ones((3, 17, 3), np.float32), "a": np.zeros((2, 17, 3), np.float32)}
    write_npz(tmp_path / "x.npz", arrays)
    write_npz(tmp_path / "y.npz", arrays)
    assert (tmp_path / "x.npz").read_bytes() == (tmp_path / "y.npz").read_bytes()
    back = dict(iter_arrays(tmp_path / "x.npz"))
    assert sorted(back) == ["a", "b"]
    np.testing.assert_array_equal(back["b"], arrays["b"])


def test_h36m_estimates_cut_every_clip(h36m, tmp_path: Path) -> None:
    planted = h36m.planted.copy()
    planted["clip_id"] = [f"clip{i}" for i in range(len(planted))]
    out = write_h36m_estimates(
        planted, [h36m.root], tmp_path / "est.npz", degrade=degrade_skeleton, seed=1
    )
    arrays = dict(iter_arrays(out))
    assert sorted(arrays) == sorted(planted["clip_id"])
    errors = []
    for row in planted.itertuples(index=False):
        clip = arrays[row.clip_id]
        assert clip.shape == (row.end_frame - row.start_frame, 17, 3)
        assert clip.dtype == np.float32
        got = turning_angle(to_z_up(clip.astype(float), "-y"), H36M17, method="net")
        errors.append(got.angle_deg - row.angle_deg)
        assert got.direction == row.direction or abs(row.angle_deg) < 1
    # degraded like a monocular estimator: not exact, but within tens of degrees
    mae = float(np.mean(np.abs(errors)))
    assert 1.0 < mae < 30.0
    with pytest.raises(TurnbenchError, match="not in the sources"):
        bad = planted.assign(subject="S7")
        write_h36m_estimates(bad, [h36m.root], tmp_path / "no.npz", degrade=degrade_skeleton)
    assert not (tmp_path / "no.npz").exists()
    # read from a file, the error names it
    bad_csv = tmp_path / "index.csv"
    planted.assign(subject="S7").to_csv(bad_csv, index=False)
    with pytest.raises(TurnbenchError, match=r"index\.csv: \d+ sequences of the index"):
        write_h36m_estimates(bad_csv, [h36m.root], tmp_path / "no.npz", degrade=degrade_skeleton)
    assert not (tmp_path / "no.npz").exists()


def test_remap_estimates_carry_the_labelled_angle(tmp_path: Path) -> None:
    remap = write_remap_corpus(tmp_path / "remap", seed=2, n_pairs=2)
    assert remap.participants_path == tmp_path / "remap" / "participants.csv"
    assert sorted(p.suffix for p in (tmp_path / "remap" / "eaf").iterdir()) == [".eaf"] * 4
    labels = remap.truth.rename(columns={"turn_id": "clip_id"})
    out = write_remap_estimates(labels, tmp_path / "est.npz", degrade=degrade_skeleton, seed=2)
    arrays = dict(iter_arrays(out))
    assert sorted(arrays) == sorted(labels["clip_id"])
    errors = {}
    for row in labels.itertuples(index=False):
        clip = arrays[row.clip_id]
        # the clip is as long as the labelled interval, at 50 Hz
        assert abs(clip.shape[0] - (row.end_s - row.start_s) * 50.0) <= 1.0
        angle = turning_angle(to_z_up(clip.astype(float), "-y"), H36M17, method="net").angle_deg
        errors.setdefault(row.scenario, []).append(abs(angle - row.angle_deg))
    everything = np.concatenate(list(errors.values()))
    # the planted angle is the label +- a normal 8° (clipped at 20°), then degraded: most
    # clips land within a bin's half-width (22.5°) of their label
    assert np.mean(everything < 22.5) > 0.6
    assert np.median(everything) < 20.0


def test_remap_corpus_has_table_2s_mix_and_raters_who_disagree_like_people(tmp_path: Path) -> None:
    """The corpus ``make demo`` writes (default seed and size), checked against the issue."""
    remap = write_remap_corpus(tmp_path, seed=DEMO_SEED)
    truth = remap.truth
    # 12 PD-HC pairs, two sessions each; 58 turns per participant (1392, the paper's 1386)
    assert len(remap.paths) == 24
    assert remap.participants["cohort"].value_counts().to_dict() == {"PD": 12, "HC": 12}
    n = len(truth)
    assert n == 24 * 58
    # Table 2's mix: each share within four binomial standard deviations of the asked one
    # (sd = sqrt(p (1 - p) / 1392), at most 0.0134)
    for column, mix in (("angle_deg", ANGLE_MIX), ("scenario", SCENARIO_MIX)):
        share = truth[column].value_counts(normalize=True)
        for value, p in mix.items():
            key = float(value) if column == "angle_deg" else value
            assert abs(share.get(key, 0.0) - p) < 4 * np.sqrt(p * (1 - p) / n), (column, value)
    # The two raters, read from what was written into the files (synth_eaf's tests check the
    # files hold exactly that), linked by the turn they label
    written = remap.written
    a = written[written["annotator"] == remap.raters[0]].set_index("turn_id")
    b = written[written["annotator"] == remap.raters[1]].set_index("turn_id")
    both = a.merge(b, left_index=True, right_index=True, suffixes=("_a", "_b"))
    # about half of the turns labelled by both (the paper: about half)
    assert 0.4 < len(both) / n < 0.6
    # Boundaries: each rater's is the truth plus N(0, 0.15 s) clipped at +-0.3 s, so the two
    # differ by sd sqrt(2) * 0.15 = 0.212 s: median |difference| 0.6745 * 0.212 = 0.143 s
    # (a little less after clipping), P(|difference| > 0.2 s) = 2 (1 - Phi(0.943)) = 0.35,
    # never more than 0.6 s. "A few hundred milliseconds", and never identical.
    for edge in ("start_s", "end_s"):
        diff = (both[f"{edge}_b"] - both[f"{edge}_a"]).abs()
        assert 0.10 < diff.median() < 0.18, edge
        assert 0.25 < (diff > 0.2).mean() < 0.45, edge
        assert diff.max() <= 0.6 + 1e-9, edge
        assert (diff > 0).mean() > 0.9, edge
    # Angles: 2.5% of double-labelled turns planted as disagreements, one 45° step apart or
    # (a quarter of them) two; binomial sd at n ~ 680 is 0.6%
    differ = both["angle_deg_a"] != both["angle_deg_b"]
    assert 0.01 < differ.mean() < 0.05
    steps = set((both["angle_deg_a"] - both["angle_deg_b"]).abs()[differ])
    assert steps <= {45.0, 90.0}


def test_remap_estimates_keep_the_camera_and_worsen_free_living(tmp_path: Path) -> None:
    """One camera per participant's session; free-living gets 30 to 110 mm of depth error
    and 0.3 dropouts per second, scripted 20 to 80 mm and 0.05, clinical in between."""
    remap = write_remap_corpus(tmp_path / "remap", seed=4, n_pairs=1)
    labels = remap.truth.rename(columns={"turn_id": "clip_id"})
    calls: list[dict] = []

    def spy(positions, layout, **kw):
        calls.append(kw)
        return degrade_skeleton(positions, layout, **kw)

    write_remap_estimates(labels, tmp_path / "est.npz", degrade=spy, seed=4)
    expected = {
        (20.0, 80.0, 0.05),  # scripted
        (22.0, 90.0, 0.1),  # clinical
        (30.0, 110.0, 0.3),  # free-living
    }
    by_camera: dict[tuple, set] = {}
    for kw in calls:
        key = (kw["depth_sd_facing_mm"], kw["depth_sd_away_mm"], kw["dropout_rate_per_s"])
        by_camera.setdefault(tuple(kw["camera_position_mm"]), set()).add(key)
    # 1 pair x 2 sessions x 2 participants = 4 cameras, each seeing the three scenarios
    n_groups = labels.groupby(["session", "subject"]).ngroups
    assert n_groups == 4
    assert len(by_camera) == n_groups
    assert all(seen == expected for seen in by_camera.values())
