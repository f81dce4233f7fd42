"""The miner: its rule on hand-made yaw series, on synthetic mocap with planted turns (recall,
precision, angle and boundary errors against the generator's truth), the clip index contract,
and the turns CMU's descriptions name in real captures.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy import signal
from scipy.ndimage import uniform_filter1d

from turn_datasets import limits
from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import turning_angle
from turn_datasets.h36m.clip_index import CLIP_INDEX_DTYPES, clip_id_of, split_of
from turn_datasets.h36m.evaluation import KnownTurns, match_turns, score_sequences
from turn_datasets.h36m.miner import (
    MinerParams,
    _moving_mean,
    _period,
    _prepared_frontal,
    _zero_phase_lowpass,
    find_turns,
    heading_runs,
    knee_gait,
    measure_clip,
    mine,
    mine_heading,
    mine_heading_report,
    mine_sequence,
    mine_sequence_report,
    rejection_reasons,
)
from turn_datasets.mocap import readers
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, H36M32, Layout, MocapSequence
from turn_datasets.synthetic import mocap as sm

FPS = 50.0


def yaw_from_rates(pieces: list[tuple[float, float]], fps: float = FPS) -> np.ndarray:
    """Yaw (degrees) from (duration_s, rate_deg_s) pieces, starting at 0."""
    rate = np.concatenate([np.full(int(round(d * fps)), r) for d, r in pieces])
    return np.concatenate([[0.0], np.cumsum(rate) / fps])


# --- the rule on yaw series ---------------------------------------------------------------


def test_constant_yaw_has_no_turn() -> None:
    assert find_turns(np.full(500, 37.0), fps_hz=FPS).empty


def test_ramp_boundaries_worked_by_hand() -> None:
    # Still for 2 s, 90°/s for 1 s (yaw 1.8° a frame from frame 100 to 150), still for 2 s.
    # (Definition changed in issue 11: boundaries are fitted where the heading departs, no
    # longer where a 0.6 s Savitzky-Golay rate crosses 10°/s.) A bare yaw series shows no
    # stride, so the heading-rate window is no_sway_window_s = 30 frames and the yaw's moving
    # mean m spans 15 frames (u-7..u+7). Before the turn the departure is D(u) = m(u) -
    # m(u-30) = m(u): in the smoothed kink (u = 93..107) m(u) = 1.8/15 * J(J+1)/2 with
    # J = u - 93, then 1.8 (u - 100). D first reaches onset_deg = 6 at u = 103 (6.6; 5.4 at
    # 102) and 4 x 6 = 24 at u = 114 (25.2; 23.4 at 113). The line through sqrt(D) over
    # u = 103..113 meets zero at 91.6 (least squares on those eleven values), earlier than
    # the start allowed by the fit's span (103 - 11 = 92): the start is frame 92. A ramp's
    # sharp kink is not the smooth onset the fit assumes, hence the 8 frames before 100.
    # The series is symmetric about frame 125 (yaw(250 - k) = 90 - yaw(k)), so the turn's
    # last frame is 250 - 92 = 158 and the run ends at 159 (exclusive). The heading change:
    # 90 - 0 (means over a window on each side of constant yaw).
    yaw = yaw_from_rates([(2.0, 0.0), (1.0, 90.0), (2.0, 0.0)])
    got = find_turns(yaw, fps_hz=FPS)
    assert got[["start_frame", "end_frame", "sign"]].values.tolist() == [[92, 159, 1]]
    assert got.net_deg[0] == pytest.approx(90.0, abs=1e-9)
    assert got.hip_net_deg[0] == pytest.approx(yaw[158] - yaw[92], abs=1e-9)
    right = find_turns(-yaw, fps_hz=FPS)
    assert right[["start_frame", "end_frame", "sign"]].values.tolist() == [[92, 159, -1]]
    assert right.net_deg[0] == pytest.approx(-90.0, abs=1e-9)


def test_brief_sway_against_the_turn_does_not_split_it() -> None:
    # A slow left turn (30°/s) with 0.2 s of rotation back (-20°/s) in its middle.
    yaw = yaw_from_rates([(2, 0), (2, 30), (0.2, -20), (2, 30), (2, 0)])
    assert len(find_turns(yaw, fps_hz=FPS)) == 1
    # (Changed in issue 11.) The heading rate is now the change over a window (0.6 s without
    # a stride), which averages the 0.2 s back-rotation away: the turn stays whole even
    # without the merge of runs...
    assert len(find_turns(yaw, fps_hz=FPS, merge_gap_s=0.0)) == 1
    # ...while a real pause, standing still for 0.6 s, ends one turn and starts the next,
    # each measured as its own heading change (60° and 60°).
    paused = yaw_from_rates([(2, 0), (2, 30), (0.6, 0), (2, 30), (2, 0)])
    got = find_turns(paused, fps_hz=FPS)
    assert len(got) == 2
    np.testing.assert_allclose(got.net_deg, [60.0, 60.0], atol=0.5)


def test_back_to_back_opposite_turns_half_a_second_apart_stay_apart() -> None:
    yaw = yaw_from_rates([(2, 0), (1, 90), (0.5, 0), (1, -90), (2, 0)])
    got = find_turns(yaw, fps_hz=FPS)
    assert got["sign"].tolist() == [1, -1]
    # Each run covers its own turn (frames 100-150 and 175-225) and not the other.
    assert got["start_frame"][0] < 100 and 150 < got["end_frame"][0] <= 175
    assert 150 <= got["start_frame"][1] < 175 and got["end_frame"][1] > 225


def test_start_threshold_and_sway() -> None:
    # 15°/s for 6 s (90° in all) never reaches the 20°/s start threshold...
    slow = yaw_from_rates([(2, 0), (6, 15), (2, 0)])
    assert find_turns(slow, fps_hz=FPS).empty
    # ...but does with a lower one.
    assert len(find_turns(slow, fps_hz=FPS, start_speed_deg_s=12.0)) == 1
    # Pelvic sway of 6° peak to peak once per stride (0.77 to 1.0 Hz: raw rate up to
    # 2 pi * 1.0 * 3 = 18.8°/s), faded in and out over a stride, never starts a turn.
    t = np.arange(int(20 * FPS)) / FPS
    fade = np.clip(np.minimum(t, t[-1] - t) / 1.0, 0.0, 1.0)
    for f_hz in (0.77, 0.9, 1.0):
        assert find_turns(3.0 * fade * np.sin(2 * np.pi * f_hz * t), fps_hz=FPS).empty


def test_find_turns_refuses_nan_and_short_series_have_no_turn() -> None:
    with pytest.raises(TurnbenchError, match="NaN"):
        find_turns(np.array([0.0, np.nan, 1.0] * 20), fps_hz=FPS)
    assert find_turns(np.linspace(0, 90, 20), fps_hz=FPS).empty  # shorter than the window


@pytest.mark.parametrize(
    "bad",
    [
        {"min_turn_deg": 0},
        {"smooth_s": -1},
        {"max_gap_s": float("nan")},
        {"start_speed_deg_s": 5, "stop_speed_deg_s": 10},
    ],
)
def test_bad_parameters_are_refused(bad) -> None:
    with pytest.raises(TurnbenchError):
        MinerParams(**bad)


# --- whole sequences --------------------------------------------------------------------


def _seq(segments, **kw):
    return sm.generate_sequence(seed=kw.pop("seed", 7), segments=segments, **kw)


def test_clean_turn_angle_is_the_heading_change_and_hip_rotation_is_geometrys() -> None:
    # (Definition changed in issue 11: angle_deg is the heading change; the old quantity,
    # the net hip rotation between the boundaries, is hip_rotation_deg.)
    seq = _seq(
        [sm.Segment.walk(3, 1.2), sm.Segment.walking_turn(-135, 1.5, 1.2), sm.Segment.walk(3, 1.2)],
        noise_mm=0.0,
    )
    clips = mine_sequence(seq.positions, layout=H36M32, fps_hz=FPS, position_cutoff_hz=0.0)
    assert len(clips) == 1
    c = clips.iloc[0]
    # DESIGN.md: the net rotation of the hip vector from start_frame to end_frame - 1.
    ref = turning_angle(seq.positions[c.start_frame : c.end_frame], H36M32, method="net")
    assert c.hip_rotation_deg == pytest.approx(ref.angle_deg, abs=1e-9)
    assert c.direction == "right" and c.net_deg < 0
    planted = seq.planted.iloc[0]
    # the heading change asked for, to the wander's half a degree
    assert c.angle_deg == pytest.approx(135.0, abs=1.0)
    assert abs(c.start_frame - planted.start_frame) <= 0.2 * FPS
    assert abs(c.end_frame - planted.end_frame) <= 0.2 * FPS


def test_straight_walking_and_standing_give_no_clip() -> None:
    for seed, sway in ((1, 3.0), (2, 6.0), (3, 6.0)):
        walk = _seq(
            [
                sm.Segment.stand(1.0),
                sm.Segment.walk(40.0, 1.0 + 0.25 * seed),
                sm.Segment.stand(20.0),
            ],
            seed=seed,
            sway_deg=sway,
        )
        assert mine_sequence(walk.positions, layout=H36M32, fps_hz=FPS).empty


def test_a_few_strides_in_a_long_standstill_still_give_the_stride() -> None:
    # Issue 11: 30 s standing, 3 s walking, a walking turn, 3 s walking, 30 s standing, with
    # ±4° sway and 15 mm noise. The stride is read from the walking frames only, so the
    # heading before and after the turn is a mean over one stride and the sway cancels.
    # Measured over seeds 0-19: median error 0.65°, largest 1.88° (before reading the stride
    # from the walking frames only: 1.77° and 3.93°).
    errors = []
    for seed in range(10):
        rng = np.random.default_rng(seed)
        heading = float(rng.choice([-1.0, 1.0]) * rng.uniform(60.0, 150.0))
        segs = [
            sm.Segment.stand(30.0),
            sm.Segment.walk(3.0, 1.2),
            sm.Segment.walking_turn(heading, 2.0, 1.2),
            sm.Segment.walk(3.0, 1.2),
            sm.Segment.stand(30.0),
        ]
        seq = _seq(segs, seed=seed, sway_deg=8.0, noise_mm=15.0)
        clips = mine_sequence(seq.positions, layout=H36M32, fps_hz=FPS)
        assert len(clips) == 1, seed
        errors.append(clips.net_deg[0] - heading)
    assert np.median(np.abs(errors)) <= 1.0
    assert np.max(np.abs(errors)) <= 2.5


def test_units_and_the_17_joint_layout_do_not_change_the_clips() -> None:
    seq = _seq([sm.Segment.walk(2, 1.2), sm.Segment.pivot_turn(90, 1.2), sm.Segment.walk(2, 1.2)])
    mm = mine_sequence(seq.positions, layout=H36M32, fps_hz=FPS)
    metres = mine_sequence(seq.positions / 1000.0, layout=H36M32, fps_hz=FPS)
    j17 = mine_sequence(seq.positions[:, list(H36M17_FROM_32)], layout=H36M17, fps_hz=FPS)
    assert len(mm) == 1
    pd.testing.assert_frame_equal(mm, metres, atol=1e-9)
    pd.testing.assert_frame_equal(mm, j17)


def test_short_dropouts_are_bridged_long_ones_cut() -> None:
    segs = [sm.Segment.walk(3, 1.2), sm.Segment.pivot_turn(120, 2.0), sm.Segment.walk(4, 1.2)]
    base = _seq(segs)
    # 0.1 s lost in the middle of the turn (frames 200-205): bridged, the turn still found.
    short = _seq(segs, dropouts=[sm.Dropout(4.0, 0.1)])
    a = mine_sequence(base.positions, layout=H36M32, fps_hz=FPS)
    b = mine_sequence(short.positions, layout=H36M32, fps_hz=FPS)
    assert len(a) == len(b) == 1
    assert b.angle_deg[0] == pytest.approx(a.angle_deg[0], abs=2.0)
    # 1 s lost in the middle of the turn: no turn is measured across the hole.
    long = _seq(segs, dropouts=[sm.Dropout(3.6, 1.0)])
    c = mine_sequence(long.positions, layout=H36M32, fps_hz=FPS)
    hole = (180, 230)
    assert all(
        e <= hole[0] or s >= hole[1] for s, e in zip(c.start_frame, c.end_frame, strict=True)
    )
    # With a longer max_gap_s the same hole is bridged and the turn is one clip again.
    d = mine_sequence(long.positions, layout=H36M32, fps_hz=FPS, max_gap_s=1.5)
    assert len(d) == 1 and d.start_frame[0] < hole[0] and d.end_frame[0] > hole[1]


def test_knee_gait_by_hand() -> None:
    # hips 0.3 apart along y (left at +y): the body faces +x. The left knee 0.2 ahead, the
    # right 0.1 behind: 0.3 apart along the facing direction, one hip width; then the legs
    # swapped; then standing (knees level); then no hips (NaN).
    frontal = np.array([[0.0, 0.3], [0.0, 0.3], [0.0, 0.3], [np.nan, np.nan]])
    left = np.array([[0.2, 0.15], [-0.1, 0.15], [0.0, 0.15], [0.0, 0.15]])
    right = np.array([[-0.1, -0.15], [0.2, -0.15], [0.0, -0.15], [0.0, -0.15]])
    g = knee_gait(frontal, left, right)
    assert g[:3] == pytest.approx([1.0, -1.0, 0.0]) and np.isnan(g[3])


def test_mine_heading_is_mine_sequence_on_the_hips_it_stands_for() -> None:
    # The heading-series entry point (the detector's) on the hips' frontal vector finds the
    # same clips, bit for bit, as the skeleton entry point on hips at +-half of it, with the
    # same knees; dropouts (short and long) included.
    segs = [sm.Segment.walk(3, 1.2), sm.Segment.walking_turn(-135, 1.5, 1.2)]
    segs += [sm.Segment.walk(2, 1.2), sm.Segment.pivot_turn(120, 2.0), sm.Segment.walk(3, 1.2)]
    seq = _seq(segs, dropouts=[sm.Dropout(4.0, 0.1), sm.Dropout(6.0, 1.0)])
    p = seq.positions
    idx = [H36M32.index(j) for j in ("left_hip", "right_hip", "left_knee", "right_knee")]
    frontal = p[:, idx[0], :2] - p[:, idx[1], :2]
    four = Layout("four", 4, {"left_hip": 0, "right_hip": 1, "left_knee": 2, "right_knee": 3})
    arr = np.zeros((p.shape[0], 4, 3))
    arr[:, 0, :2], arr[:, 1, :2] = frontal / 2, -frontal / 2
    arr[:, 2:] = p[:, idx[2:]]
    expected = mine_sequence(arr, layout=four, fps_hz=FPS)
    gait = knee_gait(frontal, p[:, idx[2], :2], p[:, idx[3], :2])
    got = mine_heading(frontal, fps_hz=FPS, gait=gait)
    assert len(expected) >= 2
    pd.testing.assert_frame_equal(got, expected, check_exact=True)
    # the validity mask is a gap, as NaN is
    masked = mine_heading(
        np.nan_to_num(frontal), fps_hz=FPS, gait=gait, valid=np.isfinite(frontal).all(axis=1)
    )
    pd.testing.assert_frame_equal(masked, expected, check_exact=True)
    with pytest.raises(TurnbenchError, match="shape"):
        mine_heading(frontal[:, :1], fps_hz=FPS)


def test_heading_runs_are_the_reports_rows_without_the_tables() -> None:
    # A 90 deg pivot (a turn) and 14 s of circling at 40 deg/s (longer than the 10 s bound):
    # the arrays name both, in time order, with the reason of the one that is not a turn.
    yaw = yaw_from_rates([(2.0, 0.0), (1.0, 90.0), (3.0, 0.0), (14.0, 40.0), (2.0, 0.0)])
    frontal = 0.3 * np.column_stack((np.cos(np.radians(yaw)), np.sin(np.radians(yaw))))
    runs = heading_runs(frontal, fps_hz=FPS)
    assert runs.reason.tolist() == ["", "circling"]
    assert runs.net_deg[0] == pytest.approx(90.0, abs=3.0)
    assert runs.net_deg[1] == pytest.approx(14.0 * 40.0, abs=20.0)
    assert runs.start[0] == pytest.approx(2.0 * FPS, abs=0.3 * FPS)
    assert runs.start[1] == pytest.approx(6.0 * FPS, abs=0.3 * FPS)
    report = mine_heading_report(frontal, fps_hz=FPS)
    assert report.turns["start_frame"].tolist() == runs.start[:1].tolist()
    assert report.rejected["end_frame"].tolist() == runs.end[1:].tolist()
    assert report.turns["angle_deg"].tolist() == np.abs(runs.net_deg[:1]).tolist()


@pytest.mark.parametrize("cutoff_hz", [0.0, 6.0])
def test_a_flip_bridged_through_zero_is_not_a_turn_nor_an_error(cutoff_hz) -> None:
    # The vector flips across a one-frame gap: bridging puts that frame at exactly zero (the
    # mean of e and -e), a vector with no direction. The hip line does not flip, so the
    # runs are those of the same heading without the flip: one 90 deg pivot (this raised
    # "not finite" before, on 60 mm of white depth error).
    yaw = yaw_from_rates([(2.0, 0.0), (1.0, 90.0), (4.0, 0.0)])
    frontal = 0.3 * np.column_stack((np.cos(np.radians(yaw)), np.sin(np.radians(yaw))))
    flipped = frontal.copy()
    flip = int(5.0 * FPS)
    flipped[flip] = np.nan
    flipped[flip + 1 :] *= -1.0
    params = MinerParams(position_cutoff_hz=cutoff_hz)
    if cutoff_hz == 0.0:
        bridged = _prepared_frontal(flipped, None, FPS, params)[0][1]
        assert not np.any(bridged[flip])  # the case: a frame with no direction at all
    runs = heading_runs(flipped, fps_hz=FPS, params=params)
    plain = heading_runs(frontal, fps_hz=FPS, params=params)
    assert runs.reason.tolist() == plain.reason.tolist() == [""]
    assert runs.start.tolist() == plain.start.tolist()
    assert runs.end.tolist() == plain.end.tolist()
    assert runs.net_deg[0] == pytest.approx(90.0, abs=3.0)
    assert runs.net_deg[0] == pytest.approx(plain.net_deg[0], abs=1e-9)


def test_sequences_without_usable_hips_are_refused() -> None:
    p = _seq([sm.Segment.walk(2, 1.2)]).positions.copy()
    nan_hips = p.copy()
    nan_hips[:, [1, 6]] = np.nan
    with pytest.raises(TurnbenchError, match="usable hip"):
        mine_sequence(nan_hips, layout=H36M32, fps_hz=FPS)
    same = p.copy()
    same[:, 6] = same[:, 1]
    with pytest.raises(TurnbenchError, match="usable hip"):
        mine_sequence(same, layout=H36M32, fps_hz=FPS)
    with pytest.raises(TurnbenchError, match="shape"):
        mine_sequence(p[:, :17], layout=H36M32, fps_hz=FPS)


def test_every_clip_angle_is_turning_angle_on_its_frames() -> None:
    # (Issue 11: the hip rotation is the old angle; the heading change is measure_clip's with
    # the windows cut at the neighbouring clips, as the miner cuts them.) The miner reads all
    # angles off the pieces' unwrapped yaw at once; measure_clip runs geometry on each clip's
    # own frames, prepared the same way.
    n = 0
    for seed in range(3):
        rng = np.random.default_rng(seed)
        segs = sm.random_segments(rng)
        seq = sm.generate_sequence(seed=seed, segments=segs, dropouts=sm.random_dropouts(rng, segs))
        clips = mine_sequence(seq.positions, layout=H36M32, fps_hz=FPS)
        for i, c in enumerate(clips.itertuples(index=False)):
            ref = measure_clip(
                seq.positions,
                layout=H36M32,
                fps_hz=FPS,
                start_frame=c.start_frame,
                end_frame=c.end_frame,
                lower_frame=int(clips.end_frame[i - 1]) if i else 0,
                upper_frame=int(clips.start_frame[i + 1]) if i + 1 < len(clips) else None,
            )
            assert c.hip_rotation_deg == pytest.approx(ref.hip_rotation_deg, abs=1e-9)
            assert c.angle_deg == pytest.approx(ref.angle_deg, abs=1e-9)
            assert c.net_deg == pytest.approx(ref.net_deg, abs=1e-9)
            n += 1
    assert n >= 20


def test_measure_clip_refuses_bad_spans() -> None:
    seq = _seq(
        [sm.Segment.walk(2, 1.2), sm.Segment.pivot_turn(90, 1.2), sm.Segment.walk(2, 1.2)],
        dropouts=[sm.Dropout(1.0, 1.0)],
    )
    with pytest.raises(TurnbenchError, match="within"):
        measure_clip(seq.positions, layout=H36M32, fps_hz=FPS, start_frame=10, end_frame=10_000)
    with pytest.raises(TurnbenchError, match="cross a dropout"):
        measure_clip(seq.positions, layout=H36M32, fps_hz=FPS, start_frame=10, end_frame=150)


def test_fast_filters_equal_scipys() -> None:
    # The miner precomputes its filters; they must stay scipy's filtfilt and savgol_filter.
    rng = np.random.default_rng(0)
    b, a = signal.butter(2, 6.0, fs=FPS)
    for n in (4, 10, 500):
        x = rng.normal(size=(n, 4))
        want = signal.filtfilt(b, a, x, axis=0, padlen=min(9, n - 1))
        np.testing.assert_allclose(_zero_phase_lowpass(x, 6.0, FPS), want, atol=1e-12)
    y = np.cumsum(rng.normal(size=600))
    # (Issue 11: the Savitzky-Golay rate is gone; the moving mean that replaced it is checked
    # against a plain loop over its shrinking windows.)
    for window in (1, 2, 15, 31):
        want = [y[max(i - window // 2, 0) : i - window // 2 + window].mean() for i in range(600)]
        np.testing.assert_allclose(_moving_mean(y, window), want, atol=1e-9)
        # inside the series (full windows) it is scipy's uniform filter
        inner = slice(window // 2, 600 - window // 2)
        np.testing.assert_allclose(
            _moving_mean(y, window)[inner], uniform_filter1d(y, window)[inner], atol=1e-9
        )


# --- measured on a synthetic corpus -----------------------------------------------------


def corpus_scores(seeds) -> dict:
    """Mine a synthetic corpus and score it against the planted turns (the library's
    :func:`turn_datasets.h36m.evaluation.score_sequences`; see the tests)."""

    def cases():
        for seed in seeds:
            rng = np.random.default_rng(seed)
            segs = sm.random_segments(rng)
            seq = sm.generate_sequence(
                seed=seed,
                segments=segs,
                sway_deg=float(rng.uniform(3.0, 6.0)),
                noise_mm=10.0,
                dropouts=sm.random_dropouts(rng, segs),
            )
            yield KnownTurns(seed, seq.positions, H36M32, seq.fps, seq.planted)

    return score_sequences(cases())


@pytest.fixture(scope="module")
def corpus() -> dict:
    return corpus_scores(range(60))


def test_corpus_covers_every_kind_of_planted_turn(corpus) -> None:
    t = corpus["table"]
    assert corpus["n_planted"] >= 350
    for col in ("kind", "left", "fast", "back_to_back"):
        assert t[col].nunique() == 2, col
    assert t.back_to_back.sum() >= 30
    assert t.planted_deg.max() > 300


def test_recall_and_precision_of_turns_of_60_degrees_or_more(corpus) -> None:
    assert corpus["recall"] >= 0.98
    assert corpus["precision"] >= 0.98
    # and in every kind of turn, not only on average
    t = corpus["table"]
    for col in ("kind", "left", "fast", "back_to_back"):
        for value, group in t.groupby(col):
            assert group.found.mean() >= 0.98, (col, value)


def test_no_clip_where_nothing_was_planted(corpus) -> None:
    # Every mined clip overlaps a planted turn: none on straight walking or standing.
    assert corpus["false_clips"] == 0


def test_median_angle_and_boundary_errors(corpus) -> None:
    assert corpus["median_angle_error_deg"] <= 3.0
    assert corpus["median_boundary_error_s"] <= 0.2


# --- the clip index -----------------------------------------------------------------------


def _mocap(seed, segments, subject, action, subaction="", source="mem") -> MocapSequence:
    seq = sm.generate_sequence(seed=seed, segments=segments)
    return seq.to_mocap(subject=subject, action=action, subaction=subaction, source=source)


TURNING = [sm.Segment.walk(2, 1.2), sm.Segment.pivot_turn(100, 1.2), sm.Segment.walk(2, 1.2)]


def test_clip_index_columns_ids_split_and_derived_values() -> None:
    seqs = [
        _mocap(1, TURNING, "S11", "Walking", "1", "a.npz"),
        _mocap(2, TURNING, "S9", "WalkDog", "", "a.npz"),
        _mocap(3, TURNING, "S1", "Walking", "1", "b.cdf"),
        _mocap(4, TURNING, "S1", "Walking", "", "c.cdf"),
        _mocap(5, TURNING, "cmu", "69_25", "", "69_25.bvh"),
    ]
    index = mine(seqs)
    assert list(index.columns) == list(CLIP_INDEX_DTYPES)
    assert {c: str(index[c].dtype) for c in index.columns} == dict(CLIP_INDEX_DTYPES)
    # Sorted by subject (S1 < S9 < S11 as numbers), then action, subaction, start frame.
    assert index["subject"].tolist() == ["S1", "S1", "S9", "S11", "cmu"]
    assert index["subaction"].tolist()[:2] == ["", "1"]
    assert index["split"].tolist() == ["train", "train", "test", "test", ""]
    for r in index.itertuples(index=False):
        label = r.action + ("-" + r.subaction if r.subaction else "")
        assert r.clip_id == f"{r.subject}_{label}_{r.start_frame}-{r.end_frame}"
        assert r.n_frames == r.end_frame - r.start_frame
        assert r.duration_s == pytest.approx(r.n_frames / 50.0)
        assert r.start_s == pytest.approx(r.start_frame / 50.0)
        assert r.speed_deg_s == pytest.approx(r.angle_deg / r.duration_s)
        assert r.bin_deg == 90  # 100° planted: nearest multiple of 45 is 90
        assert r.direction == "left"
    assert index["clip_id"].is_unique
    assert index["source"].tolist()[-1] == "69_25.bvh"


def test_clip_id_and_split_helpers() -> None:
    assert clip_id_of("S1", "Walking", "1", 120, 260) == "S1_Walking-1_120-260"
    assert clip_id_of("S1", "Walking Dog", "", 0, 50) == "S1_Walking-Dog_0-50"
    assert [split_of(s) for s in ("S1", "S5", "S6", "S7", "S8", "S9", "S11", "S2", "x")] == [
        "train",
        "train",
        "train",
        "train",
        "train",
        "test",
        "test",
        "",
        "",
    ]


def test_the_same_sequence_twice_is_refused_naming_both_sources() -> None:
    seqs = [
        _mocap(1, TURNING, "S1", "Walking", "", "copy1.cdf"),
        _mocap(1, TURNING, "S1", "Walking", "", "copy2.h5"),
    ]
    with pytest.raises(TurnbenchError, match="copy1.cdf and copy2.h5"):
        mine(seqs)


def test_a_bad_sequence_names_its_file_and_sequence() -> None:
    seq = _mocap(1, TURNING, "S1", "Walking", "1", "S1/Walking 1.cdf")
    seq.positions[:, [1, 6]] = np.nan
    with pytest.raises(TurnbenchError) as err:
        mine([seq])
    assert str(err.value).startswith("S1/Walking 1.cdf, S1/Walking 1: ")


# --- real captures --------------------------------------------------------------------


CMU_TURNS = {  # CMU's description -> the one turn it names
    "69_20.bvh": "right",  # walk forward 90 degree right turn
    "69_25.bvh": "left",  # walk forward 90 degree left turn
    "16_18.bvh": "left",  # walk, 90-degree left turn
    "16_21.bvh": None,  # walk
    "69_01.bvh": None,  # walk forward
}


def test_cmu_turns_are_found_with_their_direction(cmu_dir) -> None:
    # Measured: 69_20 right 101.5°, 69_25 left 104.5°, 16_18 left 95.6° (frame 0, the
    # conversion's T-pose, skipped); no clip in the two straight walks.
    for name, direction in CMU_TURNS.items():
        (seq,) = readers.read_source(cmu_dir / name, skip_first_frame=True)
        clips = mine_sequence(seq.positions, layout=seq.layout, fps_hz=seq.fps)
        if direction is None:
            assert clips.empty, name
            continue
        assert len(clips) == 1, name
        assert clips.direction[0] == direction, name
        # a described 90° turn: the hips turn by more, as walking turns overshoot a bit
        assert 85.0 <= clips.angle_deg[0] <= 115.0, (name, clips.angle_deg[0])
        # DESIGN.md's hip_rotation_deg (the angle before issue 11): geometry's net rotation of
        # the raw (unfiltered) hips between the clip's boundaries; the miner's 6 Hz low-pass
        # only removes marker noise
        s, e = clips.start_frame[0], clips.end_frame[0]
        raw = turning_angle(seq.positions[s:e], seq.layout, method="net")
        assert clips.hip_rotation_deg[0] == pytest.approx(raw.angle_deg, abs=1.0), name


def test_match_turns_maximises_shared_frames_of_same_direction_pairs():
    # Worked by hand. P0 [0, 100) and P1 [100, 200) turn left. M0 [20, 170) shares 80 frames
    # with P0 and 70 with P1; M1 [25, 100) shares 75 with P0 only. Taking the largest overlap
    # first (P0-M0) leaves M1 alone: 80 frames; the best matching is P0-M1 and P1-M0, 145.
    # P2 turns right and M2 left over the same frames: no pair. M3 overlaps nothing.
    planted = pd.DataFrame(
        {
            "start_frame": [0, 100, 300],
            "end_frame": [100, 200, 400],
            "heading_deg": [90.0, 90.0, -90.0],
        }
    )
    mined = pd.DataFrame(
        {
            "start_frame": [20, 25, 300, 500],
            "end_frame": [170, 100, 400, 600],
            "net_deg": [85.0, 80.0, 90.0, 90.0],
        }
    )
    assert match_turns(planted, mined) == [(0, 1), (1, 0)]
    assert match_turns(planted.iloc[:0], mined) == []


# --- continuous turning: pauses, hesitations, circling and impossible speeds ---------------


def _sine_turn(angle_deg: float, duration_s: float, fps: float = FPS) -> np.ndarray:
    """Per-frame yaw increments of a turn whose rate rises and falls as a half sine."""
    n = int(round(duration_s * fps))
    rate = np.sin(np.pi * (np.arange(n) + 0.5) / n)
    return rate / rate.sum() * angle_deg


def _yaw(*parts: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.concatenate(parts))])


def _still(seconds: float, fps: float = FPS) -> np.ndarray:
    return np.zeros(int(round(seconds * fps)))


def test_turns_in_place_with_a_pause_between_them_are_two_turns() -> None:
    # Two 90° turns in place (1.5 s each) with a 0.3 s standstill between them: the stride
    # rate (0.6 s) never drops below the stop threshold (10 °/s) across the pause, so
    # without the split they are one 180° run; the 0.4 s rate falls to 0 there.
    y = _yaw(_still(2), _sine_turn(90, 1.5), _still(0.3), _sine_turn(90, 1.5), _still(2))
    got = find_turns(y, fps_hz=FPS)
    assert len(got) == 2
    np.testing.assert_allclose(got.net_deg, [90.0, 90.0], atol=1.0)
    # the pause lies between them: the first ends before frame 100 + 75 + 15, the second
    # starts after frame 100 + 75
    assert got.end_frame[0] <= 190 and got.start_frame[1] >= 175
    # with the pause threshold at 0 nothing is split: one 180° turn
    merged = find_turns(y, fps_hz=FPS, pause_speed_deg_s=0.0)
    assert len(merged) == 1 and merged.net_deg[0] == pytest.approx(180.0, abs=1.0)


def test_a_hesitation_inside_a_turn_does_not_split_it() -> None:
    # A 180° turn over 3 s whose rate sags to 30% of its peak halfway, without stopping
    # (as 69_17's first turn does): one turn (Shah et al. count hesitations inside a turn).
    n = int(3 * FPS)
    u = (np.arange(n) + 0.5) / n
    rate = np.sin(np.pi * u) * (1 - 0.7 * np.exp(-(((u - 0.5) / 0.08) ** 2)))
    y = _yaw(_still(2), rate / rate.sum() * 180.0, _still(2))
    got = find_turns(y, fps_hz=FPS)
    assert len(got) == 1 and got.net_deg[0] == pytest.approx(180.0, abs=1.0)


def test_a_pause_whose_sides_turn_less_than_a_clip_does_not_split() -> None:
    # 30° then a pause then 120°: the first part is below min_turn_deg (45°), so the pause
    # does not make two clips of it (and 30° alone would be none).
    y = _yaw(_still(2), _sine_turn(30, 0.8), _still(0.3), _sine_turn(120, 1.8), _still(2))
    got = find_turns(y, fps_hz=FPS)
    assert len(got) == 1 and got.net_deg[0] == pytest.approx(150.0, abs=1.5)


def _hips_from_yaw(yaw_deg: np.ndarray) -> tuple[np.ndarray, Layout]:
    """Left and right hip, 0.13 m either side of the origin, facing yaw - 90°."""
    rad = np.radians(yaw_deg)
    half = 0.13 * np.stack([np.cos(rad), np.sin(rad), np.zeros_like(rad)], axis=1)
    return np.stack([half, -half], axis=1), Layout("hips", 2, {"left_hip": 0, "right_hip": 1})


def test_walking_round_a_loop_for_half_a_minute_is_circling_not_a_turn() -> None:
    # 40 °/s for 30 s (1200°) with brief dips to 25 °/s every 4 s, as Human3.6M's walks
    # round their loop do: no pause, so one run of 30 s; past max_turn_s (10 s) it is a
    # circling episode, reported apart, never a 1200° turn.
    rate = np.full(int(30 * FPS), 40.0)
    for k in range(1, 8):
        rate[int(4 * k * FPS) : int((4 * k + 0.4) * FPS)] = 25.0
    y = _yaw(_still(2), rate / FPS, _still(2))
    positions, layout = _hips_from_yaw(y)
    got = mine_sequence_report(positions, layout=layout, fps_hz=FPS)
    assert got.turns.empty
    assert len(got.rejected) == 1 and got.rejected.reason[0] == "circling"
    expected = 40.0 * 30 - 7 * 0.4 * 15.0  # 1200° less the dips' 15 °/s for 0.4 s each
    assert got.rejected.angle_deg[0] == pytest.approx(expected, abs=2.0)
    # the same loop lasting 8 s (320°) is one turn: within the bound
    short = _yaw(_still(2), np.full(int(8 * FPS), 40.0 / FPS), _still(2))
    kept = mine_sequence(_hips_from_yaw(short)[0], layout=layout, fps_hz=FPS)
    assert len(kept) == 1 and kept.angle_deg[0] == pytest.approx(320.0, abs=2.0)


def test_a_turn_faster_than_a_person_turns_is_rejected_as_too_fast() -> None:
    # 180° in 0.2 s (900 °/s on average; the boundary fit smooths it to about 0.5 s, still
    # far above the bound) is a flip of the hip line, not a turn; the same
    # 180° over 1.2 s (150 °/s) is a turn.
    fast = _yaw(_still(2), _sine_turn(180, 0.2), _still(2))
    positions, layout = _hips_from_yaw(fast)
    got = mine_sequence_report(positions, layout=layout, fps_hz=FPS)
    assert got.turns.empty and list(got.rejected.reason) == ["too_fast"]
    d = (got.rejected.end_frame[0] - got.rejected.start_frame[0]) / FPS
    assert got.rejected.angle_deg[0] / d > limits.MAX_TURN_MEAN_SPEED_DEG_S
    slow = _yaw(_still(2), _sine_turn(180, 1.2), _still(2))
    kept = mine_sequence(_hips_from_yaw(slow)[0], layout=layout, fps_hz=FPS)
    assert len(kept) == 1 and kept.angle_deg[0] == pytest.approx(180.0, abs=1.0)


def test_rejection_reasons_by_hand() -> None:
    p = MinerParams()
    # in time order, each 2 s or more after the one before (turns far apart are judged alone)
    reasons = rejection_reasons(
        np.array([0, 150, 800, 1000]),
        np.array([50, 150 + 50 * 11, 810, 1000 + 50 * 11]),
        np.array([90.0, -500.0, 90.0, 4000.0]),
        50.0,
        p,
    )
    # 1 s at 90 °/s; 11 s; 0.2 s at 450 °/s; 11 s at 364 °/s (circling first)
    assert reasons.tolist() == ["", "circling", "too_fast", "circling"]


def test_a_circle_halted_for_a_moment_is_one_circling_episode() -> None:
    # At 50 fps: 6 s left, 0.4 s apart another 5 s left (11.4 s of one episode: circling);
    # then 3.2 s later (more than circling_gap_s) a 3 s turn left, judged alone; then at once
    # a 6 s turn right and 0.2 s after it 5 s more right (11.2 s: circling again); the
    # right turns do not join the 3 s left turn before them.
    p = MinerParams()
    start = np.array([0, 320, 730, 880, 1190])
    end = np.array([300, 570, 880, 1180, 1440])
    net = np.array([240.0, 200.0, 120.0, -240.0, -200.0])
    assert rejection_reasons(start, end, net, 50.0, p).tolist() == [
        "circling",
        "circling",
        "",
        "circling",
        "circling",
    ]
    # in any order of the rows; and with circling_gap_s 0 every turn is judged alone
    shuffled = np.array([4, 2, 0, 3, 1])
    got = rejection_reasons(start[shuffled], end[shuffled], net[shuffled], 50.0, p)
    assert got.tolist() == ["circling", "", "circling", "circling", "circling"]
    alone = rejection_reasons(start, end, net, 50.0, replace(p, circling_gap_s=0.0))
    assert alone.tolist() == ["", "", "", "", ""]


def test_two_walking_turns_in_quick_succession_are_two_turns() -> None:
    # Walking (a 0.9 Hz pelvic sway of ±4°, from which the stride is read), two 90° turns
    # of 1.5 s each 0.4 s apart: the stride rate (over about 1.1 s) never falls near a
    # standstill between them, but dips by far more than walking_dip_deg_s (25 °/s) below
    # both peaks (each about 90° / 1.5 s x pi / 2 = 94 °/s, smoothed to some 60 °/s).
    inc = np.concatenate(
        [_still(6), _sine_turn(90, 1.5), _still(0.4), _sine_turn(90, 1.5), _still(6)]
    )
    yaw = np.concatenate([[0.0], np.cumsum(inc)])
    yaw = yaw + 4.0 * np.sin(2 * np.pi * 0.9 * np.arange(yaw.size) / FPS)
    got = find_turns(yaw, fps_hz=FPS)
    assert len(got) == 2
    np.testing.assert_allclose(got.net_deg, [90.0, 90.0], atol=5.0)
    # the first ends and the second starts in the 20 frames between the planted turns
    # (frames 375-395), give or take a fifth of a second
    assert 365 <= got.end_frame[0] <= 405 and 365 <= got.start_frame[1] <= 405
    # without the walking split: one 180° turn
    merged = find_turns(yaw, fps_hz=FPS, walking_dip_deg_s=1e4)
    assert len(merged) == 1 and merged.net_deg[0] == pytest.approx(180.0, abs=2.0)


def test_a_stride_lag_with_exactly_the_least_believed_pairs_is_found() -> None:
    """A lag is believed from ``hi / 2`` valid pairs on: 57 valid frames of 96 have
    57 - 33 = 24 pairs at lag 33, exactly 48 / 2. A sine of period 33 correlates best
    there among the lags with enough pairs (24 to 33); its correlation is the mean product
    over the 24 pairs over the mean square, and at half the lag (16) it is negative. The FFT
    counts those pairs 3.6e-15 short of 24 (NumPy 1.26 and 2.x alike here; on the demo's
    streams the two versions' FFTs erred in opposite directions, and a stride of 28 or 29
    frames, 26 or 27, decided which turns were found); the counts are whole numbers."""
    t = np.arange(96)
    valid = t < 57
    x = np.sin(2 * np.pi * t / 33)

    def mean_product(lag: int) -> float:
        both = valid[: t.size - lag] & valid[lag:]
        return float(np.mean((x[: t.size - lag] * x[lag:])[both]))

    lag, corr, half = _period(x, valid, 24, 48)
    assert lag == 33
    assert corr == pytest.approx(mean_product(33) / mean_product(0), rel=1e-12)
    assert half == pytest.approx(mean_product(16) / mean_product(0), rel=1e-12)
    assert half < 0
