"""``--position-cutoff-hz`` is bounded from the frame rate by one rule for ``detect`` and
``h36m mine`` (:func:`turn_datasets.h36m.miner.position_filter_applies`): from 1e-4 to below
0.45 times the rate. Below, the filter's coefficients are a singular system (1e-9 Hz was a
LinAlgError traceback); at or above, there is no filter (detect skipped it silently while
its manifest recorded it). ``detect``, whose rate is one option, refuses a cut-off outside;
``h36m mine``, whose files bring their own rates, mines those sequences unfiltered and says so."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import run_cli as run
from test_reading_bounds import walking

from turn_datasets.cli import cli as datasets_cli
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.errors import TurnbenchError
from turn_datasets.h36m.miner import (
    check_position_cutoff,
    mine_sequence,
    position_filter_applies,
)
from turn_datasets.skeleton import H36M17
from turn_eval.cli import cli as eval_cli

DETECT = ["--layout", "h36m17", "--up-axis", "z", "--fps", "30"]
MINE = ["--layout", "h36m17", "--fps", "30", "--up-axis", "z", "--units", "m"]


@pytest.mark.parametrize("cutoff", ["1e-9", "0.0029", "13.5", "100"])
def test_detect_refuses_a_cutoff_outside_the_frame_rates_range_one_line_exit_2(
    tmp_path, capsys, cutoff
) -> None:
    np.savez(tmp_path / "home.npz", P01=walking())
    out = tmp_path / "o.csv"
    args = ["detect", tmp_path / "home.npz", *DETECT, "--position-cutoff-hz", cutoff]
    code, _, err = run(eval_cli, "turn-eval", [*args, "--out", out], capsys)
    assert code == EXIT_BAD_INPUT, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert f"--position-cutoff-hz {float(cutoff):g} cannot filter at 30 fps" in err
    assert "from 0.0001 x fps (0.003 Hz) to below 0.45 x fps (13.5 Hz)" in err
    assert not out.exists()


def test_mine_takes_a_cutoff_below_the_range_unfiltered_and_says_so(tmp_path, capsys) -> None:
    # the same rule: 1e-9 Hz at 30 fps was a LinAlgError traceback; mine (whose files bring
    # their own rates) mines the sequence unfiltered, with a warning and the manifest's count
    np.savez(tmp_path / "home.npz", P01=walking())
    out = tmp_path / "o.csv"
    args = ["h36m", "mine", tmp_path / "home.npz", *MINE, "--position-cutoff-hz", "1e-9"]
    code, _, err = run(datasets_cli, "turn-datasets", [*args, "--out", out], capsys)
    assert code == 0, err
    assert "Traceback" not in err
    assert "warning: --position-cutoff-hz 1e-09 is below 0.0001 x 30 Hz" in err
    manifest = json.loads((tmp_path / "o.manifest.json").read_text())
    assert manifest["position_filter"]["sequences_unfiltered"] == 1


@pytest.mark.parametrize("cutoff", ["0", "0.003", "6", "13.4"])
def test_a_cutoff_inside_the_range_detects(tmp_path, capsys, cutoff) -> None:
    np.savez(tmp_path / "home.npz", P01=walking())
    out = tmp_path / "o.csv"
    args = ["detect", tmp_path / "home.npz", *DETECT, "--position-cutoff-hz", cutoff]
    code, _, err = run(eval_cli, "turn-eval", [*args, "--out", out], capsys)
    assert code == 0, err
    assert out.exists()


def test_the_rule_bounds_by_hand() -> None:
    check_position_cutoff(0.0, 30.0)  # no filter
    check_position_cutoff(6.0, 13.34)  # 6 < 0.45 x 13.34 = 6.003
    check_position_cutoff(1e-4 * 50, 50.0)  # the lower end itself
    for cutoff, fps in ((6.0, 13.33), (22.5, 50.0), (0.0049, 50.0), (1e-9, 30.0)):
        with pytest.raises(TurnbenchError, match="cannot filter at"):
            check_position_cutoff(cutoff, fps)


def test_the_miner_does_not_filter_outside_the_range() -> None:
    # where the rule says no filter, the miner's hips are the raw ones (no LinAlgError)
    p = walking().astype(float)
    raw = mine_sequence(p, layout=H36M17, fps_hz=30.0, position_cutoff_hz=0.0)
    low = mine_sequence(p, layout=H36M17, fps_hz=30.0, position_cutoff_hz=1e-9)
    assert low.equals(raw)
    assert not position_filter_applies(1e-9, 30.0) and position_filter_applies(0.003, 30.0)
