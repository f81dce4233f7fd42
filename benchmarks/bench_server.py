"""Load a real ``turn-eval serve``: 200 uploads of a 1,400-row file from 10 teams at once.

The server (a child process, 127.0.0.1, a free port, 2 scoring workers, SQLite) holds a
Turn-REMAP-sized reference (1,400 clips of 24 participants, grouped by cohort and scenario,
1000 bootstrap resamples). Ten teams, each with a daily and total quota of 20, send 20
uploads each from 10 client threads (200 at once, in all), then one more each, which must be
refused (429). Checked: every one of the 200 is accepted and scored, none lost, and exactly
10 extra uploads refused.

Measured: each upload's latency (request to ``202``), its median and 95th percentile, and
the scoring throughput (from the first upload to the last submission scored). The baseline
is ``turn-eval score`` on the same file and reference in this process (the command's own
code, ``run_group``; its best of three wall times, with the same resamples and groupings).
Ratios: median latency / score time (the ratio the table reports; target 1: a team's upload
is answered faster than scoring it would take, since the scoring is queued), p95 / score
time, and wall time per scored submission / score time (the server scores each submission
on the public and the private split, together the same clips as one ``score``; with two
workers on two cores about 0.5 is the ideal). All three go to stderr and into ``what``.

Run: ``.venv/bin/python benchmarks/bench_server.py`` (``make bench`` runs every benchmark).
"""

from __future__ import annotations

import contextlib
import io
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd

REQUIRES = ("fastapi", "uvicorn", "sqlalchemy", "httpx")

N_CLIPS = 1400
N_TEAMS = 10
PER_TEAM = 20
N_RESAMPLES = 1000
BY = ("cohort", "scenario")


def _write_inputs(folder: Path) -> tuple[Path, Path]:
    rng = np.random.default_rng(23)
    subjects = np.array([f"P{i:02d}" for i in range(1, 25)])
    subject = subjects[rng.integers(0, 24, N_CLIPS)]
    angle = rng.uniform(45.0, 300.0, N_CLIPS).round(2)
    reference = pd.DataFrame(
        {
            "clip_id": [f"clip{i:05d}" for i in range(N_CLIPS)],
            "subject": subject,
            "cohort": np.where(np.isin(subject, subjects[:12]), "PD", "HC"),
            "scenario": rng.choice(["scripted", "clinical", "free-living"], N_CLIPS),
            "duration_s": rng.uniform(0.8, 6.0, N_CLIPS).round(3),
            "angle_deg": angle,
        }
    )
    predictions = pd.DataFrame(
        {"clip_id": reference["clip_id"], "angle_deg": np.abs(angle + rng.normal(0, 25, N_CLIPS))}
    )
    ref_path, pred_path = folder / "reference.csv", folder / "predictions.csv"
    reference.to_csv(ref_path, index=False)
    predictions.round(2).to_csv(pred_path, index=False)
    return ref_path, pred_path


def _cli(args: list[str]) -> str:
    from turn_datasets.cli.common import run_group
    from turn_eval.cli import cli

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = run_group(cli, "turn-eval", [str(a) for a in args])
    if code != 0:
        raise RuntimeError(f"turn-eval {args[0]}: exit {code}: {err.getvalue()}")
    return out.getvalue()


def _score_seconds(ref_path: Path, pred_path: Path) -> float:
    args = ["score", pred_path, "-r", ref_path, "--format", "json"]
    args += [f"--by={b}" for b in BY] + ["--bootstrap", str(N_RESAMPLES)]
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        _cli(args)
        best = min(best, time.perf_counter() - t0)
    return best


def _start(root: Path, port: int) -> subprocess.Popen:
    import httpx

    args = [sys.executable, "-m", "turn_eval", "serve", str(root), "--port", str(port)]
    proc = subprocess.Popen([*args, "--workers", "2"], stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        with contextlib.suppress(httpx.TransportError):
            if httpx.get(f"http://127.0.0.1:{port}/api/leaderboard", timeout=5).status_code == 200:
                return proc
        time.sleep(0.2)
    proc.kill()
    raise RuntimeError("the server did not start in 120 s")


def _load(url: str, tokens: list[str], body: bytes) -> tuple[list[float], list[str], float]:
    """Every team's uploads at once, one client thread per team; latencies, ids, start."""
    import httpx

    latencies: list[float] = []
    ids: list[str] = []
    errors: list[str] = []
    lock = threading.Lock()
    barrier = threading.Barrier(len(tokens))

    def team(token: str) -> None:
        headers = {"Authorization": f"Bearer {token}"}
        with httpx.Client(timeout=300) as c:
            barrier.wait()
            for _ in range(PER_TEAM):
                t0 = time.perf_counter()
                r = c.post(
                    f"{url}/api/submissions", headers=headers, files={"file": ("p.csv", body)}
                )
                dt = time.perf_counter() - t0
                with lock:
                    if r.status_code == 202:
                        latencies.append(dt)
                        ids.append(r.json()["id"])
                    else:
                        errors.append(f"{r.status_code} {r.text[:100]}")
            extra = c.post(
                f"{url}/api/submissions", headers=headers, files={"file": ("p.csv", body)}
            )
            if extra.status_code != 429:
                with lock:
                    errors.append(f"the quota let a 21st upload in: {extra.status_code}")

    threads = [threading.Thread(target=team, args=(t,)) for t in tokens]
    start = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if errors:
        raise RuntimeError(f"{len(errors)} uploads went wrong: {errors[:3]}")
    return latencies, ids, start


def _wait_scored(root: Path, n: int, timeout_s: float = 1800) -> None:
    import json

    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        teams = json.loads(_cli(["server", "list", root, "--format", "json"]))["teams"]
        scored = sum(t["scored"] for t in teams)
        failed = sum(t["failed"] for t in teams)
        if failed:
            raise RuntimeError(f"{failed} submissions failed")
        if scored == n:
            if any(t["submissions"] != PER_TEAM for t in teams):
                raise RuntimeError(f"quota not exact: {[t['submissions'] for t in teams]}")
            return
        time.sleep(0.2)
    raise RuntimeError(f"not all {n} submissions were scored in {timeout_s} s")


def run() -> dict:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from _server_support import free_port

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        ref_path, pred_path = _write_inputs(folder)
        score_s = _score_seconds(ref_path, pred_path)
        root = folder / "challenge"
        init = ["server", "init", root, "-r", ref_path, "--name", "bench"]
        init += [f"--by={b}" for b in BY] + ["--bootstrap", str(N_RESAMPLES)]
        init += ["--daily-quota", str(PER_TEAM), "--total-quota", str(PER_TEAM)]
        _cli(init)
        tokens = [_cli(["server", "add-team", root, f"team {i}"]).strip() for i in range(N_TEAMS)]
        port = free_port()
        proc = _start(root, port)
        try:
            latencies, ids, start = _load(
                f"http://127.0.0.1:{port}", tokens, pred_path.read_bytes()
            )
            _wait_scored(root, N_TEAMS * PER_TEAM)
            wall = time.perf_counter() - start
        finally:
            proc.terminate()
            proc.wait(timeout=60)
    n = len(ids)
    median = statistics.median(latencies)
    p95 = float(np.percentile(latencies, 95))
    per_submission = wall / n
    print(
        f"server: {n} scored, none lost; latency median {median:.3f} s, p95 {p95:.3f} s; "
        f"{n / wall:.2f} scored/s; score {score_s:.3f} s; ratios: median "
        f"{median / score_s:.2f}, p95 {p95 / score_s:.2f}, per submission "
        f"{per_submission / score_s:.2f}",
        file=sys.stderr,
    )
    return {
        "what": (
            f"upload latency, median / score (p95 {p95 / score_s:.2f}x; "
            f"throughput {per_submission / score_s:.2f}x score per submission)"
        ),
        "size": f"{n} uploads of {N_CLIPS} rows, {N_TEAMS} teams at once",
        "baseline": "turn-eval score, same file, in process",
        "seconds": median,
        "ratio": median / score_s,
        "target": "<= 1",
    }


if __name__ == "__main__":
    print(run())
