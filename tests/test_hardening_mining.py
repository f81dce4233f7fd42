"""What the miner did but its options do not say (issue 10, #8): a cut-off it had to ignore,
a frame rate that is no motion capture's."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run_turn_datasets as _run

from turn_datasets.synthetic import mocap as sm


def _array(tmp_path: Path) -> Path:
    segs = [sm.Segment.stand(1.0), sm.Segment.walk(2.0, 1.2), sm.Segment.pivot_turn(90.0, 1.4)]
    segs += [sm.Segment.walk(2.0, 1.2), sm.Segment.stand(1.0)]
    seq = sm.generate_sequence(seed=1, segments=segs, noise_mm=5.0)
    path = tmp_path / "walk.npy"
    np.save(path, seq.positions)
    return path


ARRAY = ["--layout", "h36m32", "--fps", "50", "--up-axis", "z", "--units", "mm"]


def test_a_cutoff_at_or_above_045_fps_warns_and_the_manifest_says_unfiltered(tmp_path, capsys):
    arr = _array(tmp_path)
    out = tmp_path / "o.csv"
    code, _, err = _run(
        ["h36m", "mine", arr, *ARRAY, "--position-cutoff-hz", "22.5", "--out", out], capsys
    )
    assert code == 0, err
    assert "warning: --position-cutoff-hz 22.5 is at or above 0.45 x 50 Hz" in err
    manifest = json.loads((tmp_path / "o.manifest.json").read_text())
    assert manifest["position_filter"] == {
        "cutoff_hz": 22.5,
        "sequences_filtered": 0,
        "sequences_unfiltered": 1,
    }
    assert manifest["parameters"]["miner"]["position_cutoff_hz"] == 22.5  # as given, beside it


def test_a_cutoff_below_045_fps_filters_without_a_word(tmp_path, capsys):
    arr = _array(tmp_path)
    code, _, err = _run(
        ["h36m", "mine", arr, *ARRAY, "--position-cutoff-hz", "22.4", "--out", tmp_path / "o.csv"],
        capsys,
    )
    assert code == 0, err
    assert "warning" not in err
    manifest = json.loads((tmp_path / "o.manifest.json").read_text())
    assert manifest["position_filter"]["sequences_filtered"] == 1
    assert manifest["notes"] == []


@pytest.mark.parametrize("frame_time, fps", [("1e-9", "1e+09"), ("100", "0.01")])
def test_a_bvh_frame_time_in_the_wrong_unit_warns(cmu_dir, tmp_path, capsys, frame_time, fps):
    text = (cmu_dir / "16_21.bvh").read_text()
    bvh = tmp_path / "odd.bvh"
    bvh.write_text(text.replace("Frame Time: .0083333", f"Frame Time: {frame_time}"))
    out = tmp_path / "o.csv"
    code, _, err = _run(["h36m", "mine", bvh, "--out", out], capsys)
    assert code == 0, err
    assert f"frame rate {fps} Hz is outside the plausible 1-10000 Hz" in err
    manifest = json.loads((tmp_path / "o.manifest.json").read_text())
    assert any("outside the plausible" in n for n in manifest["notes"])
