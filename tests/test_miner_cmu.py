"""The miner on real motion capture: every CMU trial listed in ``../shared/data/cmu-mocap``'s
SOURCE.md, against a truth computed here from the BVH root joint's own rotation channels.

The truth does not use the hip joint positions the miner reads (nor the reader's forward
kinematics): the root's Euler angles (``Zrotation Yrotation Xrotation``, intrinsic, as
SOURCE.md says) are turned into a rotation with SciPy, the T-pose's facing direction (+z) is
rotated by it, and its direction on the ground plane (x, z of BVH's y-up frame) is the
heading. A rotation about +y by theta takes +z to (sin theta, 0, cos theta), so
``atan2(x, z)`` is that angle, counter-clockwise seen from above: left is increasing, as in
DESIGN.md. A turn's true angle is the change of the mean heading between the second before
the mined clip's start and the second after its end, each window cut at a neighbouring
turn and at the trial's ends (issue 11).

Trials are read from SOURCE.md's first table: adding a row (and its file) adds a case.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import REPO, run_turn_eval
from scipy.spatial.transform import Rotation

from turn_datasets.h36m.miner import mine_sequence
from turn_datasets.mocap import bvh, readers
from turn_datasets.synthetic import mocap as sm

_COUNTS = {"none": 0, "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6}


def source_table(cmu_dir: Path) -> list[tuple[str, int, str | None]]:
    """``(file, number of turns, direction or None)`` for each row of SOURCE.md's first table.

    Its third column reads like ``one, right``, ``none`` or ``three, all left: about ...``.
    """
    rows = []
    lines = (cmu_dir / "SOURCE.md").read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| file | CMU's"))
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        name, turns = cells[0], cells[2].lower()
        count = _COUNTS[re.match(r"[a-z]+", turns).group(0)]
        head = re.split(r"[:(]", turns)[0]
        sides = set(re.findall(r"\b(left|right)\b", head))
        assert len(sides) <= 1, line  # a row with both directions would need per-turn order
        rows.append((name, count, sides.pop() if sides else None))
    return rows


def root_heading_deg(path: Path) -> np.ndarray:
    """Unwrapped heading (degrees, left = increasing) of the root per captured frame.

    Frame 0, the T-pose CMU's conversion adds (SOURCE.md), is left out, as the reader does.
    """
    motion = bvh.parse_bvh(path)
    root = motion.joints[0]
    rot = [(k, c) for k, c in enumerate(root.channels) if c.lower().endswith("rotation")]
    order = "".join(c[0].upper() for _, c in rot)  # upper case: intrinsic, as BVH means
    angles = motion.motion[1:, [root.channel_start + k for k, _ in rot]]
    facing = Rotation.from_euler(order, angles, degrees=True).apply([0.0, 0.0, 1.0])
    return np.degrees(np.unwrap(np.arctan2(facing[:, 0], facing[:, 2])))


def true_angles(heading: np.ndarray, starts, ends, fps: float) -> np.ndarray:
    """Change of the mean heading from the second before each turn to the second after it."""
    out = []
    second = int(round(fps))
    n = heading.shape[0]
    for i, (s, e) in enumerate(zip(starts, ends, strict=True)):
        lo = ends[i - 1] if i else 0
        hi = starts[i + 1] if i + 1 < len(starts) else n
        before = heading[max(s - second, lo) : s]
        after = heading[e : min(e + second, hi)]
        b = before.mean() if before.size else heading[s]
        a = after.mean() if after.size else heading[e - 1]
        out.append(a - b)
    return np.array(out)


def _trials(cmu_dir: Path):
    return source_table(cmu_dir)


def test_source_table_lists_every_trial_with_its_turns(cmu_dir) -> None:
    rows = {name: (count, side) for name, count, side in source_table(cmu_dir)}
    assert rows["69_20.bvh"] == (1, "right")
    assert rows["69_17.bvh"] == (3, "left")
    assert rows["69_19.bvh"] == (4, "right")
    assert rows["69_32.bvh"] == (1, "left")
    assert rows["16_21.bvh"] == (0, None) and rows["69_01.bvh"] == (0, None)
    # 69_20, 69_25, 16_18, 16_27 and 69_32 one each; 69_17 three; 69_19 four
    assert len(rows) == 9 and sum(c for c, _ in rows.values()) == 12


@pytest.fixture(scope="module")
def mined(cmu_dir) -> dict:
    """Every listed trial read and mined with no option: ``{file: (sequence, clips)}``."""
    out = {}
    for name, _, _ in source_table(cmu_dir):
        (seq,) = readers.read_source(cmu_dir / name, skip_first_frame=True)
        out[name] = (seq, mine_sequence(seq.positions, layout=seq.layout, fps_hz=seq.fps))
    return out


def readme_cmu_table() -> list[list[str]]:
    """The cells of each row of the README's CMU table (the miner's rule section)."""
    lines = (REPO / "README.md").read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| trial | CMU's"))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip("|").split("|")])
    return rows


def test_every_listed_trial_mined_against_the_roots_heading(cmu_dir, mined) -> None:
    """Each turn found with its direction, within 3° of the root's heading change; no clip on
    the walks; each clip's boundaries where the root's heading is still (or again) near its
    mean before (after) the turn, so the truth's windows are outside the turn."""
    report = []
    for name, count, side in source_table(cmu_dir):
        seq, clips = mined[name]
        assert len(clips) == count, (name, clips)
        if not count:
            continue
        heading = root_heading_deg(cmu_dir / name)
        assert heading.shape[0] == seq.n_frames
        starts, ends = clips.start_frame.tolist(), clips.end_frame.tolist()
        truth = true_angles(heading, starts, ends, seq.fps)
        assert (clips.direction == side).all(), name
        assert np.sign(truth).tolist() == [1.0 if side == "left" else -1.0] * count
        np.testing.assert_allclose(clips.net_deg, truth, atol=3.0, err_msg=name)
        for s, e, t in zip(starts, ends, truth, strict=True):
            second = int(round(seq.fps))
            before = heading[max(s - second, 0) : s].mean() if s else heading[0]
            after = heading[e : e + second].mean() if e < seq.n_frames else heading[-1]
            assert abs(heading[s] - before) < 0.15 * abs(t), (name, s)
            assert abs(heading[e - 1] - after) < 0.15 * abs(t), (name, e)
        report.append((name, clips.net_deg.round(1).tolist(), truth.round(1).tolist()))
    assert len(report) >= 5


def test_the_readmes_cmu_table_is_what_the_miner_gives(cmu_dir, mined) -> None:
    """Every row of the README's CMU table (mined angles, the root's heading change, the hip
    rotation, to 0.1°) is what the miner and the root's own rotation give now."""
    rows = {
        cells[0] + ".bvh": [[float(x) for x in re.findall(r"\d+\.\d", c)] for c in cells[2:5]]
        for cells in readme_cmu_table()
    }
    assert set(rows) == set(mined)
    for name, (angles, root, hip) in rows.items():
        seq, clips = mined[name]
        starts, ends = clips.start_frame.tolist(), clips.end_frame.tolist()
        truth = np.abs(true_angles(root_heading_deg(cmu_dir / name), starts, ends, seq.fps))
        assert clips.angle_deg.round(1).tolist() == angles, name
        assert truth.round(1).tolist() == root, name
        assert clips.hip_rotation_deg.round(1).tolist() == hip, name


def _signed(value: float) -> str:
    """``+5.3°`` or ``−1.0°``, as the README writes a signed difference (U+2212 for minus)."""
    return f"{value:+.1f}°".replace("-", "\u2212")


def test_the_readmes_hip_rotation_range_is_what_the_miner_gives(mined) -> None:
    """The miner's rule section: how far ``hip_rotation_deg`` is off the heading change
    (``angle_deg``) on the CMU table's walking turns (the trials CMU describes as walks), from
    its lowest to its highest, is what the miner gives now."""
    walks = [cells[0] + ".bvh" for cells in readme_cmu_table() if cells[1].startswith("walk")]
    off = []
    for name in walks:
        clips = mined[name][1]
        off += (clips.hip_rotation_deg.abs() - clips.angle_deg.abs()).tolist()
    assert len(off) >= 5  # four corners and the curved walk
    text = " ".join((REPO / "README.md").read_text(encoding="utf-8").split())
    claim = (
        f"it is off by {_signed(min(off))} to {_signed(max(off))} on the CMU walking turns below"
    )
    assert claim in text


def _stride_sway_amplitudes_deg(heading: np.ndarray, fps: float) -> list[float]:
    """Half the peak-to-peak of the heading about its stride mean, one value per stride.

    The stride is the lag (0.8 to 1.6 s) of the highest autocorrelation of the heading's
    deviation from a 1.1 s running mean: the pelvis rotates once per stride.
    """
    from scipy.ndimage import uniform_filter1d

    d = heading - uniform_filter1d(heading, int(1.1 * fps), mode="nearest")
    n = d.shape[0]
    ac = np.correlate(d, d, "full")[n - 1 :] / (n - np.arange(n))
    lo, hi = int(0.8 * fps), int(1.6 * fps)
    stride = lo + int(np.argmax(ac[lo:hi]))
    dev = heading - uniform_filter1d(heading, stride, mode="nearest")
    core = dev[stride // 2 : n - stride // 2]
    return [
        float(np.ptp(core[i : i + stride]) / 2) for i in range(0, core.size - stride + 1, stride)
    ]


def test_generator_sway_is_what_cmus_walks_show(cmu_dir) -> None:
    # Measured on the straight walks: ±3.4° and ±4.1° (69_01, two strides), ±6.3° (16_21).
    amps = []
    for name, count, _ in source_table(cmu_dir):
        if count == 0:
            (seq,) = readers.read_source(cmu_dir / name, skip_first_frame=True)
            amps += _stride_sway_amplitudes_deg(root_heading_deg(cmu_dir / name), seq.fps)
    assert len(amps) >= 3
    assert 3.0 <= min(amps) and max(amps) <= 7.0
    # the generator's default (peak to peak) sits inside what the real walks show
    assert min(amps) <= sm.SWAY_DEG / 2 <= max(amps)
    # and is what a straight synthetic walk's hip yaw shows, measured the same way
    walk = sm.generate_sequence(
        seed=3, segments=[sm.Segment.walk(12.0, 1.2)], noise_mm=0.0, wander_deg=0.0
    )
    yaw = np.degrees(np.unwrap(np.radians(walk.true_yaw_deg)))
    synth = _stride_sway_amplitudes_deg(yaw[100:-100], walk.fps)
    assert np.median(synth) == pytest.approx(sm.SWAY_DEG / 2, abs=0.3)


def test_the_readmes_cmu_sway_is_what_the_walks_show(cmu_dir) -> None:
    """The README's pelvic sway of the CMU walks (per stride, on the root's own yaw, to
    0.1°) is what the straight walks' root rotation gives now."""
    said = []
    for trial in ("69_01", "16_21"):
        (seq,) = readers.read_source(cmu_dir / f"{trial}.bvh", skip_first_frame=True)
        amps = _stride_sway_amplitudes_deg(root_heading_deg(cmu_dir / f"{trial}.bvh"), seq.fps)
        said.append(" and ".join(f"±{a:.1f}°" for a in amps) + f" in {trial}")
    text = " ".join((REPO / "README.md").read_text(encoding="utf-8").split())
    assert f"measured on the root's yaw about its stride mean, is {' and '.join(said)}." in text


def test_detect_reads_the_same_captures_and_finds_the_same_turns(cmu_dir, tmp_path, capsys) -> None:
    """``turn-eval detect --from mocap`` on the real captures: every trial's turns by count
    and direction as SOURCE.md lists them (69_17's three turns in place and 69_19's four
    with pauses of 0.1-0.3 s, not one or two merged turns; each walking turn, 69_32's curved
    one included, once; none on the walks), each within 8° of the root's own heading change,
    none longer than 10 s or faster than the human bound."""
    from turn_datasets import limits

    out = tmp_path / "d.csv"
    code, _, err = run_turn_eval(["detect", cmu_dir, "--from", "mocap", "--out", out], capsys)
    assert code == 0, err
    found = pd.read_csv(out)
    manifest = json.loads(out.with_suffix(".manifest.json").read_text(encoding="utf-8"))
    assert manifest["reading"]["fps_hz"] is None  # each file's own: 120 Hz
    assert {s["fps_hz"] for f in manifest["inputs"] for s in f["streams"]} == {120.0}
    for name, count, side in source_table(cmu_dir):
        mine = found[found.session == name.removesuffix(".bvh")]
        assert len(mine) == count, (name, mine)
        if not count:
            continue
        assert (mine.direction == side).all(), name
        fps = 120.0
        heading = root_heading_deg(cmu_dir / name)
        starts = np.rint(mine.start_s.to_numpy() * fps).astype(int).tolist()
        ends = np.rint(mine.end_s.to_numpy() * fps).astype(int).tolist()
        truth = np.abs(true_angles(heading, starts, ends, fps))
        np.testing.assert_allclose(mine.angle_deg, truth, atol=8.0, err_msg=name)
    assert (found.end_s - found.start_s).max() <= limits.MAX_TURN_DURATION_S
    assert found.speed_deg_s.max() <= limits.MAX_TURN_MEAN_SPEED_DEG_S
    assert manifest["counts"]["detections"] == 12 and manifest["counts"]["rejected"] == {}
