"""``turn_eval.detect``: each estimator artefact on a stream built to show it, the raw miner
fooled by it, the detector not; the protocol; the preprocessing worked by hand."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import frame_yaw_deg
from turn_datasets.h36m.miner import MinerParams, mine_sequence, mine_sequence_report
from turn_datasets.skeleton import H36M17, H36M17_FROM_32, to_z_up
from turn_datasets.synthetic import mocap as sm
from turn_datasets.synthetic.degrade import degrade_skeleton
from turn_datasets.synthetic.untrimmed import camera_frame_m, plant_sitting, swap_sides
from turn_eval.detect import (
    TURN_DTYPES,
    DetectParams,
    MinerRule,
    TurnDetector,
    checked_turns,
)
from turn_eval.detect import rule as rule_module
from turn_eval.detect.preprocess import identity_pieces, repair_swaps

FPS = 30.0
CAMERA_MM = (0.0, -4000.0, 1500.0)
RULE = MinerRule(DetectParams(miner=MinerParams(min_turn_deg=67.5, max_gap_s=0.5)))


def stream(segments, *, seed=0, edit=None, degrade=None) -> np.ndarray:
    """A 17-joint stream as an estimator writes it (camera axes, metres), read back z up."""
    seq = sm.generate_sequence(
        seed=seed,
        segments=segments,
        fps_hz=FPS,
        noise_mm=0.0,
        sway_deg=4.0,
        start_heading_deg=0.0,
    )
    body = seq.positions
    if edit is not None:
        edit(body)
    b17 = body[:, list(H36M17_FROM_32)]
    if degrade is not None:
        b17 = degrade_skeleton(
            b17, H36M17, seed=seed, fps=FPS, camera_position_mm=CAMERA_MM, **degrade
        ).positions
    return to_z_up(camera_frame_m(b17, CAMERA_MM).astype(float), "-y")


def raw_miner(p: np.ndarray, **kw) -> pd.DataFrame:
    kw = {"min_turn_deg": 67.5, "max_gap_s": 0.5, **kw}
    return mine_sequence(p, layout=H36M17, fps_hz=FPS, **kw)


WALK_TURN_WALK = [
    sm.Segment.stand(2),
    sm.Segment.walk(6, 1.0),
    sm.Segment.pivot_turn(90, 2.0),  # frames 240-300
    sm.Segment.walk(6, 1.0),
    sm.Segment.stand(2),
]


def test_clean_turn_is_found_once_with_its_angle_and_boundaries() -> None:
    got = RULE.detect(stream(WALK_TURN_WALK), FPS, H36M17)
    assert list(got.columns) == list(TURN_DTYPES)
    assert len(got) == 1
    t = got.iloc[0]
    assert t.direction == "left" and t.angle_deg == pytest.approx(90.0, abs=6.0)
    assert t.start_s == pytest.approx(8.0, abs=0.3) and t.end_s == pytest.approx(10.0, abs=0.3)
    # equation 4 and the documented score
    assert t.speed_deg_s == pytest.approx(t.angle_deg / (t.end_s - t.start_s))
    assert t.score == pytest.approx(t.angle_deg / (t.angle_deg + 67.5))


def test_left_right_swaps_are_not_turns() -> None:
    clean = stream(WALK_TURN_WALK)
    swapped = clean.copy()
    for a in (150, 260, 500):  # 5 frames each, walking, inside the turn, walking
        swap_sides(swapped, a, a + 5)
    # A swap flips the hip vector by 180° but not the hip line: the miner unwraps the line
    # modulo 180°, so even run raw it sees only the real turn (planted at frames 240-300),
    # where it used to read each swap as a full turn and lose the real one.
    raw = mine_sequence_report(swapped, layout=H36M17, fps_hz=FPS, min_turn_deg=67.5, max_gap_s=0.5)
    assert len(raw.turns) == 1 and raw.rejected.empty
    t = raw.turns.iloc[0]
    assert t.direction == "left" and t.angle_deg == pytest.approx(90.0, abs=3.0)
    assert abs(t.start_frame - 240) <= 10 and abs(t.end_frame - 300) <= 10
    # Repaired: exactly the 15 swapped frames put back, bit for bit.
    fixed, n = repair_swaps(swapped, H36M17, fps_hz=FPS, max_gap_s=0.5)
    assert n == 15
    np.testing.assert_array_equal(fixed, clean)
    got = RULE.detect(swapped, FPS, H36M17)
    np.testing.assert_allclose(
        got[["start_s", "end_s", "angle_deg"]].to_numpy(),
        RULE.detect(clean, FPS, H36M17)[["start_s", "end_s", "angle_deg"]].to_numpy(),
    )


def test_a_swap_lasting_most_of_a_stretch_is_read_as_the_persons_side() -> None:
    # Parity by majority: when the "swap" is the longer part, the other part is repaired.
    clean = stream(WALK_TURN_WALK)
    swapped = clean.copy()
    swap_sides(swapped, 0, 400)
    fixed, n = repair_swaps(swapped, H36M17, fps_hz=FPS, max_gap_s=0.5)
    assert n == clean.shape[0] - 400
    yaw = frame_yaw_deg(fixed, H36M17)
    # the body's own sense is the swapped one throughout: a constant 180° offset from clean
    offset = (yaw - frame_yaw_deg(clean, H36M17) + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(np.abs(offset), 180.0, atol=1e-6)


def test_depth_error_hips_and_shoulders_halve_the_yaw_noise() -> None:
    segs = [sm.Segment.stand(2), sm.Segment.walk(20, 1.0), sm.Segment.stand(2)]
    clean = stream(segs, seed=4)
    noisy = stream(segs, seed=4, degrade={"depth_sd_facing_mm": 60.0, "depth_sd_away_mm": 60.0})

    def err(joints):
        d = frame_yaw_deg(noisy, H36M17, joints) - frame_yaw_deg(clean, H36M17, joints)
        return np.sqrt(np.nanmean((d - np.nanmean(d)) ** 2))

    # independent errors per joint: two pairs give 1/sqrt(2) of one pair's error, roughly
    assert err(("hip", "shoulder")) < 0.85 * err(("hip",))
    # and no turn is read into 20 s of straight walking
    assert len(RULE.detect(noisy, FPS, H36M17)) == 0


#: An estimator whose error is depth (20-76 mm drifting, 30 mm white, doubled with the back
#: to the camera) against 8 mm across.
ESTIMATOR = {
    "depth_sd_facing_mm": 20.0,
    "depth_sd_away_mm": 76.0,
    "white_depth_sd_mm": 30.0,
    "joint_noise_mm": 8.0,
    "dropout_rate_per_s": 0.0,
}
ESTIMATOR_RULE = MinerRule(DetectParams(miner=MinerParams(min_turn_deg=67.5, max_gap_s=0.5)))


def walking_turns() -> list[tuple[float, np.ndarray]]:
    """Walking turns of 90° and 135° (6-8 s) through :data:`ESTIMATOR`, 12 draws each: the
    turn's angle and the stream."""
    out = []
    for angle in (90.0, -135.0):
        segs = [
            sm.Segment.stand(2),
            sm.Segment.walk(4, 1.0),
            sm.Segment.pivot_turn(angle, 1.5 if angle > 0 else 2.0),
            sm.Segment.walk(4, 1.0),
            sm.Segment.stand(2),
        ]
        out += [(abs(angle), stream(segs, seed=seed, degrade=ESTIMATOR)) for seed in range(12)]
    return out


def angle_mae(rule: MinerRule, streams: list[tuple[float, np.ndarray]]) -> float:
    """The mean error of the one turn each stream gives between 6 and 8 s."""
    errors = []
    for angle, p in streams:
        found = rule.detect(p, FPS, H36M17)
        turn = found[(found.start_s < 8.0) & (found.end_s > 6.0)]
        assert len(turn) == 1, found
        errors.append(abs(float(turn.angle_deg.iloc[0]) - angle))
    return float(np.mean(errors))


def test_depth_error_along_the_ray_costs_walking_turns_less() -> None:
    """The walking turns seen by :data:`ESTIMATOR`: the depth-aware heading's mean angle
    error is well under the plain direction's (2.7° against 6.5°)."""
    streams = walking_turns()
    plain = MinerRule(
        DetectParams(miner=ESTIMATOR_RULE.params.miner, ray_noise_ratio=1.0, ray_search_deg=0.0)
    )
    aware_mae, plain_mae = angle_mae(ESTIMATOR_RULE, streams), angle_mae(plain, streams)
    assert aware_mae < 0.7 * plain_mae, (aware_mae, plain_mae)


def test_a_root_relative_stream_reads_its_ray_from_its_error(monkeypatch) -> None:
    """The walking turns above, root-relative (pelvis at the origin, as lifting networks
    write): the person stands up to 45° off the camera's axis, which the stream no longer
    shows. The ray read from the jitter (``heading.noise_rays``) gives a mean angle error of
    2.7° over the 24 draws, as good as the positioned streams' 2.7°; taking everyone as
    straight ahead gives 6.0°, no better than the plain direction."""
    streams = [(angle, p - p[:, :1]) for angle, p in walking_turns()]
    from_error = angle_mae(ESTIMATOR_RULE, streams)
    rays = rule_module.camera_rays
    monkeypatch.setattr(rule_module, "camera_rays", lambda mid, width, *_: rays(mid, width))
    ahead = angle_mae(ESTIMATOR_RULE, streams)
    assert from_error < 0.7 * ahead, (from_error, ahead)


ABSENCE = [
    sm.Segment.stand(3),
    sm.Segment.walk(4, 1.0),
    sm.Segment.stand(3),
    sm.Segment.pivot_turn(180, 2.5),  # frames 300-375, hidden by the absence below
    sm.Segment.stand(3),
    sm.Segment.walk(4, 1.0),
    sm.Segment.stand(2),
]


def test_a_turn_is_not_followed_through_an_absence() -> None:
    p = stream(ABSENCE)
    p[int(7 * FPS) : int(17 * FPS)] = np.nan  # 10 s out of view
    assert len(RULE.detect(p, FPS, H36M17)) == 0
    # what bridging the absence would do: the hips interpolated across the unseen 180° turn
    # pass through each other, and the hip line (unwrapped modulo 180°) does not rotate
    # through it: neither the turn nor anything else, so nothing is gained by bridging
    bridged = mine_sequence_report(p, layout=H36M17, fps_hz=FPS, min_turn_deg=67.5, max_gap_s=11.0)
    assert bridged.turns.empty and bridged.rejected.empty


def test_a_short_dropout_inside_a_turn_is_bridged() -> None:
    p = stream(ABSENCE)
    p[int(11.0 * FPS) : int(11.3 * FPS)] = np.nan
    got = RULE.detect(p, FPS, H36M17)
    assert len(got) == 1
    assert got.angle_deg[0] == pytest.approx(180.0, abs=8.0)
    # 0.3 s of its 2.5 s unseen: the score says so
    assert got.score[0] < got.angle_deg[0] / (got.angle_deg[0] + 67.5)


STANDING = [
    sm.Segment.stand(3),
    sm.Segment.walk(5, 1.0),
    sm.Segment.stand(8),  # frames 240-480
    sm.Segment.walk(5, 1.0),
    sm.Segment.stand(2),
]


def with_bystander(body: np.ndarray) -> None:
    """Frames 270-420: the tracker follows someone 20% larger, 2.5 m away, who turns 150°."""
    a, b = 270, 420
    other = sm.generate_sequence(
        seed=5,
        segments=[sm.Segment.stand(1), sm.Segment.pivot_turn(150, 2.0), sm.Segment.stand(2)],
        fps_hz=FPS,
        noise_mm=0.0,
        start_heading_deg=40.0,
    ).positions[: b - a]
    ground = other[:, :1].copy()
    ground[..., 2] = 0.0
    other = ground + 1.2 * (other - ground)
    other[..., :2] += body[a, 0, :2] + np.array([2500.0, 0.0]) - other[0, 0, :2]
    body[a:b] = other


@pytest.mark.parametrize("root_relative", [False, True])
def test_identity_break_to_a_bystander_is_cut_out(root_relative: bool) -> None:
    p = stream(STANDING, edit=with_bystander)
    if root_relative:
        p = p - p[:, :1]  # no position left: only the size tells the bystander apart
    raw = raw_miner(p)
    # the bystander's turn. (Issue 11: the miner's yaw is a 0.3 s moving mean, so a clip
    # that starts at a jump starts up to that window, 9 frames at 30 fps, before it: 263
    # here, since the stream's 5 s walks now give the stride the heading rate spans.)
    smoothing = round(MinerParams().smooth_s * FPS)
    assert len(raw) >= 1 and raw.start_frame.between(270 - smoothing, 420).all()
    assert len(RULE.detect(p, FPS, H36M17)) == 0
    usable = np.isfinite(p).all(axis=(1, 2))
    pieces = identity_pieces(
        p, H36M17, usable, fps_hz=FPS, jump_sizes=0.5, size_change=0.15, size_tolerance=0.1
    )
    kept = np.zeros(p.shape[0], dtype=bool)
    for a, b in pieces:
        kept[a:b] = True
    # the cut is at the jump: every bystander frame out, the person's frames in (the size
    # change is found within a few frames of it when there is no position to go by)
    slack = 0 if not root_relative else 5
    assert not kept[270 + slack : 420 - slack].any()
    assert kept[: 270 - slack].all() and kept[420 + slack :].all()


PIVOT_180 = [sm.Segment.stand(8), sm.Segment.pivot_turn(180, 2.0), sm.Segment.stand(8)]


@pytest.mark.parametrize("root_relative", [False, True])
def test_a_size_change_within_the_tolerance_does_not_cut_a_turn(root_relative: bool) -> None:
    """The depth error inflates the body's size as the back turns to the camera: here the
    size is 8% under its usual value for the 3 s before the middle of a 180° turn (frames
    240-300) and 8% over it for the 3 s after. Across frame 270 the median size over a
    second changes by 17%, more than ``identity_size_change``: a cut. Either side's median
    is the stream's size (two thirds of each side are unchanged), so both are the person's
    own and the cut is undone: one piece, one turn of 180°, where the pieces alone would
    give two turns of about 90°."""

    def scale(body: np.ndarray, spans) -> None:
        for a, b, k in spans:
            pelvis = body[a:b, :1].copy()
            body[a:b] = pelvis + k * (body[a:b] - pelvis)

    kw = {"fps_hz": FPS, "jump_sizes": 0.5, "size_change": 0.15, "size_tolerance": 0.1}

    def pieces(spans):
        p = stream(PIVOT_180, edit=lambda body: scale(body, spans))
        if root_relative:
            p = p - p[:, :1]
        return p, identity_pieces(p, H36M17, np.isfinite(p).all(axis=(1, 2)), **kw)

    p, found = pieces([(180, 270, 0.92), (270, 360, 1.08)])
    assert found == [(0, p.shape[0])]
    turns = RULE.detect(p, FPS, H36M17)
    assert len(turns) == 1 and turns.angle_deg.iloc[0] == pytest.approx(180, abs=5)
    # 25% larger from frame 270 to 420 is someone else: cut out (within the median's
    # half-window of each edge), the rest kept
    p, found = pieces([(270, 420, 1.25)])
    assert len(found) == 2 and found[0][0] == 0 and found[1][1] == p.shape[0]
    assert abs(found[0][1] - 270) <= 16 and abs(found[1][0] - 420) <= 16


def test_decoys_are_not_turns() -> None:
    segs = [
        sm.Segment.stand(2),
        sm.Segment.walk(3, 1.0),
        sm.Segment.walking_turn(35, 1.0, 1.0),  # a small change of direction
        sm.Segment.walk(3, 1.0),
        sm.Segment.stand(1),
        *[sm.Segment.pivot_turn(s * 15, 0.6) for s in (1, -1, 1, -1, 1, -1)],  # swaying
        sm.Segment.stand(1),
        sm.Segment.pivot_turn(40, 1.0),  # reaching to the side and back
        sm.Segment.stand(1.5),
        sm.Segment.pivot_turn(-40, 1.0),
        sm.Segment.stand(12),  # sits down (below) for most of this
        sm.Segment.walk(3, 1.0),
        sm.Segment.stand(2),
    ]
    n = sum(max(2, round(s.duration_s * FPS)) for s in segs)
    sit_a = n - int(17 * FPS)

    def sit(body):
        plant_sitting(body, sit_a, sit_a + int(11 * FPS), FPS)

    degrade = {"depth_sd_facing_mm": 15.0, "depth_sd_away_mm": 60.0, "dropout_rate_per_s": 0.0}
    p = stream(segs, seed=2, edit=sit, degrade=degrade)
    assert len(RULE.detect(p, FPS, H36M17)) == 0
    # At the paper's 45°, estimator noise lifts some decoys over the line (sway's 30° from
    # side to side, the 40° reach): all well below 67.5°, the threshold for 90° labels.
    at45 = MinerRule(DetectParams()).detect(p, FPS, H36M17)
    assert (at45.angle_deg < 60.0).all()


def test_a_slow_en_bloc_turn_is_one_turn() -> None:
    # Parkinson's: 135° on the spot at 30 °/s (4.5 s), in small steps.
    segs = [sm.Segment.stand(3), sm.Segment.pivot_turn(-135, 4.5), sm.Segment.stand(3)]
    degrade = {"depth_sd_facing_mm": 15.0, "depth_sd_away_mm": 60.0, "dropout_rate_per_s": 0.0}
    got = RULE.detect(stream(segs, seed=1, degrade=degrade), FPS, H36M17)
    assert len(got) == 1 and got.direction[0] == "right"
    assert got.angle_deg[0] == pytest.approx(135.0, abs=12.0)
    assert got.start_s[0] == pytest.approx(3.0, abs=0.5) and got.end_s[0] == pytest.approx(
        7.5, abs=0.5
    )


def test_the_builtin_rule_is_a_turn_detector_and_params_validate() -> None:
    assert isinstance(RULE, TurnDetector)
    assert RULE.name == "miner-rule"
    d = DetectParams().as_dict()
    assert d["joints"] == "hip,shoulder" and d["min_turn_deg"] == 45.0 and d["max_gap_s"] == 0.5
    with pytest.raises(TurnbenchError, match="identity_size_change"):
        DetectParams(identity_size_change=-1.0)
    with pytest.raises(TurnbenchError, match="unknown joint pair"):
        DetectParams(joints=("elbow",))


def test_checked_turns_refuses_impossible_output() -> None:
    ok = pd.DataFrame({"start_s": [2.0, 0.5], "end_s": [3.0, 1.5], "angle_deg": [90.0, 80.0]})
    got = checked_turns(ok, detector="mine", n_frames=300, fps_hz=FPS)
    assert got.start_s.tolist() == [0.5, 2.0]  # time order
    assert got.angle_deg.tolist() == [80.0, 90.0] and got.index.tolist() == [0, 1]
    assert got.direction.tolist() == ["", ""] and got.score.isna().all()
    bad = [
        ({"start_s": [1.0], "end_s": [0.5], "angle_deg": [90.0]}, "impossible turn"),
        ({"start_s": [1.0], "end_s": [11.0], "angle_deg": [90.0]}, "impossible turn"),
        ({"start_s": [1.0], "end_s": [2.0], "angle_deg": [np.nan]}, "impossible turn"),
        ({"start_s": [1.0, 1.5], "end_s": [2.0, 3.0], "angle_deg": [90.0, 90.0]}, "overlapping"),
        ({"start_s": [1.0], "end_s": [2.0]}, "no angle_deg"),
    ]
    for table, match in bad:
        with pytest.raises(TurnbenchError, match=match):
            checked_turns(pd.DataFrame(table), detector="mine", n_frames=300, fps_hz=FPS)
    # turns starting together are in order of their ends: the overlap named is the first pair
    same_start = {"start_s": [1.0, 1.0], "end_s": [3.0, 2.0], "angle_deg": [90.0, 90.0]}
    with pytest.raises(TurnbenchError, match=r"\(1\.000-2\.000 s and 1\.000-3\.000 s\)"):
        checked_turns(pd.DataFrame(same_start), detector="mine", n_frames=300, fps_hz=FPS)
