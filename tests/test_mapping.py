"""The shared mapping over Dask (turn_eval.mapping), through ``turn-eval detect``: what a cluster
is sent (absolute paths, the client's sha256), what its set-up failures and Ctrl-C print."""

from __future__ import annotations

import glob
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import run_turn_eval as run
from test_detect import WALK_TURN_WALK, stream

from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.fileio import sha256_file
from turn_datasets.skeleton import H36M17
from turn_eval.detect.mapping import detect_files
from turn_eval.detect.rule import MinerRule
from turn_eval.mapping import Failure, files
from turn_eval.mapping.cluster import noting_interrupts

BASE = ["--layout", "h36m17", "--up-axis", "-y", "--fps", "30", "--min-turn-deg", "67.5"]
KW = {"detector": MinerRule(), "layout": H36M17, "up_axis": "-y", "fps_hz": 30.0}


def _camera(p_zup: np.ndarray) -> np.ndarray:
    return np.stack([p_zup[..., 0], -p_zup[..., 2], p_zup[..., 1]], axis=-1).astype(np.float32)


@pytest.fixture(scope="module")
def turn_stream() -> np.ndarray:
    return _camera(stream(WALK_TURN_WALK))


@pytest.fixture()
def scheduler():
    """A scheduler alone (no workers), in this process: its address."""
    from dask.distributed import LocalCluster

    cluster = LocalCluster(n_workers=0, dashboard_address=None, processes=True)
    try:
        yield cluster.scheduler_address
    finally:
        cluster.close()


def test_a_worker_in_another_folder_reads_our_files_not_its_own(
    tmp_path, turn_stream, scheduler, monkeypatch
) -> None:
    # The worker runs in another folder holding other files of the same names: sent relative
    # paths, it read those and the manifest recorded their sha256 as ours.
    ours, theirs = tmp_path / "client", tmp_path / "worker"
    ours.mkdir()
    theirs.mkdir()
    np.savez(ours / "home.npz", P01=turn_stream)
    np.savez(theirs / "home.npz", P01=turn_stream[:150])  # no turn in it
    worker = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_worker", scheduler, "--nthreads", "1"],
        cwd=theirs,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        monkeypatch.chdir(ours)
        serial = detect_files(["home.npz"], **KW)
        on_cluster = detect_files(["home.npz"], scheduler=scheduler, **KW)
    finally:
        worker.terminate()
        worker.wait(timeout=60)
    assert len(serial.detections) == 1
    assert on_cluster.detections.equals(serial.detections)
    assert on_cluster.inputs == serial.inputs
    assert on_cluster.inputs[0]["sha256"] == sha256_file(ours / "home.npz")
    assert on_cluster.inputs[0]["file"] == "home.npz"  # the path as given, in the manifest


class _FakeWorker:
    address = "tcp://10.0.0.7:40000"

    def log_event(self, topic, msg) -> None:
        pass


def _unused(path, *, sha256):
    raise AssertionError("a file the worker cannot vouch for must not be read")


def test_a_worker_without_the_file_or_with_another_copy_refuses(tmp_path, monkeypatch) -> None:
    import distributed

    monkeypatch.setattr(distributed, "get_worker", lambda: _FakeWorker())
    missing = str(tmp_path / "elsewhere.npz")
    # a task carries a run of files: (path, sha256, keyword arguments) each, one result each
    (got,) = files._on_worker(_unused, [(missing, "0" * 64, {})], None)
    assert isinstance(got, Failure) and got.path == missing
    assert got.message.startswith("not reachable from worker tcp://10.0.0.7:40000")
    other = tmp_path / "home.npz"
    other.write_bytes(b"the worker's own file")
    (got,) = files._on_worker(_unused, [(str(other), "a" * 64, {})], None)
    assert isinstance(got, Failure)
    assert f"sha256 {sha256_file(other)} there, {'a' * 64} here" in got.message


def test_files_are_hashed_here_and_an_unreadable_one_is_a_failure(tmp_path, turn_stream) -> None:
    np.savez(tmp_path / "home.npz", P01=turn_stream)
    got = files._hashes([str(tmp_path / "home.npz")], None)
    assert got == [sha256_file(tmp_path / "home.npz")]
    assert isinstance(files._hashes([str(tmp_path / "none.npz")], None)[0], Failure)


@pytest.mark.parametrize("scheme", ["tls", "ucx"])
def test_tls_and_ucx_schedulers_are_one_line(tmp_path, capsys, turn_stream, scheme) -> None:
    np.savez(tmp_path / "home.npz", P01=turn_stream)
    args = ["detect", tmp_path / "home.npz", *BASE, "--scheduler", f"{scheme}://127.0.0.1:9"]
    code, _, err = run([*args, "--out", tmp_path / "d.csv"], capsys)
    assert code == EXIT_BAD_INPUT and len(err.strip().splitlines()) == 1, err
    assert f"only tcp:// schedulers are supported, not {scheme}://" in err
    assert not (tmp_path / "d.csv").exists()


def test_a_scheduler_without_workers_times_out_in_one_line(
    tmp_path, capsys, turn_stream, scheduler, monkeypatch
) -> None:
    import turn_eval.mapping.cluster as cluster

    monkeypatch.setattr(cluster, "WORKER_WAIT_S", 1)
    np.savez(tmp_path / "home.npz", P01=turn_stream)
    args = ["detect", tmp_path / "home.npz", *BASE, "--scheduler", scheduler]
    code, _, err = run([*args, "--out", tmp_path / "d.csv"], capsys)
    assert code == EXIT_BAD_INPUT and len(err.strip().splitlines()) == 1, err
    assert f"no worker joined the Dask scheduler at {scheduler} within 1 s" in err


def _detect(tmp_path: Path, *extra: str, env: dict | None = None, preexec=None):
    return subprocess.run(
        [sys.executable, "-m", "turn_eval", "detect", str(tmp_path / "home.npz"), *BASE]
        + [*extra, "--out", str(tmp_path / "out" / "d.csv")],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, **(env or {})},
        preexec_fn=preexec,
    )


def test_an_unusable_dask_temporary_directory_is_one_line(tmp_path, turn_stream) -> None:
    np.savez(tmp_path / "home.npz", P01=turn_stream)
    (tmp_path / "a_file").write_text("")
    env = {"DASK_TEMPORARY_DIRECTORY": str(tmp_path / "a_file" / "dask")}
    proc = _detect(tmp_path, "--workers", "1", env=env)
    assert proc.returncode == EXIT_BAD_INPUT, proc.stderr
    assert proc.stderr.strip().splitlines() == [
        "turn-eval: error: cannot start a local Dask cluster of 1 workers: Not a directory: "
        f"{tmp_path / 'a_file' / 'dask'} (hint: a local Dask cluster needs a writable temporary "
        "folder (DASK_TEMPORARY_DIRECTORY, or TMPDIR) and a few hundred open files (ulimit -n))"
    ]
    assert not (tmp_path / "out").exists()


def test_too_few_open_files_is_one_line_before_anything_starts(tmp_path, turn_stream) -> None:
    import resource

    np.savez(tmp_path / "home.npz", P01=turn_stream)

    def ulimit_40() -> None:
        resource.setrlimit(resource.RLIMIT_NOFILE, (40, 40))

    proc = _detect(tmp_path, "--workers", "2", preexec=ulimit_40)
    assert proc.returncode == EXIT_BAD_INPUT, proc.stderr
    assert proc.stderr.strip().splitlines() == [
        "turn-eval: error: a local Dask cluster of 2 workers needs 320 open files, but this "
        "session allows 40 (ulimit -n) (hint: raise the limit (ulimit -n 320), or run without "
        "--workers)"
    ]
    # the serial run needs no cluster, and no more files
    proc = _detect(tmp_path, preexec=ulimit_40)
    assert proc.returncode == 0, proc.stderr


SLOW_DETECTOR = """
import os, time
import pandas as pd

class Slow:
    name = "slow"

    def detect(self, positions, fps_hz, layout):
        open(os.path.join(os.environ["MARK_DIR"], f"started-{os.getpid()}"), "w").close()
        time.sleep(60)
        return pd.DataFrame({"start_s": [], "end_s": [], "angle_deg": []})
"""


def _importing(process) -> bool:
    """A worker process has been running for half a second: Python is importing its modules."""
    children = [c for c in process.children() if "spawn_main" in " ".join(c.cmdline())]
    return any(time.time() - c.create_time() > 0.5 for c in children)


@pytest.mark.parametrize("moment", ["starting", "working"])
def test_ctrl_c_with_workers_is_one_line_exit_130_and_leaves_nothing(tmp_path, turn_stream, moment):
    # Ctrl-C at a terminal signals the whole foreground process group: the command and every
    # worker process. Workers still importing printed a traceback each (99 lines), and the
    # cluster interrupted in its start-up printed Dask's own at exit.
    import psutil

    (tmp_path / "slowdet.py").write_text(SLOW_DETECTOR)
    (tmp_path / "marks").mkdir()
    (tmp_path / "in").mkdir()
    for i in range(4):
        np.savez(tmp_path / "in" / f"s{i}.npz", P01=turn_stream)
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "MARK_DIR": str(tmp_path / "marks")}
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "turn_eval", "detect", str(tmp_path / "in"), *BASE]
        + ["--detector", "slowdet:Slow", "--workers", "2", "--out", str(out / "d.csv")],
        env=env,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, signalled as a terminal would
    )
    try:
        deadline = time.monotonic() + 240
        while not (
            _importing(psutil.Process(proc.pid))
            if moment == "starting"
            else len(glob.glob(str(tmp_path / "marks" / "started-*"))) >= 2
        ):
            assert time.monotonic() < deadline and proc.poll() is None
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines[-1] == "turn-eval: aborted" and len(lines) <= 2, err
    assert lines[0] in ("detecting on 2 local workers", "turn-eval: aborted"), err
    assert not out.exists()


def test_a_ctrl_c_that_something_swallows_is_still_noted() -> None:
    # A Dask call into its event loop can catch the KeyboardInterrupt of a Ctrl-C; the run
    # then heard only of its workers' deaths and reported a file that killed its worker
    # (exit 2). The Ctrl-C is noted as well as raised, and the handler put back after.
    pressed: list[int] = []
    before = signal.getsignal(signal.SIGINT)
    with noting_interrupts(pressed, then_raise=True):
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)  # the handler runs at the next bytecode, well within this
        assert pressed == [signal.SIGINT]
    assert signal.getsignal(signal.SIGINT) is before
    # while a local cluster starts: noted only (the caller stops once it can close it)
    with noting_interrupts(pressed, then_raise=False):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.2)
    assert pressed == [signal.SIGINT, signal.SIGINT]
    # ignored before (a job started in the background), ignored inside: neither noted nor
    # raised
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with noting_interrupts(pressed, then_raise=True):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)
    finally:
        signal.signal(signal.SIGINT, before)
    assert pressed == [signal.SIGINT, signal.SIGINT]


def test_runs_of_files_are_cut_into_about_equal_tasks_in_order() -> None:
    assert files._batches(list(range(10)), 4) == [[0, 1], [2, 3, 4], [5, 6], [7, 8, 9]]
    assert files._batches([3, 5, 8], 8) == [[3], [5], [8]]  # never an empty task
    assert files._batches([], 4) == []


KILLER = """
import os, signal

def size_unless_bad(path, *, sha256):
    if path.endswith("bad.bin"):
        os.kill(os.getpid(), signal.SIGKILL)
    return os.path.getsize(path)
"""


def test_a_task_of_several_files_whose_worker_dies_fails_only_the_file_that_killed_it(
    tmp_path, monkeypatch
) -> None:
    # one worker, one task for all four files: the worker dies on the third; each file is
    # then sent again alone, the bad one kills its worker again and alone, the rest are done
    import importlib

    (tmp_path / "killer.py").write_text(KILLER)
    monkeypatch.syspath_prepend(str(tmp_path))  # the spawned workers get this path too
    killer = importlib.import_module("killer")
    paths = []
    for name, size in (("a", 3), ("b", 5), ("bad", 7), ("c", 11)):
        paths.append(tmp_path / f"{name}.bin")
        paths[-1].write_bytes(b"x" * size)
    got = files.map_files(killer.size_unless_bad, paths, workers=1, tasks_per_worker=1)
    assert [g if isinstance(g, int) else g.died for g in got] == [3, 5, True, 11]
    assert got[2].path == str(paths[2])
