"""Quotas under concurrency, on SQLite and PostgreSQL, over HTTP to a real server.

12 simultaneous uploads of one team with a daily quota of 5 must take exactly 5 (the count
and the insert are one transaction); refused uploads take none; the daily count starts again
at the next UTC day (here: the team's submissions moved to yesterday in the database), and
the total quota still holds.
"""

from __future__ import annotations

import threading
import time

import pytest

pytest.importorskip("fastapi", reason="needs the server extra (make venv installs it)")
httpx = pytest.importorskip("httpx")

from _server_support import (  # noqa: E402
    Served,
    bearer,
    database,
    write_predictions,
    write_reference,
)
from conftest import run_turn_eval as run  # noqa: E402


@pytest.mark.parametrize("db", ["sqlite", "postgresql"])
def test_twelve_at_once_take_exactly_five(db, tmp_path, capsys):
    ref = write_reference(tmp_path / "labels.csv")
    good = write_predictions(tmp_path / "good.csv", ref, noise_deg=10.0, seed=4).read_bytes()
    with database(db) as url:
        root = tmp_path / "challenge"
        args = ["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "Quota"]
        args += ["--daily-quota", "5", "--total-quota", "8", "--bootstrap", "50"]
        args += [] if url is None else ["--db", url]
        assert run(args, capsys)[0] == 0
        code, token, _ = run(["server", "add-team", root, "Racers"], capsys)
        token = token.strip()
        code, other, _ = run(["server", "add-team", root, "Others"], capsys)
        other = other.strip()
        served = Served(root, workers=1).start()
        try:
            with httpx.Client(timeout=120) as c:
                post = f"{served.url}/api/submissions"
                # refused uploads count for nothing
                for body in (b"clip_id,angle_deg\nclip0000,-5\n", b"no,columns\n"):
                    r = c.post(post, headers=bearer(token), files={"file": ("x.csv", body)})
                    assert r.status_code == 422
                barrier = threading.Barrier(12)
                codes: list[int] = []
                lock = threading.Lock()

                def upload() -> None:
                    with httpx.Client(timeout=120) as own:
                        barrier.wait()
                        r = own.post(post, headers=bearer(token), files={"file": ("g.csv", good)})
                    with lock:
                        codes.append(r.status_code)

                threads = [threading.Thread(target=upload) for _ in range(12)]
                for t in threads:
                    t.start()
                for t in threads:
                    t.join()
                assert sorted(codes) == [202] * 5 + [429] * 7
                r = c.post(post, headers=bearer(token), files={"file": ("g.csv", good)})
                assert r.status_code == 429 and "daily quota of 5" in r.json()["detail"]
                # another team's quota is its own
                r = c.post(post, headers=bearer(other), files={"file": ("g.csv", good)})
                assert r.status_code == 202
                # the next UTC day: yesterday's five no longer count against today's five
                _move_to_yesterday(root, url, team="Racers")
                accepted = [
                    c.post(post, headers=bearer(token), files={"file": ("g.csv", good)}).status_code
                    for _ in range(4)
                ]
                # ... but the total of 8 does: 5 yesterday + 3 today
                assert accepted == [202, 202, 202, 429]
                r = c.post(post, headers=bearer(token), files={"file": ("g.csv", good)})
                assert "total quota of 8" in r.json()["detail"]
        finally:
            served.stop()
        code, out, _ = run(["server", "list", root, "--format", "json"], capsys)
        teams = {t["team"]: t for t in __import__("json").loads(out)["teams"]}
        assert teams["Racers"]["submissions"] == 8 and teams["Others"]["submissions"] == 1
        assert len(list((root / "uploads").iterdir())) == 9


def _move_to_yesterday(root, url, *, team: str) -> None:
    from sqlalchemy import create_engine, text

    engine = create_engine(url or f"sqlite:///{root / 'turnbench.db'}")
    with engine.begin() as conn:
        conn.execute(
            text(
                "update submissions set created = created - 86400 where team_id = "
                "(select id from teams where name = :team)"
            ),
            {"team": team},
        )
    engine.dispose()
    time.sleep(0.1)
