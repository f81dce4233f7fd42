"""The synthetic mocap generator: body geometry, gait, turns, noise, dropouts, determinism.

Every expected value is worked out from the specification of the motion (speeds, bone
lengths, turn angles) or measured with a second tool (scipy's periodogram, a hand-written
atan2 of the walking direction), never copied from the generator's output.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, signal

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import frame_yaw_deg
from turn_datasets.skeleton import H36M32
from turn_datasets.synthetic import mocap as sm

FPS = 50.0
LH, RH = H36M32.index("left_hip"), H36M32.index("right_hip")
LS, RS = H36M32.index("left_shoulder"), H36M32.index("right_shoulder")
LK = H36M32.index("left_knee")


def _clean(segments, **kw):
    kw.setdefault("noise_mm", 0.0)
    kw.setdefault("wander_deg", 0.0)
    return sm.generate_sequence(seed=kw.pop("seed", 3), segments=segments, **kw)


def _walk_direction_deg(xy: np.ndarray) -> float:
    """Direction of travel (degrees from +x) of a pelvis path, by a hand atan2 of the chord."""
    d = xy[-1] - xy[0]
    return float(np.degrees(np.arctan2(d[1], d[0])))


def test_same_seed_same_bytes_other_seed_differs() -> None:
    segs = sm.random_segments(np.random.default_rng(5))
    a = sm.generate_sequence(seed=11, segments=segs)
    b = sm.generate_sequence(seed=11, segments=segs)
    c = sm.generate_sequence(seed=12, segments=segs)
    assert a.positions.tobytes() == b.positions.tobytes()
    assert a.planted.equals(b.planted)
    assert not np.array_equal(a.positions, c.positions)


def test_shape_units_and_bone_lengths() -> None:
    seq = _clean([sm.Segment.stand(1.0), sm.Segment.walk(3.0, 1.2)])
    p = seq.positions
    assert p.shape == (int(4.0 * FPS), 32, 3)
    # Hip half-width 132 mm -> hips 264 mm apart; shoulders 2 x 180 mm; thigh 442 mm.
    np.testing.assert_allclose(np.linalg.norm(p[:, LH] - p[:, RH], axis=1), 264.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(p[:, LS] - p[:, RS], axis=1), 360.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(p[:, LK] - p[:, LH], axis=1), 442.0, atol=1e-9)
    # z up, millimetres: the head is about 1.7 m above the ground, feet near it.
    assert 1600 < np.median(p[:, H36M32.index("head"), 2]) < 1800
    assert np.all(p[:, H36M32.index("left_foot"), 2] < 400)


def test_walking_speed_and_direction_follow_the_heading() -> None:
    seq = _clean([sm.Segment.walk(6.0, 1.3)], start_heading_deg=30.0, sway_deg=4.0)
    pelvis = seq.positions[:, 0, :2]
    # Middle 4 s, away from the speed ramp at the start: 1.3 m/s = 1300 mm/s.
    a, b = int(1.0 * FPS), int(5.0 * FPS)
    dist_mm = np.linalg.norm(pelvis[b] - pelvis[a])
    assert dist_mm / ((b - a) / FPS) == pytest.approx(1300.0, rel=0.02)
    assert _walk_direction_deg(pelvis[a:b]) == pytest.approx(30.0, abs=1.0)
    # The left-minus-right hip vector points 90° left of the walking direction.
    yaw = frame_yaw_deg(seq.positions, H36M32)
    assert np.mean(yaw[a:b]) == pytest.approx(30.0 + 90.0, abs=0.5)


@pytest.mark.parametrize("sway_deg", [3.0, 6.0])
def test_pelvic_sway_amplitude_and_frequency(sway_deg: float) -> None:
    speed = 1.25
    seq = _clean([sm.Segment.walk(20.0, speed)], sway_deg=sway_deg, start_heading_deg=0.0)
    yaw = frame_yaw_deg(seq.positions, H36M32)[int(1 * FPS) :]
    # Peak to peak of the hip yaw on a straight path is the sway asked for.
    assert np.ptp(yaw) == pytest.approx(sway_deg, abs=0.05)
    # Once per stride: step length 0.45 + 0.2 v = 0.70 m, stride 1.40 m at 1.25 m/s
    # -> 0.893 strides per second.
    freqs, power = signal.periodogram(yaw - yaw.mean(), fs=FPS, nfft=1 << 14)
    assert freqs[np.argmax(power)] == pytest.approx(1.25 / 1.40, abs=0.01)


def _stride_amplitude_deg(positions: np.ndarray, freq_hz: float) -> float:
    """Amplitude of the hip vector's yaw at ``freq_hz``, by a least-squares sinusoid.

    The yaw is a hand-written atan2 of left hip minus right hip on the ground plane (not
    geometry's), fitted with a constant + sin + cos at the stride frequency by numpy's lstsq.
    """
    d = positions[:, LH, :2] - positions[:, RH, :2]
    yaw = np.degrees(np.unwrap(np.arctan2(d[:, 1], d[:, 0])))
    t = np.arange(yaw.shape[0]) / FPS
    design = np.column_stack(
        [np.ones_like(t), np.sin(2 * np.pi * freq_hz * t), np.cos(2 * np.pi * freq_hz * t)]
    )
    (_, a, b), *_ = np.linalg.lstsq(design, yaw, rcond=None)
    return float(np.hypot(a, b))


@pytest.mark.parametrize("sway_deg", [3.0, 4.5, 6.0])
def test_sway_survives_the_default_noise_and_wander(sway_deg: float) -> None:
    # As the miner's corpus is generated: 10 mm joint noise and the postural wander on.
    # Noise of 10 mm on each coordinate of two hips 264 mm apart moves the yaw by about
    # sqrt(2) * 10 / 264 rad = 3.1 deg per frame, yet over 29 s (1450 frames) the fitted
    # amplitude is off by only about 3.1 * sqrt(2 / 1450) = 0.12 deg: half the peak to peak
    # asked for must come out within 0.4 deg.
    seq = sm.generate_sequence(
        seed=21, segments=[sm.Segment.walk(30.0, 1.25)], sway_deg=sway_deg, start_heading_deg=0.0
    )
    stride_hz = 1.25 / 1.40  # step 0.45 + 0.2 * 1.25 = 0.70 m, two steps a stride
    amplitude = _stride_amplitude_deg(seq.positions[int(1 * FPS) :], stride_hz)
    assert amplitude == pytest.approx(sway_deg / 2, abs=0.4)
    # Standing, the same fit finds no rotation at that frequency beyond the noise.
    still = sm.generate_sequence(seed=21, segments=[sm.Segment.stand(30.0)], sway_deg=sway_deg)
    assert _stride_amplitude_deg(still.positions, stride_hz) < 0.4


def test_standing_has_no_sway_and_does_not_move() -> None:
    seq = _clean([sm.Segment.stand(4.0)], sway_deg=6.0)
    yaw = frame_yaw_deg(seq.positions, H36M32)
    assert np.ptp(yaw) < 1e-9
    assert np.ptp(seq.positions[:, 0, 0]) < 1e-9


@pytest.mark.parametrize(
    ("segment", "expected_deg"),
    [
        (sm.Segment.pivot_turn(90.0, 1.5), 90.0),
        (sm.Segment.pivot_turn(-180.0, 1.0), -180.0),
        (sm.Segment.pivot_turn(360.0, 2.5), 360.0),
        (sm.Segment.walking_turn(-60.0, 1.2, 1.1), -60.0),
    ],
)
def test_turns_rotate_the_hips_by_the_planted_angle(segment, expected_deg) -> None:
    segs = [sm.Segment.stand(1.0), segment, sm.Segment.stand(1.0)]
    seq = _clean(segs, sway_deg=0.0)
    row = seq.planted.iloc[0]
    assert (row.start_frame, row.end_frame) == (50, 50 + int(round(segment.duration_s * FPS)))
    yaw = frame_yaw_deg(seq.positions, H36M32)
    # Geometry's unwrapped yaw of the hip vector turns by exactly the heading change; positive
    # is counter-clockwise from above (left), as DESIGN.md says.
    assert yaw[row.end_frame - 1] - yaw[row.start_frame] == pytest.approx(expected_deg, abs=1e-6)
    assert row.angle_deg == pytest.approx(expected_deg, abs=1e-6)
    assert row.heading_deg == expected_deg
    # Nothing turns outside the turn.
    assert np.ptp(yaw[: row.start_frame + 1]) < 1e-9
    assert np.ptp(yaw[row.end_frame - 1 :]) < 1e-9


def test_left_turn_is_counter_clockwise_seen_from_above() -> None:
    segs = [
        sm.Segment.walk(3.0, 1.2),
        sm.Segment.walking_turn(90.0, 1.5, 1.2),
        sm.Segment.walk(3.0, 1.2),
    ]
    seq = _clean(segs, start_heading_deg=0.0)
    pelvis = seq.positions[:, 0, :2]
    before = pelvis[int(1.0 * FPS) : int(2.5 * FPS)]
    after = pelvis[-int(2.5 * FPS) : -int(1.0 * FPS)]
    # Walking +x before, +y after (a quarter turn counter-clockwise).
    assert _walk_direction_deg(before) == pytest.approx(0.0, abs=1.5)
    assert _walk_direction_deg(after) == pytest.approx(90.0, abs=1.5)


def test_pivot_turn_stays_on_the_spot_walking_turn_follows_a_curve() -> None:
    pivot = _clean(
        [sm.Segment.stand(1.0), sm.Segment.pivot_turn(180.0, 1.5), sm.Segment.stand(1.0)]
    )
    row = pivot.planted.iloc[0]
    path = pivot.positions[row.start_frame : row.end_frame, 0, :2]
    assert np.max(np.linalg.norm(path - path[0], axis=1)) < 50.0  # lateral pelvic shift only
    walking = _clean(
        [
            sm.Segment.walk(2.0, 1.2),
            sm.Segment.walking_turn(180.0, 3.0, 1.2),
            sm.Segment.walk(2.0, 1.2),
        ],
        start_heading_deg=0.0,
    )
    row = walking.planted.iloc[0]
    path = walking.positions[row.start_frame : row.end_frame, 0, :2]
    # 3 s at 1.2 m/s is 3.6 m of path. The heading follows the sinusoidal-rate profile
    # h(t) = 180° (1 - cos(pi t / 3)) / 2, so the chord is |integral of 1.2 m/s (cos h, sin h)|,
    # integrated here with scipy's quad.
    length = np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))
    assert length == pytest.approx(3600.0, rel=0.03)

    def heading(t: float) -> float:
        return np.pi * (1 - np.cos(np.pi * t / 3.0)) / 2

    cx = integrate.quad(lambda t: 1200.0 * np.cos(heading(t)), 0, 3.0)[0]
    cy = integrate.quad(lambda t: 1200.0 * np.sin(heading(t)), 0, 3.0)[0]
    assert np.linalg.norm(path[-1] - path[0]) == pytest.approx(np.hypot(cx, cy), rel=0.03)
    # A left half turn: the path bends to the left of the start direction (+x), so +y.
    assert path[-1, 1] - path[0, 1] > 0.9 * np.hypot(cx, cy)


def test_noise_is_ten_mm_per_coordinate() -> None:
    segs = [sm.Segment.walk(20.0, 1.2)]
    clean = sm.generate_sequence(seed=4, segments=segs, noise_mm=0.0)
    noisy = sm.generate_sequence(seed=4, segments=segs, noise_mm=10.0)
    diff = noisy.positions - clean.positions
    assert diff.std() == pytest.approx(10.0, rel=0.02)
    assert abs(diff.mean()) < 0.1
    # Independent per joint: left and right hip noise uncorrelated.
    # |r| of independent samples exceeds 4 / sqrt(n) with probability about 6e-5.
    r = np.corrcoef(diff[:, LH, 0], diff[:, RH, 0])[0, 1]
    assert abs(r) < 4 / np.sqrt(diff.shape[0])


def test_dropouts_set_whole_frames_to_nan() -> None:
    seq = sm.generate_sequence(
        seed=1,
        segments=[sm.Segment.walk(5.0, 1.2)],
        dropouts=[sm.Dropout(1.0, 0.1), sm.Dropout(3.0, 1.0)],
    )
    nan_frames = np.flatnonzero(np.isnan(seq.positions).any(axis=(1, 2)))
    expected = np.r_[50:55, 150:200]  # 1.0 s + 5 frames, 3.0 s + 50 frames, at 50 Hz
    np.testing.assert_array_equal(nan_frames, expected)
    assert np.isnan(seq.positions[nan_frames]).all()
    assert seq.dropouts.values.tolist() == [[50, 55], [150, 200]]


def test_random_segments_mix() -> None:
    segs = [s for seed in range(30) for s in sm.random_segments(np.random.default_rng(seed))]
    turns = [s for s in segs if s.is_turn]
    mags = np.array([abs(s.heading_deg) for s in turns])
    mean_speed = mags / np.array([s.duration_s for s in turns])
    assert mags.min() >= 50.0 and mags.max() <= 360.0
    assert mags.max() > 300.0 and mags.min() < 70.0
    assert {s.kind for s in turns} == {"pivot_turn", "walking_turn"}
    assert any(s.heading_deg > 0 for s in turns) and any(s.heading_deg < 0 for s in turns)
    assert (mean_speed < 90.0).sum() > 20 and (mean_speed > 120.0).sum() > 20
    walk_speeds = [s.speed_m_s for s in segs if s.kind in ("walk", "walking_turn")]
    assert 1.0 <= min(walk_speeds) and max(walk_speeds) <= 1.5
    assert any(s.kind == "stand" and s.duration_s >= 1.0 for s in segs)
    # Back-to-back opposite turns, 0.5 s apart.
    pairs = [
        (a, b, c)
        for a, b, c in zip(segs, segs[1:], segs[2:], strict=False)
        if a.is_turn and c.is_turn and not b.is_turn and b.duration_s == 0.5
    ]
    assert len(pairs) >= 10
    assert all(np.sign(a.heading_deg) == -np.sign(c.heading_deg) for a, _, c in pairs)


def test_long_dropouts_avoid_turns() -> None:
    for seed in range(20):
        rng = np.random.default_rng(seed)
        segs = sm.random_segments(rng)
        drops = sm.random_dropouts(rng, segs, n_short=0, n_long=2)
        seq = sm.generate_sequence(seed=seed, segments=segs, dropouts=drops)
        for a, b in seq.dropouts.itertuples(index=False):
            overlap = np.minimum(b, seq.planted.end_frame) - np.maximum(a, seq.planted.start_frame)
            assert (overlap <= 0).all()


def test_planted_table_columns_and_kinds() -> None:
    segs = sm.random_segments(np.random.default_rng(2))
    seq = sm.generate_sequence(seed=2, segments=segs)
    assert list(seq.planted.columns) == [
        "start_frame",
        "end_frame",
        "angle_deg",
        "kind",
        "heading_deg",
        "duration_s",
    ]
    assert seq.planted["start_frame"].dtype == np.int64
    assert len(seq.planted) == sum(s.is_turn for s in segs)
    assert (seq.planted["end_frame"] > seq.planted["start_frame"]).all()
    mocap = seq.to_mocap(subject="S1", action="Walking", subaction="1")
    assert mocap.layout is H36M32 and mocap.units == "mm" and mocap.fps == FPS


@pytest.mark.parametrize(
    "make",
    [
        lambda: sm.Segment("jump", 1.0),
        lambda: sm.Segment.walk(0.0),
        lambda: sm.Segment.pivot_turn(0.0, 1.0),
        lambda: sm.Segment("walk", 1.0, heading_deg=10.0, speed_m_s=1.0),
        lambda: sm.Segment("walk", 1.0),
        lambda: sm.Segment("stand", 1.0, speed_m_s=1.0),
        lambda: sm.generate_sequence(seed=0, segments=[]),
        lambda: sm.generate_sequence(seed=0, segments=[sm.Segment.stand(1)], fps_hz=float("nan")),
        lambda: sm.generate_sequence(seed=0, segments=[sm.Segment.stand(1)], noise_mm=-1.0),
        lambda: sm.generate_sequence(seed=0, segments=[sm.Segment.stand(1)], sway_deg=np.inf),
    ],
)
def test_bad_segments_are_refused(make) -> None:
    with pytest.raises(TurnbenchError):
        make()


def test_a_turn_with_ramps_keeps_one_speed_between_them() -> None:
    # Walking round a loop: 360° over 10 s with 1 s ramps. The rate is level at
    # 360 / (10 - 1) = 40 °/s between the ramps (the ramps' raised cosines carry half
    # their length each), zero at both ends; the heading change is exact.
    from turn_datasets.synthetic.mocap import _turn_profile

    u = np.linspace(0.0, 1.0, 10001)
    done = 360.0 * _turn_profile(u, 0.1)
    rate = np.gradient(done, u) / 10.0  # degrees per second over the 10 s segment
    assert done[0] == pytest.approx(0.0) and done[-1] == pytest.approx(360.0)
    level = (u > 0.11) & (u < 0.89)
    np.testing.assert_allclose(rate[level], 40.0, rtol=1e-6)
    assert rate[0] == pytest.approx(0.0, abs=0.05) and rate[-1] == pytest.approx(0.0, abs=0.05)
    assert (np.diff(done) >= 0).all()
    # the default is the sine profile, bit for bit
    np.testing.assert_array_equal(_turn_profile(u), 0.5 * (1.0 - np.cos(np.pi * u)))
