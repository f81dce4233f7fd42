"""A user's own detector that misbehaves (loading, calling, returning, dying on a worker) is
one line naming the detector, the file and the stream, exit 2; what it returns is held to
the plausibility bounds every reader applies."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_eval as run

from turn_datasets import limits
from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.errors import TurnbenchError
from turn_eval.detect.protocol import checked_turns

BASE = ["--layout", "h36m17", "--up-axis", "z", "--fps", "30"]
FRAMES = 300  # 10 s


def _still(n: int = FRAMES) -> np.ndarray:
    """A person standing still, z up, hips 0.26 apart: a stream every detector can read."""
    p = np.zeros((n, 17, 3), dtype=np.float32)
    p[:, 1, 0], p[:, 4, 0] = -0.13, 0.13  # right hip, left hip (h36m17)
    p[:, :, 2] += 1.0
    return p


def _plugin(tmp_path: Path, monkeypatch, name: str, body: str) -> str:
    (tmp_path / f"{name}.py").write_text(
        "import sys, os\nimport pandas as pd\n" + textwrap.dedent(body)
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


GOOD_CLASS = """
class Det:
    name = "det"
    def detect(self, positions, fps_hz, layout):
        return {returns}
"""


def _one_line_error(code: int, stderr: str) -> str:
    assert code == EXIT_BAD_INPUT, stderr
    lines = [line for line in stderr.strip().splitlines() if not line.startswith("detecting")]
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    return lines[0]


@pytest.mark.parametrize(
    "body, expected",
    [
        ("raise ValueError('oops')", "importing its module failed (ValueError: oops)"),
        ("def broken(:\n    pass", "importing its module failed (SyntaxError"),
        ("sys.exit(3)", "importing its module failed (sys.exit(3))"),
        ("sys.exit(0)", "importing its module failed (sys.exit(0))"),
        (
            "class Det:\n    name = 'd'\n    def __init__(self):\n        raise RuntimeError('no')\n"
            "    def detect(self, p, f, l):\n        return None",
            "calling it without arguments failed (RuntimeError: no)",
        ),
        (
            "class Det:\n    name = 'd'\n    def __init__(self, model):\n        pass\n"
            "    def detect(self, p, f, l):\n        return None",
            "calling it without arguments failed (TypeError",
        ),
        ("Det = 42", "it is not a turn detector"),
        ("class Det:\n    name = 7\n    def detect(self, p, f, l):\n        pass", "not a turn"),
        ("x = 1", "has no 'Det'"),
    ],
)
def test_a_plugin_that_fails_to_load_is_one_line_exit_2(
    tmp_path, capsys, monkeypatch, body, expected
) -> None:
    np.savez(tmp_path / "home.npz", P01=_still())
    mod = _plugin(tmp_path, monkeypatch, f"plug_load_{abs(hash(body))}", body)
    code, _, stderr = run(
        [
            "detect",
            tmp_path / "home.npz",
            *BASE,
            "--detector",
            f"{mod}:Det",
            "--out",
            tmp_path / "d.csv",
        ],
        capsys,
    )
    line = _one_line_error(code, stderr)
    assert f"cannot load detector '{mod}:Det'" in line and expected in line, line
    assert not (tmp_path / "d.csv").exists()


@pytest.mark.parametrize(
    "returns, expected",
    [
        ("None", "returned None, not a pandas DataFrame"),
        ("[]", "returned list, not a pandas DataFrame"),
        ("{'start_s': [1.0]}", "returned dict, not a pandas DataFrame"),
        ("(x for x in [])", "returned generator, not a pandas DataFrame"),
        (
            "pd.DataFrame({'start_s': ['a'], 'end_s': ['b'], 'angle_deg': ['c']})",
            "returned a start_s column that is not numbers",
        ),
        (
            "pd.DataFrame([[1.0, 2.0, 90.0, 95.0]], columns=['start_s', 'end_s', 'angle_deg', 'angle_deg'])",
            "returned the column(s) angle_deg twice",
        ),
        ("1 / 0", "failed (ZeroDivisionError: division by zero)"),
        ("sys.exit(0)", "failed (sys.exit(0))"),
        ("sys.exit(3)", "failed (sys.exit(3))"),
    ],
)
def test_a_plugin_that_misbehaves_in_detect_names_detector_file_and_stream(
    tmp_path, capsys, monkeypatch, returns, expected
) -> None:
    np.savez(tmp_path / "home.npz", P01=_still())
    mod = _plugin(
        tmp_path, monkeypatch, f"plug_call_{abs(hash(returns))}", GOOD_CLASS.format(returns=returns)
    )
    code, _, stderr = run(
        [
            "detect",
            tmp_path / "home.npz",
            *BASE,
            "--detector",
            f"{mod}:Det",
            "--out",
            tmp_path / "d.csv",
        ],
        capsys,
    )
    line = _one_line_error(code, stderr)
    assert f"{tmp_path / 'home.npz'}, P01: detector 'det'" in line and expected in line, line
    assert not (tmp_path / "d.csv").exists()


def test_a_plugin_raising_keyboard_interrupt_on_the_main_thread_is_the_users_ctrl_c(
    tmp_path, monkeypatch
) -> None:
    from turn_eval.detect.plugins import call_detector

    class Interrupted:
        name = "ctrl-c"

        def detect(self, positions, fps_hz, layout):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        call_detector(Interrupted(), _still(), 30.0, None)  # type: ignore[arg-type]


def test_a_plugin_raising_keyboard_interrupt_on_a_worker_thread_is_its_error() -> None:
    # a cluster's worker runs the detector on a thread, where no Ctrl-C can arrive
    import threading

    from turn_eval.detect.plugins import call_detector

    class Interrupted:
        name = "ctrl-c"

        def detect(self, positions, fps_hz, layout):
            raise KeyboardInterrupt

    caught: list[BaseException] = []

    def work() -> None:
        try:
            call_detector(Interrupted(), _still(), 30.0, None)  # type: ignore[arg-type]
        except BaseException as exc:
            caught.append(exc)

    thread = threading.Thread(target=work)
    thread.start()
    thread.join()
    assert isinstance(caught[0], TurnbenchError)
    assert caught[0].message == "detector 'ctrl-c' failed (KeyboardInterrupt)"


@pytest.mark.parametrize(
    "column, value, bound",
    [
        ("angle_deg", 1e9, "angle_deg 1e+09, plausible: at most 3600"),
        ("speed_deg_s", 1e12, "speed_deg_s 1e+12, plausible: in [0, 10000]"),
        ("speed_deg_s", -5.0, "speed_deg_s -5, plausible: in [0, 10000]"),
        ("score", np.inf, "score inf, plausible: finite (or empty)"),
        ("end_s", 1.001, "angle_deg / (end_s - start_s) 90000"),
    ],
)
def test_detector_output_is_held_to_the_plausibility_bounds_of_limits(column, value, bound) -> None:
    row = {"start_s": [1.0], "end_s": [2.0], "angle_deg": [90.0], "speed_deg_s": [90.0]}
    row["score"] = [0.5]
    row[column] = [value]
    with pytest.raises(TurnbenchError, match="implausible turn") as info:
        checked_turns(pd.DataFrame(row), detector="mine", n_frames=FRAMES, fps_hz=30.0)
    assert bound in info.value.message
    # the bounds are the declared ones, not copies
    assert limits.MAX_ANGLE_DEG == 3600.0 and limits.MAX_SPEED_DEG_S == 10_000.0


def test_empty_optional_columns_pass_the_plausibility_check() -> None:
    t = pd.DataFrame(
        {"start_s": [1.0], "end_s": [2.0], "angle_deg": [90.0], "speed_deg_s": [np.nan]}
    )
    t["score"] = np.nan
    got = checked_turns(t, detector="mine", n_frames=FRAMES, fps_hz=30.0)
    assert got.speed_deg_s.isna().all() and got.score.isna().all()


def test_implausible_plugin_output_is_refused_before_anything_is_written(
    tmp_path, capsys, monkeypatch
) -> None:
    np.savez(tmp_path / "home.npz", P01=_still())
    returns = "pd.DataFrame({'start_s': [1.0], 'end_s': [2.0], 'angle_deg': [1e9]})"
    mod = _plugin(tmp_path, monkeypatch, "plug_huge", GOOD_CLASS.format(returns=returns))
    out = tmp_path / "d.csv"
    code, _, stderr = run(
        ["detect", tmp_path / "home.npz", *BASE, "--detector", f"{mod}:Det", "--out", out], capsys
    )
    line = _one_line_error(code, stderr)
    assert "home.npz, P01: detector 'det' returned an implausible turn" in line
    assert not out.exists()


# --- on a local Dask cluster (subprocesses: the workers import the plug-in fresh) ----------

WORKER_PLUGIN = """
import os, signal, threading
import pandas as pd

class Det:
    name = "worker-det"

    def __init__(self):
        self.how = os.environ.get("PLUG_HOW", "")

    def detect(self, positions, fps_hz, layout):
        if positions.shape[0] == 200:  # only the file "bad.npz" has 200 frames
            if self.how == "kill":
                os.kill(os.getpid(), signal.SIGKILL)
            if self.how == "exit":
                os._exit(1)
            if self.how == "interrupt":
                raise KeyboardInterrupt
        return pd.DataFrame({"start_s": [1.0], "end_s": [2.0], "angle_deg": [90.0]})


class Locked(Det):
    name = "locked"

    def __init__(self):
        super().__init__()
        self.lock = threading.Lock()
"""


def _cluster_run(tmp_path: Path, how: str, spec: str, *extra: str) -> subprocess.CompletedProcess:
    # Dask retries a task whose worker died on other workers (3 times by default): the
    # answer is the same, only slower, so the tests let it give up at the first death
    env = {**os.environ, "PLUG_HOW": how, "PYTHONPATH": str(tmp_path)}
    env["DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES"] = "0"
    return subprocess.run(
        [sys.executable, "-m", "turn_eval", "detect", str(tmp_path / "in"), *BASE]
        + ["--detector", spec, "--workers", "2", *extra, "--out", str(tmp_path / "d.csv")],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )


@pytest.fixture()
def worker_inputs(tmp_path: Path) -> Path:
    (tmp_path / "in").mkdir()
    np.savez(tmp_path / "in" / "good.npz", P01=_still())
    np.savez(tmp_path / "in" / "bad.npz", P01=_still(200))
    (tmp_path / "worker_plug.py").write_text(WORKER_PLUGIN)
    return tmp_path


def test_an_unpicklable_detector_on_workers_is_one_line(worker_inputs) -> None:
    proc = _cluster_run(worker_inputs, "", "worker_plug:Locked")
    line = _one_line_error(proc.returncode, proc.stderr)
    assert "detector 'locked' cannot be sent to the workers: it cannot be pickled" in line


def test_a_worker_that_dies_under_skip_bad_skips_that_file_and_lists_it(worker_inputs) -> None:
    proc = _cluster_run(worker_inputs, "kill", "worker_plug:Det", "--skip-bad")
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr and "KilledWorker" not in proc.stderr
    bad = str(worker_inputs / "in" / "bad.npz")
    assert f"skipped {bad}" in proc.stderr
    manifest = json.loads((worker_inputs / "d.manifest.json").read_text())
    assert [s["file"] for s in manifest["skipped"]] == [bad]
    assert pd.read_csv(worker_inputs / "d.csv").session.tolist() == ["good"]


def test_a_worker_that_dies_without_skip_bad_is_one_line_exit_2(worker_inputs) -> None:
    proc = _cluster_run(worker_inputs, "exit", "worker_plug:Det")
    line = _one_line_error(proc.returncode, proc.stderr)
    assert f"{worker_inputs / 'in' / 'bad.npz'}: the worker process died" in line
    assert not (worker_inputs / "d.csv").exists()
