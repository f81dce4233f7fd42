"""``--workers N`` starts N local processes of about 200 MB each: bounded by
``limits.MAX_LOCAL_WORKERS`` and by the machine's free memory, refused in one line before
any process starts (4096 were accepted: some 800 GB)."""

from __future__ import annotations

import numpy as np
from conftest import run_turn_eval as run
from test_reading_bounds import walking

from turn_datasets import limits, machine
from turn_datasets.cli.common import EXIT_BAD_INPUT

DETECT = ["--layout", "h36m17", "--up-axis", "z", "--fps", "30"]


def test_more_local_workers_than_the_bound_are_refused(tmp_path, capsys) -> None:
    np.savez(tmp_path / "home.npz", P01=walking())
    n = limits.MAX_LOCAL_WORKERS + 1
    code, _, err = run(
        ["detect", tmp_path, *DETECT, "--workers", n, "--out", tmp_path / "d.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT and "Traceback" not in err
    assert "257" in err and "256" in err
    assert not (tmp_path / "d.csv").exists()


def test_local_workers_beyond_the_free_memory_are_refused_before_any_starts(
    tmp_path, capsys, monkeypatch
) -> None:
    np.savez(tmp_path / "home.npz", P01=walking())
    monkeypatch.setattr(machine, "available_memory_bytes", lambda: 1_000_000_000)
    code, _, err = run(
        ["detect", tmp_path, *DETECT, "--workers", 8, "--out", tmp_path / "d.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT, err
    lines = [x for x in err.strip().splitlines() if not x.startswith("detecting")]
    # 8 x 200 MB = 1.6 GB > 1.0 GB; at most 1e9 // 2e8 - 1 = 4 leave room for the files
    assert lines == [
        "turn-eval: error: --workers 8 needs about 1.6 GB before reading any file (0.2 GB per "
        "worker process) and this machine has 1.0 GB free (hint: use at most 4 workers)"
    ]
    assert "distributed" not in "".join(lines)
