"""The scoring server end to end: a real ``turn-eval serve`` on 127.0.0.1, driven over HTTP
(httpx), on SQLite and on PostgreSQL.

Expected scores are worked out here from the files with numpy (nearest-45° bins, absolute
errors) on the clips the recorded split makes public or private, not by the server's code.
"""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("fastapi", reason="needs the server extra (make venv installs it)")
httpx = pytest.importorskip("httpx")

from _server_support import (  # noqa: E402
    MARKER,
    MARKER_COLUMN,
    Served,
    bearer,
    database,
    wait_scored,
    write_predictions,
    write_reference,
)
from conftest import run_turn_eval as run  # noqa: E402

DBS = ["sqlite", "postgresql"]


def _bins(x: np.ndarray) -> np.ndarray:
    return 45.0 * np.floor(np.asarray(x) / 45.0 + 0.5)


def _expected(ref: pd.DataFrame, predictions: Path, split: pd.DataFrame, side: str) -> dict:
    pred = pd.read_csv(predictions).set_index("clip_id")["angle_deg"]
    clips = set(split.loc[split["split"] == side, "clip_id"])
    on = ref[ref["clip_id"].isin(clips)]
    p = pred.loc[on["clip_id"]].to_numpy()
    r = on["angle_deg"].to_numpy()
    return {
        "n": len(on),
        "accuracy": float(np.mean(_bins(p) == _bins(r))),
        "mae_deg": float(np.mean(np.abs(p - r))),
    }


@pytest.fixture(params=DBS)
def challenge(request, tmp_path, capsys):
    """A data directory on each database, with a reference, three teams' files and tokens."""
    ref_path = tmp_path / "labels.csv"
    ref = write_reference(ref_path)
    with database(request.param) as url:
        root = tmp_path / "challenge"
        args = ["server", "init", root, "-r", ref_path, "--name", "Turn test", "--by", "cohort"]
        args += ["--daily-quota", "5", "--total-quota", "7", "--bootstrap", "200", "--seed", "3"]
        args += ["--max-upload-mb", "0.05"]
        if url is not None:
            args += ["--db", url]
        code, out, err = run(args, capsys)
        assert code == 0, err
        yield {"root": root, "ref": ref, "ref_path": ref_path, "tmp": tmp_path, "db": url}


def _team(root: Path, name: str, capsys) -> str:
    code, out, err = run(["server", "add-team", root, name], capsys)
    assert code == 0, err
    token = out.strip()
    assert "\n" not in token and len(token) > 30
    return token


def test_whole_flow(challenge, capsys):
    root, ref, tmp = challenge["root"], challenge["ref"], challenge["tmp"]
    good = write_predictions(tmp / "good.csv", ref, noise_deg=6.0, seed=1)
    poor = write_predictions(tmp / "poor.csv", ref, noise_deg=20.0, seed=2)
    # C: B's file with one clip 45° off, a difference no bootstrap can call significant
    near = tmp / "near.csv"
    frame = pd.read_csv(poor)
    frame.loc[0, "angle_deg"] += 45.0
    frame.to_csv(near, index=False)
    constant = tmp / "constant90.csv"
    pd.DataFrame({"clip_id": ref["clip_id"], "angle_deg": 90.0}).to_csv(constant, index=False)
    token_a, token_b = _team(root, "Team A", capsys), _team(root, "Team B", capsys)
    token_c = _team(root, "Team C", capsys)
    code, out, err = run(["server", "add-baseline", root, "constant 90", constant], capsys)
    assert code == 0, err
    split = pd.read_csv(root / "private" / "split.csv", dtype=str)

    bodies: list[str] = []  # every response of the flow, searched for the marker at the end

    def keep(r):
        bodies.append(r.text + json.dumps(dict(r.headers)))
        return r

    served = Served(root).start()
    try:
        with httpx.Client(timeout=60) as c:
            url = served.url
            # a malformed upload: 422 with turn-eval score's own line, and nothing counted
            # (every clip given, one angle not a number: the one problem, said alike)
            bad = tmp / "bad.csv"
            rows = pd.read_csv(good).astype({"angle_deg": object})
            rows.loc[1, "angle_deg"] = "abc"
            rows.to_csv(bad, index=False)
            r = keep(
                c.post(
                    f"{url}/api/submissions",
                    headers=bearer(token_a),
                    files={"file": ("bad.csv", bad.read_bytes(), "text/csv")},
                )
            )
            assert r.status_code == 422
            code, _, err = _score_cli(tmp, "bad.csv", capsys)
            assert code == 2
            assert err.strip() == f"turn-eval: error: {r.json()['detail']}"
            assert r.json()["detail"].startswith("bad.csv:3: ")
            # missing clips: the count, never the reference's ids
            part = tmp / "part.csv"
            pd.read_csv(good).iloc[:10].to_csv(part, index=False)
            r = keep(
                c.post(
                    f"{url}/api/submissions",
                    headers=bearer(token_a),
                    files={"file": ("part.csv", part.read_bytes())},
                )
            )
            assert r.status_code == 422 and "230 of the reference's 240" in r.json()["detail"]
            assert "clip0239" not in r.text
            # no token, a wrong token, a baseline's non-token
            r = keep(c.post(f"{url}/api/submissions", files={"file": ("g.csv", good.read_bytes())}))
            assert r.status_code == 401
            wrong = token_a[:-2] + ("xy" if not token_a.endswith("xy") else "zz")
            r = keep(
                c.post(
                    f"{url}/api/submissions",
                    headers=bearer(wrong),
                    files={"file": ("g.csv", good.read_bytes())},
                )
            )
            assert r.status_code == 401
            # over the 0.05 MiB cap: 413, while streaming (no Content-Length to go by)
            big = b"clip_id,angle_deg\n" + b"x,1\n" * 20_000

            def chunks():
                boundary = b"--tb"
                yield (
                    boundary
                    + b'\r\nContent-Disposition: form-data; name="file"; filename="b.csv"\r\n\r\n'
                )
                for i in range(0, len(big), 4096):
                    yield big[i : i + 4096]
                yield b"\r\n" + boundary + b"--\r\n"

            r = keep(
                c.post(
                    f"{url}/api/submissions",
                    content=chunks(),
                    headers={**bearer(token_a), "Content-Type": "multipart/form-data; boundary=tb"},
                )
            )
            assert r.status_code == 413
            # ... and before reading, when the request announces its size
            r = keep(
                c.post(
                    f"{url}/api/submissions",
                    headers=bearer(token_a),
                    files={"file": ("b.csv", big)},
                )
            )
            assert r.status_code == 413 and r.json()["detail"] == (
                "the upload is larger than 52428 bytes"
            )
            assert not any((root / "incoming").iterdir())
            # two good uploads, queued at once
            ids = {}
            for name, path, token in (
                ("a", good, token_a),
                ("b", poor, token_b),
                ("c", near, token_c),
            ):
                r = keep(
                    c.post(
                        f"{url}/api/submissions",
                        headers=bearer(token),
                        files={"file": (f"../../{name}.csv", path.read_bytes())},
                    )
                )
                assert r.status_code == 202, r.text
                assert r.json()["status"] == "queued"
                ids[name] = r.json()["id"]
            # uploads are kept under their id alone, never the sender's name
            assert sorted(p.name for p in (root / "uploads").iterdir()) == sorted(
                [f"{i}.csv" for i in ids.values()] + [_baseline_file(root)]
            )
            assert not any((root / "incoming").iterdir())
            view_a = wait_scored(c, url, token_a, [ids["a"]])[ids["a"]]
            wait_scored(c, url, token_b, [ids["b"]])
            wait_scored(c, url, token_c, [ids["c"]])
            keep(c.get(f"{url}/api/submissions/{ids['a']}", headers=bearer(token_a)))
            assert view_a["status"] == "scored" and "private" not in view_a
            want = _expected(ref, good, split, "public")
            got = view_a["public"]
            assert got["n"] == want["n"]
            assert got["accuracy"] == pytest.approx(want["accuracy"], abs=1e-12)
            assert got["mae_deg"] == pytest.approx(want["mae_deg"], rel=1e-9)
            lo, hi = got["ci95"]["accuracy"]
            assert lo <= got["accuracy"] <= hi
            assert set(got["by"]) == {"cohort"} and set(got["by"]["cohort"]["groups"]) == {
                "HC",
                "PD",
            }
            # per-object permission: B cannot see A's submission or its receipt
            for path in (f"/api/submissions/{ids['a']}", f"/api/receipts/{ids['a']}"):
                r = keep(c.get(url + path, headers=bearer(token_b)))
                assert r.status_code == 404
                assert ids["a"] not in r.text
            r = keep(c.get(f"{url}/api/submissions/{ids['a']}"))
            assert r.status_code == 401
            # each team's list holds its own submissions alone
            mine = keep(c.get(f"{url}/api/submissions", headers=bearer(token_b))).json()
            assert mine["team"] == "Team B"
            assert [v["id"] for v in mine["submissions"]] == [ids["b"]]
            # the receipt verifies; a changed one does not
            r = keep(c.get(f"{url}/api/receipts/{ids['a']}", headers=bearer(token_a)))
            assert r.status_code == 200
            receipt = r.json()
            assert receipt["sha256"] == view_a["sha256"]
            path = tmp / "receipt.json"
            path.write_text(json.dumps(receipt))
            assert run(["server", "verify-receipt", root, path], capsys)[0] == 0
            receipt["public_scores"]["accuracy"] = 0.99
            path.write_text(json.dumps(receipt))
            code, _, err = run(["server", "verify-receipt", root, path], capsys)
            assert code == 3 and "does not match" in err
            # the board: A, then B and C sharing a rank, then the badged constant
            board = keep(c.get(f"{url}/api/leaderboard")).json()
            teams = [row["team"] for row in board["rows"]]
            assert teams[0] == "Team A" and set(teams[1:3]) == {"Team B", "Team C"}
            assert teams[3] == "constant 90"
            assert [row["rank"] for row in board["rows"]] == [1, 2, 2, 4]
            assert board["rows"][2]["p_value_vs_above"] > 0.5
            assert [row["baseline"] for row in board["rows"]] == [False, False, False, True]
            assert all("private" not in row for row in board["rows"])
            page = keep(c.get(f"{url}/")).text
            assert "Team A" in page and ">baseline<" in page
            # nothing of the data directory is reachable by URL
            for path in (
                "/private/reference.csv",
                "/reference.csv",
                "/challenge.json",
                "/labels.csv",
                f"/uploads/{ids['b']}.csv",
                "/static/reference.csv",
                "/api/../private/reference.csv",
                "/docs",
                "/openapi.json",
                "/private/secret",
                "/turnbench.db",
            ):
                r = keep(c.get(url + path))
                assert r.status_code == 404, path
            # closing the phase reveals the private scores, and ranks on them
            assert run(["server", "close-phase", root], capsys)[0] == 0
            board = keep(c.get(f"{url}/api/leaderboard")).json()
            assert board["phase"] == "closed" and board["ranked_on"] == "private"
            row_a = next(row for row in board["rows"] if row["team"] == "Team A")
            want = _expected(ref, good, split, "private")
            assert row_a["private"]["n"] == want["n"]
            assert row_a["private"]["accuracy"] == pytest.approx(want["accuracy"], abs=1e-12)
            view = keep(c.get(f"{url}/api/submissions/{ids['a']}", headers=bearer(token_a))).json()
            assert view["private"]["mae_deg"] == pytest.approx(want["mae_deg"], rel=1e-9)
            keep(c.get(f"{url}/"))
    finally:
        served.stop()
    # nor the columns --by did not name: participants (P00 to P11), scenarios, their names
    hidden = (
        MARKER,
        MARKER_COLUMN,
        "notes",
        "P0",
        "P1",
        "scripted",
        "free-living",
        "scenario",
        "subject",
        "labels.csv",
    )
    leaked = [b for b in bodies if any(word in b for word in hidden)]
    assert not leaked, leaked[0][:300]
    assert "ZQX" not in served.log_text()


def _baseline_file(root: Path) -> str:
    con = sqlite3.connect(root / "turnbench.db") if (root / "turnbench.db").exists() else None
    if con is None:
        from sqlalchemy import create_engine, text

        url = json.loads((root / "challenge.json").read_text())["database"]
        engine = create_engine(url)
        with engine.connect() as conn:
            sid = conn.execute(
                text(
                    "select s.id from submissions s join teams t on t.id = s.team_id "
                    "where t.is_baseline"
                )
            ).scalar_one()
        engine.dispose()
        return f"{sid}.csv"
    (sid,) = con.execute(
        "select s.id from submissions s join teams t on t.id = s.team_id where t.is_baseline"
    ).fetchone()
    con.close()
    return f"{sid}.csv"


def _score_cli(tmp: Path, name: str, capsys):
    """``turn-eval score NAME -r reference.csv`` from the folder that holds both, as a
    submitter would run it (so the messages name the files as the server does)."""
    import os

    reference = tmp / "reference.csv"
    if not reference.exists():
        reference.write_bytes((tmp / "labels.csv").read_bytes())
    cwd = os.getcwd()
    os.chdir(tmp)
    try:
        return run(["score", name, "-r", "reference.csv"], capsys)
    finally:
        os.chdir(cwd)
