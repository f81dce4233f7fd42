"""What the server tests share: a reference with planted markers, predictions of known
quality, a data directory on SQLite or PostgreSQL, and a real ``turn-eval serve`` process.

PostgreSQL: the tests read a server URL from ``TURNBENCH_TEST_POSTGRES_URL`` (``.ci/run``
starts a throwaway cluster with ``.ci/postgres.sh`` and sets it) and make a fresh database
per data directory. Without the variable the PostgreSQL cases skip, except in CI
(``CI=true``), where that is a failure.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

#: Planted in the reference's columns that no --by names: no response may contain them.
MARKER = "ZQXMARKER7741"
MARKER_COLUMN = "SITE_ONLY_COLUMN_9"
N_CLIPS = 240
N_SUBJECTS = 12
POSTGRES_ENV = "TURNBENCH_TEST_POSTGRES_URL"


def write_reference(path: Path, *, seed: int = 11) -> pd.DataFrame:
    """A Turn-REMAP-like reference: 240 clips of 12 participants, with the markers planted."""
    rng = np.random.default_rng(seed)
    subject = np.array([f"P{i % N_SUBJECTS:02d}" for i in range(N_CLIPS)])
    ref = pd.DataFrame(
        {
            "clip_id": [f"clip{i:04d}" for i in range(N_CLIPS)],
            "subject": subject,
            "cohort": np.where([int(s[1:]) % 2 == 0 for s in subject], "PD", "HC"),
            "scenario": rng.choice(["scripted", "free-living"], N_CLIPS),
            "duration_s": rng.uniform(1.0, 4.0, N_CLIPS).round(2),
            "angle_deg": rng.uniform(40.0, 280.0, N_CLIPS).round(1),
            "notes": f"rater said {MARKER}",
            MARKER_COLUMN: f"{MARKER}-site",
        }
    )
    ref.to_csv(path, index=False)
    return ref


def write_predictions(path: Path, ref: pd.DataFrame, *, noise_deg: float, seed: int) -> Path:
    """Predictions: the reference angle plus Gaussian noise, clipped at 0."""
    rng = np.random.default_rng(seed)
    angle = (ref["angle_deg"].to_numpy() + rng.normal(0.0, noise_deg, len(ref))).clip(0.0)
    pd.DataFrame({"clip_id": ref["clip_id"], "angle_deg": angle.round(2)}).to_csv(path, index=False)
    return path


@contextlib.contextmanager
def database(kind: str) -> Iterator[str | None]:
    """None (SQLite in the data directory) or the URL of a new, empty PostgreSQL database,
    dropped afterwards."""
    if kind == "sqlite":
        yield None
        return
    admin = os.environ.get(POSTGRES_ENV)
    if not admin:
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI=true but {POSTGRES_ENV} is not set: the PostgreSQL tests must run")
        pytest.skip(f"set {POSTGRES_ENV} (.ci/postgres.sh start DIR prints one)")
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url

    name = f"turnbench_test_{secrets.token_hex(6)}"
    engine = create_engine(admin, isolation_level="AUTOCOMMIT")
    with engine.connect() as conn:
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    try:
        yield make_url(admin).set(database=name).render_as_string(hide_password=False)
    finally:
        with engine.connect() as conn:
            conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        engine.dispose()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Served:
    """A ``turn-eval serve`` child process on 127.0.0.1 and a free port."""

    def __init__(self, root: Path, *, workers: int = 2) -> None:
        self.root = root
        self.workers = workers
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.proc: subprocess.Popen | None = None
        self.log = root.parent / f"serve-{self.port}.log"

    def start(self, timeout_s: float = 60.0) -> Served:
        import httpx

        args = [sys.executable, "-m", "turn_eval", "serve", str(self.root)]
        args += ["--host", "127.0.0.1", "--port", str(self.port), "--workers", str(self.workers)]
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise AssertionError(f"serve exited {self.proc.returncode}: {self.log_text()}")
            with contextlib.suppress(httpx.TransportError):
                if httpx.get(self.url + "/api/leaderboard", timeout=5).status_code == 200:
                    return self
            time.sleep(0.2)
        raise AssertionError(f"serve did not answer in {timeout_s} s: {self.log_text()}")

    def log_text(self) -> str:
        return self.log.read_text(errors="replace") if self.log.exists() else ""

    def stop(self, sig: int = signal.SIGTERM) -> None:
        if self.proc is None or self.proc.poll() is not None:
            return
        self.proc.send_signal(sig)
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=30)


def descendants(pid: int) -> set[int]:
    """The process ids below ``pid`` (its pool's fork server and workers), from ps."""
    out = subprocess.run(
        ["ps", "-e", "-o", "pid=,ppid="], capture_output=True, text=True, check=True
    ).stdout
    children: dict[int, list[int]] = {}
    for line in out.splitlines():
        child, parent = (int(x) for x in line.split())
        children.setdefault(parent, []).append(child)
    found: set[int] = set()
    todo = [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def alive(pids: set[int]) -> set[int]:
    """Those of ``pids`` still running (not zombies)."""
    out = subprocess.run(
        ["ps", "-e", "-o", "pid=,stat="], capture_output=True, text=True, check=True
    ).stdout
    running = {int(p) for p, stat in (line.split() for line in out.splitlines()) if "Z" not in stat}
    return pids & running


def wait_scored(client, url: str, token: str, ids: list[str], timeout_s: float = 120.0) -> dict:
    """Poll until every id is scored or failed; their views by id."""
    deadline = time.monotonic() + timeout_s
    views: dict[str, dict] = {}
    while time.monotonic() < deadline:
        for sid in ids:
            if sid in views:
                continue
            r = client.get(f"{url}/api/submissions/{sid}", headers=bearer(token))
            assert r.status_code == 200, r.text
            if r.json()["status"] in ("scored", "failed"):
                views[sid] = r.json()
        if len(views) == len(ids):
            return views
        time.sleep(0.3)
    raise AssertionError(f"not scored in {timeout_s} s: {sorted(set(ids) - set(views))}")


def bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}
