"""Nothing queued is lost: a server killed with SIGKILL while scoring scores everything
after a restart; a submission whose scoring fails is marked failed and the rest go on."""

from __future__ import annotations

import json
import signal
import time

import pytest

pytest.importorskip("fastapi", reason="needs the server extra (make venv installs it)")
httpx = pytest.importorskip("httpx")

from _server_support import (  # noqa: E402
    Served,
    alive,
    bearer,
    database,
    descendants,
    wait_scored,
    write_predictions,
    write_reference,
)
from conftest import run_turn_eval as run  # noqa: E402


def _statuses(root, capsys) -> dict[str, int]:
    code, out, err = run(["server", "list", root, "--format", "json"], capsys)
    assert code == 0, err
    team = json.loads(out)["teams"][0]
    return {k: team[k] for k in ("queued", "scoring", "scored", "failed")}


@pytest.mark.parametrize("db", ["sqlite", "postgresql"])
def test_kill_9_then_restart_scores_what_was_queued(db, tmp_path, capsys):
    ref = write_reference(tmp_path / "labels.csv")
    with database(db) as url:
        root = tmp_path / "challenge"
        # many resamples, one worker: the uploads are still queued when the server dies
        args = ["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "Restart"]
        args += ["--by", "cohort", "--by", "scenario", "--bootstrap", "4000"]
        args += [] if url is None else ["--db", url]
        assert run(args, capsys)[0] == 0
        token = run(["server", "add-team", root, "Team"], capsys)[1].strip()
        files = [
            write_predictions(tmp_path / f"p{i}.csv", ref, noise_deg=5.0 + 5 * i, seed=i)
            for i in range(5)
        ]
        served = Served(root, workers=1).start()
        ids = []
        with httpx.Client(timeout=60) as c:
            for path in files:
                r = c.post(
                    f"{served.url}/api/submissions",
                    headers=bearer(token),
                    files={"file": (path.name, path.read_bytes())},
                )
                assert r.status_code == 202, r.text
                ids.append(r.json()["id"])
        assert served.proc is not None
        workers = descendants(served.proc.pid)
        assert workers, "the server has no pool processes"
        served.stop(signal.SIGKILL)
        # the pool does not outlive its server
        deadline = time.monotonic() + 30
        while alive(workers) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not alive(workers)
        before = _statuses(root, capsys)
        assert before["queued"] + before["scoring"] >= 3, before
        # one upload vanishes while the server is down: its scoring fails, alone
        (root / "uploads" / f"{ids[-1]}.csv").unlink()
        served = Served(root, workers=2).start()
        try:
            with httpx.Client(timeout=60) as c:
                views = wait_scored(c, served.url, token, ids, timeout_s=300)
                assert [views[i]["status"] for i in ids] == ["scored"] * 4 + ["failed"]
                assert views[ids[-1]]["error"] == "the upload: predictions file not found"
                assert str(root) not in json.dumps(views)
                board = c.get(f"{served.url}/api/leaderboard")
                assert board.status_code == 200 and board.json()["rows"][0]["team"] == "Team"
        finally:
            served.stop()
        assert _statuses(root, capsys) == {"queued": 0, "scoring": 0, "scored": 4, "failed": 1}
