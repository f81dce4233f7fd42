"""The scoring server's parts, each against values worked out here: the split, receipts
(HMAC by RFC 2104's formula), gated ranks, the worker pool's crash handling, the command
line's refusals, and that the core never imports the server's packages."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _server_support import write_predictions, write_reference
from conftest import run_turn_eval as run

from turn_eval.server.ranking import gated_ranks
from turn_eval.server.receipts import RECEIPT_FIELDS, sign_receipt, verify_receipt
from turn_eval.server.split import draw_split


def init_challenge(tmp_path: Path, capsys) -> tuple[pd.DataFrame, Path]:
    """A challenge folder made by ``server init`` from a written reference: (reference, root)."""
    ref = write_reference(tmp_path / "labels.csv")
    root = tmp_path / "c"
    assert (
        run(["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "x"], capsys)[0] == 0
    )
    return ref, root


SERVER_PACKAGES = (
    "fastapi",
    "uvicorn",
    "httptools",
    "uvloop",
    "sqlalchemy",
    "jinja2",
    "python_multipart",
    "starlette",
)


# --- the split ------------------------------------------------------------------------------
def test_split_by_participant_is_the_seeded_permutation():
    ref = pd.DataFrame(
        {
            "clip_id": [f"c{i}" for i in range(12)],
            "subject": ["S10", "S2", "S1", "S3"] * 3,
        }
    )
    split = draw_split(ref, private_fraction=0.5, seed=7)
    # by hand: units in natural order S1, S2, S3, S10; the first two of the permutation
    names = ["S1", "S2", "S3", "S10"]
    order = np.random.default_rng(7).permutation(4)
    private = {names[i] for i in order[:2]}
    want = ["private" if s in private else "public" for s in ref["subject"]]
    assert split.table["split"].tolist() == want
    assert split.unit == "subject" and (split.n_units, split.n_units_private) == (4, 2)
    # no participant on both sides
    both = split.table.assign(subject=ref["subject"]).groupby("subject")["split"].nunique()
    assert (both == 1).all()
    # the same seed, the same split; another seed may differ
    again = draw_split(ref, private_fraction=0.5, seed=7)
    assert again.table.equals(split.table)


def test_split_by_clip_without_subjects_and_bounds():
    ref = pd.DataFrame({"clip_id": [f"c{i}" for i in range(10)], "subject": [""] * 10})
    split = draw_split(ref, private_fraction=0.3, seed=0)
    assert split.unit == "clip_id" and int(split.mask("private").sum()) == 3
    one = pd.DataFrame({"clip_id": ["a"]})
    from turn_datasets.errors import TurnbenchError

    with pytest.raises(TurnbenchError, match="two or more"):
        draw_split(one, private_fraction=0.5, seed=0)
    # a fraction that rounds to nothing still keeps one unit private (and one public)
    tiny = draw_split(ref, private_fraction=0.01, seed=0)
    assert int(tiny.mask("private").sum()) == 1


# --- receipts -------------------------------------------------------------------------------
def _rfc2104(key: bytes, message: bytes) -> str:
    """HMAC-SHA256 by the RFC's formula, without the hmac module."""
    block = 64
    key = key.ljust(block, b"\0")
    inner = hashlib.sha256(bytes(k ^ 0x36 for k in key) + message).digest()
    return hashlib.sha256(bytes(k ^ 0x5C for k in key) + inner).hexdigest()


def test_receipt_signature_is_hmac_sha256_of_the_canonical_json():
    secret = bytes(range(32))
    payload = {
        "submission": "ab12",
        "team": "Équipe",
        "sha256": "0" * 64,
        "reference_version": "1" * 64,
        "turnbench_version": "0.1.0",
        "public_scores": {"n": 3, "accuracy": 0.5, "mae_deg": 12.25},
    }
    receipt = sign_receipt(secret, payload)
    canonical = (
        '{"public_scores":{"accuracy":0.5,"mae_deg":12.25,"n":3},'
        '"reference_version":"' + "1" * 64 + '","sha256":"' + "0" * 64 + '",'
        '"submission":"ab12","team":"Équipe","turnbench_version":"0.1.0"}'
    ).encode()
    assert receipt["signature"] == _rfc2104(secret, canonical)
    assert verify_receipt(secret, receipt) == (True, "the signature matches")
    for field in RECEIPT_FIELDS:
        changed = json.loads(json.dumps(receipt))
        changed[field] = "x" if field != "public_scores" else {"accuracy": 1.0}
        ok, why = verify_receipt(secret, changed)
        assert not ok and "does not match" in why
    assert not verify_receipt(b"another secret", receipt)[0]
    assert (
        "lacks team" in verify_receipt(secret, {k: v for k, v in receipt.items() if k != "team"})[1]
    )
    assert "no receipt is signed with" in verify_receipt(secret, {**receipt, "extra": 1})[1]


# --- ranks ----------------------------------------------------------------------------------
def test_ranks_are_shared_unless_the_paired_bootstrap_separates_them():
    rng = np.random.default_rng(0)
    ref = rng.uniform(45, 270, 400)
    good = ref + rng.normal(0, 5, 400)
    same = good.copy()  # identical predictions: p = 1 exactly (module docstring of compare)
    bad = ref + rng.normal(0, 60, 400)
    entries = [good, same, bad]

    def arrays(i):
        return {
            "pred_deg": entries[i],
            "pred_speed_deg_s": None,
            "ref_deg": ref,
            "ref_duration_s": None,
        }

    ranks = gated_ranks(3, arrays, alpha=0.05, n_resamples=500, seed=0)
    assert [r.rank for r in ranks] == [1, 1, 3]
    assert ranks[0].p_value is None and ranks[1].p_value == 1.0
    # accuracy about 0.9 against about 0.3 on 400 clips: p at its floor, 1 / (500 + 1)
    assert ranks[2].p_value == pytest.approx(1 / 501)


# --- the worker pool ------------------------------------------------------------------------
def crashing_job(root: str, upload: str) -> dict:
    """A scorer that kills its worker process on one file, as a segfault would."""
    if upload.endswith("crash.csv"):
        os._exit(7)
    return {"public": {"n": 1}, "private": {"n": 1}}


def test_a_worker_crash_fails_that_submission_alone(tmp_path, capsys):
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    from turn_eval.server.datadir import open_challenge
    from turn_eval.server.service import Scorer, open_store

    ref, root = init_challenge(tmp_path, capsys)
    challenge = open_challenge(root)
    store = open_store(challenge)
    store.add_team("T", lambda i: "0" * 64, baseline=False, now=time.time())
    names = ["a", "b", "crash", "c", "d"]
    for n in names:
        write_predictions(root / "uploads" / f"{n}.csv", ref, noise_deg=1, seed=1)
        store.take_quota(1, n, sha256="0", n_rows=1, now=time.time(), daily=None, total=None)
    # the crash's id is not alphanumeric-safe as a file name test, so name files by id
    scorer = Scorer(challenge, store, workers=2, job=crashing_job)
    scorer.start()
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            subs = {s["id"]: s for s in store.submissions_of()}
            if all(s["status"] in ("scored", "failed") for s in subs.values()):
                break
            time.sleep(0.2)
    finally:
        scorer.stop()
    status = {sid: s["status"] for sid, s in subs.items()}
    assert status == {"a": "scored", "b": "scored", "crash": "failed", "c": "scored", "d": "scored"}
    assert subs["crash"]["error"] == "the scorer crashed while scoring this submission"


def test_the_dispatcher_reads_the_queue_only_for_free_workers(tmp_path, capsys):
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    import concurrent.futures as cf

    from turn_eval.server.datadir import open_challenge
    from turn_eval.server.service import Scorer, open_store

    _, root = init_challenge(tmp_path, capsys)
    challenge = open_challenge(root)
    store = open_store(challenge)
    store.add_team("T", lambda i: "0" * 64, baseline=False, now=time.time())
    for k, n in enumerate(["e", "a", "d", "b", "c"]):
        store.take_quota(1, n, sha256="0", n_rows=1, now=1000.0 + k, daily=None, total=None)
    # oldest first, as many as asked
    assert store.queued(limit=2) == [("e", 0), ("a", 0)]
    assert [sid for sid, _ in store.queued()] == ["e", "a", "d", "b", "c"]
    reads: list[int | None] = []
    queued = store.queued

    def counted(limit: int | None = None) -> list[tuple[str, int]]:
        reads.append(limit)
        return queued(limit)

    store.queued = counted  # type: ignore[method-assign]
    submitted: list[str] = []
    scorer = Scorer(challenge, store, workers=3)
    scorer._submit = submitted.append  # type: ignore[method-assign]
    # every worker busy (each upload wakes the dispatcher): no read at all
    scorer._inflight = {n: cf.Future() for n in ("x", "y", "z")}
    scorer._dispatch()
    assert reads == [] and submitted == []
    # one free worker: the oldest queued one is claimed, and only it was read
    del scorer._inflight["z"]
    scorer._dispatch()
    assert reads == [1] and submitted == ["e"]
    assert [sid for sid, _ in queued()] == ["a", "d", "b", "c"]
    store.engine.dispose()


def check_crashing_once(root: str, upload: str, shown_name: str) -> int:
    """A check that kills its worker the first time it sees a file with a ``.crash`` mark."""
    mark = Path(upload).with_suffix(".crash")
    if mark.exists():
        mark.unlink()
        os._exit(7)
    from turn_eval.server.scoring import check_job

    return check_job(root, upload, shown_name)


def check_crashing_always(root: str, upload: str, shown_name: str) -> int:
    os._exit(7)


def check_slowly_then_crash(root: str, upload: str, shown_name: str) -> int:
    time.sleep(0.5)
    os._exit(7)


def test_a_check_waiting_for_a_worker_that_dies_is_answered(tmp_path, capsys):
    """Two uploads at once on one check worker that each check kills: the one waiting for
    the worker is not left waiting when the worker dies (it starts the next one), and each
    gets the broken-worker error."""
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    from concurrent.futures.process import BrokenProcessPool

    from turn_eval.server.datadir import open_challenge
    from turn_eval.server.service import Checker

    ref, root = init_challenge(tmp_path, capsys)
    good = write_predictions(tmp_path / "good.csv", ref, noise_deg=5, seed=0)
    checker = Checker(open_challenge(root), job=check_slowly_then_crash)
    checker.start()
    outcomes: dict[str, str] = {}

    def upload(name: str) -> None:
        try:
            checker.check(good, name)
            outcomes[name] = "answered"
        except BrokenProcessPool:
            outcomes[name] = "broken"

    first = threading.Thread(target=upload, args=("first",))
    second = threading.Thread(target=upload, args=("second",))
    try:
        first.start()
        time.sleep(0.2)  # the first holds the only worker; the second waits for it
        second.start()
        first.join(timeout=30)
        second.join(timeout=30)
        assert not first.is_alive() and not second.is_alive()
        assert outcomes == {"first": "broken", "second": "broken"}
    finally:
        checker.stop()


def test_the_checker_answers_as_score_does_from_its_own_process(tmp_path, capsys):
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    from concurrent.futures.process import BrokenProcessPool

    from turn_datasets.errors import TurnbenchError
    from turn_eval.server.datadir import open_challenge
    from turn_eval.server.scoring import check_upload
    from turn_eval.server.service import Checker

    ref, root = init_challenge(tmp_path, capsys)
    challenge = open_challenge(root)
    good = write_predictions(tmp_path / "good.csv", ref, noise_deg=5, seed=0)
    bad = tmp_path / "bad.csv"
    # 3 rows of the reference's 240 (line 3: a negative angle)
    bad.write_text("clip_id,angle_deg\nclip0000,10\nclip0001,-5\nclip0002,7\n")
    checker = Checker(challenge)
    try:
        assert checker.check(good, "g.csv") == 240
        with pytest.raises(TurnbenchError) as there:
            checker.check(bad, "mine.csv")
        with pytest.raises(TurnbenchError) as here:
            check_upload(challenge, bad, "mine.csv")
        assert str(there.value) == str(here.value)
        assert there.value.where.file == "mine.csv" and there.value.where.row == 3
        assert str(tmp_path) not in str(there.value)
    finally:
        checker.stop()
    # a worker that dies is replaced and the check tried once more; twice, it is raised
    good.with_suffix(".crash").touch()
    checker = Checker(challenge, job=check_crashing_once)
    try:
        assert checker.check(good, "g.csv") == 240
        assert not good.with_suffix(".crash").exists()
    finally:
        checker.stop()
    checker = Checker(challenge, job=check_crashing_always)
    try:
        with pytest.raises(BrokenProcessPool):
            checker.check(good, "g.csv")
    finally:
        checker.stop()


# --- the command line -----------------------------------------------------------------------
def test_init_refusals_leave_nothing(tmp_path, capsys):
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    write_reference(tmp_path / "labels.csv")
    root = tmp_path / "c"
    code, _, err = run(
        ["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "x", "--by", "nosuch"],
        capsys,
    )
    assert code == 2 and "--by 'nosuch'" in err and not root.exists()
    # angle_deg is the label, never a group
    code, _, err = run(
        ["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "x", "--by", "angle_deg"],
        capsys,
    )
    assert code == 2 and not root.exists()
    bad = tmp_path / "bad.csv"
    bad.write_text("clip_id,angle_deg\na,1\na,2\n")
    code, _, err = run(["server", "init", root, "-r", bad, "--name", "x"], capsys)
    assert code == 2 and "bad.csv" in err and not root.exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
    root.mkdir()
    (root / "keep.txt").write_text("mine")
    code, _, err = run(
        ["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "x"], capsys
    )
    assert code == 2 and "not empty" in err
    assert [p.name for p in root.iterdir()] == ["keep.txt"]
    code, _, err = run(
        [
            "server",
            "init",
            tmp_path / "d",
            "-r",
            tmp_path / "labels.csv",
            "--name",
            "x",
            "--private-fraction",
            "1.5",
        ],
        capsys,
    )
    assert code == 2 and "Traceback" not in err


def test_an_unreachable_database_is_one_line(tmp_path, capsys):
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    write_reference(tmp_path / "labels.csv")
    nowhere = "postgresql+psycopg://nobody@/x?host=/nonexistent-socket-dir&port=1"
    root = tmp_path / "c"
    args = ["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "x"]
    code, _, err = run([*args, "--db", nowhere], capsys)
    assert code == 2 and "cannot create the tables" in err and not root.exists()
    assert len(err.strip().splitlines()) == 1
    assert run(args, capsys)[0] == 0
    settings = json.loads((root / "challenge.json").read_text())
    (root / "challenge.json").write_text(json.dumps({**settings, "database": nowhere}))
    for command in (["server", "add-team", root, "A"], ["server", "list", root], ["serve", root]):
        code, _, err = run(command, capsys)
        assert code == 2 and err.startswith("turn-eval: error: cannot reach the database")
        assert "Traceback" not in err


def test_team_and_receipt_commands(tmp_path, capsys):
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    _, root = init_challenge(tmp_path, capsys)
    code, token, err = run(["server", "add-team", root, "A"], capsys)
    assert code == 0 and token.count("\n") == 1 and "shown once" in err
    import sqlite3

    con = sqlite3.connect(root / "turnbench.db")
    # WAL: the page and the API read while an upload's quota transaction writes
    assert con.execute("pragma journal_mode").fetchone() == ("wal",)
    (stored,) = con.execute("select token_hash from teams where name = 'A'").fetchone()
    con.close()
    from turn_eval.server.datadir import open_challenge
    from turn_eval.server.service import open_store

    store = open_store(open_challenge(root))
    with store.engine.connect() as conn:
        # the server's connections: 1 is NORMAL (SQLite's PRAGMA synchronous: 0 OFF, 1
        # NORMAL, 2 FULL, the default), no sync at each commit under WAL
        assert conn.exec_driver_sql("pragma synchronous").scalar() == 1
    store.engine.dispose()
    # only the hash is kept
    assert stored == hashlib.sha256(token.strip().encode()).hexdigest()
    code, _, err = run(["server", "add-team", root, "A"], capsys)
    assert code == 2 and "already exists" in err
    bad = tmp_path / "r.json"
    bad.write_text("{not json")
    code, _, err = run(["server", "verify-receipt", root, bad], capsys)
    assert code == 2 and "not a receipt" in err
    bad.write_text('{"team": "A"}')
    code, _, err = run(["server", "verify-receipt", root, bad], capsys)
    assert code == 3 and "lacks" in err
    code, _, err = run(["serve", tmp_path], capsys)
    assert code == 2 and "not a challenge data directory" in err
    for command in (
        "serve",
        "server",
        "server init",
        "server add-team",
        "server add-baseline",
        "server close-phase",
        "server list",
        "server verify-receipt",
    ):
        code, out, _ = run([*command.split(), "--help"], capsys)
        assert code == 0 and "Example:" in out, command


def test_reads_do_not_wait_for_a_writer(tmp_path, capsys):
    """Under WAL a read sees the last commit while another connection holds the write lock:
    the store's reads (a token's team, the phase, the queue) must not ask for that lock."""
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    import sqlite3
    import threading

    from turn_eval.server.datadir import open_challenge
    from turn_eval.server.service import open_store

    _, root = init_challenge(tmp_path, capsys)
    assert run(["server", "add-team", root, "A"], capsys)[0] == 0
    store = open_store(open_challenge(root))
    holder = sqlite3.connect(root / "turnbench.db", isolation_level=None)
    holder.execute("BEGIN IMMEDIATE")
    # written, not committed: no read may see it
    holder.execute("insert into phase (key, value) values ('closed', '0')")
    seen: dict = {}

    def read() -> None:
        seen["team"] = store.team(1)
        seen["closed"] = store.is_closed()
        seen["queued"] = store.queued()

    reader = threading.Thread(target=read, daemon=True)
    try:
        reader.start()
        reader.join(timeout=10)
        assert not reader.is_alive(), "a read waited for the write lock"
    finally:
        holder.execute("ROLLBACK")
        holder.close()
        reader.join()
        store.engine.dispose()
    assert seen["team"].name == "A" and seen["closed"] is False and seen["queued"] == []


def test_a_team_read_once_is_kept_and_its_tokens_still_checked(tmp_path, capsys):
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    import sqlite3

    from turn_eval.server.datadir import open_challenge
    from turn_eval.server.service import authenticate, open_store, token_team_id

    _, root = init_challenge(tmp_path, capsys)
    token = run(["server", "add-team", root, "A"], capsys)[1].strip()
    store = open_store(open_challenge(root))
    team_id = int(token.split(".")[0])
    assert token_team_id(f"Bearer {token}") == team_id
    assert token_team_id("Bearer nope") is None and token_team_id(None) is None
    assert store.known_team(team_id) is None
    assert authenticate(store, f"Bearer {token}").name == "A"
    assert store.known_team(team_id).name == "A"
    # a wrong secret for a kept team is refused as before
    assert authenticate(store, f"Bearer {team_id}.{'x' * 43}") is None
    # a team's row never changes once written, so what was read is kept (here the file is
    # changed behind the store's back, which nothing of ours does, to show no read is made)
    con = sqlite3.connect(root / "turnbench.db")
    con.execute("update teams set name = 'changed' where id = ?", (team_id,))
    con.commit()
    con.close()
    assert authenticate(store, f"Bearer {token}").name == "A"
    # a team the store did not find is not kept as missing: added later, it is found
    assert authenticate(store, f"Bearer {team_id + 1}.{'y' * 43}") is None
    other = run(["server", "add-team", root, "B"], capsys)[1].strip()
    assert int(other.split(".")[0]) == team_id + 1
    assert authenticate(store, f"Bearer {other}").name == "B"
    store.engine.dispose()


def test_the_core_never_imports_the_server_packages(tmp_path):
    ref = write_reference(tmp_path / "labels.csv")
    write_predictions(tmp_path / "p.csv", ref, noise_deg=5, seed=0)
    code = (
        "import sys\n"
        "from turn_datasets.cli.common import run_group\n"
        "from turn_eval.cli import cli\n"
        f"rc = run_group(cli, 'turn-eval', ['score', {str(tmp_path / 'p.csv')!r}, '-r', "
        f"{str(tmp_path / 'labels.csv')!r}, '--bootstrap', '10', '--format', 'json'])\n"
        "assert rc == 0, rc\n"
        "run_group(cli, 'turn-eval', ['--help'])\n"
        "run_group(cli, 'turn-eval', ['server', '--help'])\n"
        "import turn_eval, turn_datasets, turn_eval.server, turn_eval.server.scoring\n"
        f"loaded = [m for m in {SERVER_PACKAGES!r} if m in sys.modules]\n"
        "print('LOADED:' + ','.join(loaded))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "LOADED:"


def test_without_the_extra_the_commands_say_how_to_get_it(tmp_path):
    # a sitecustomize that makes sqlalchemy unimportable, as on an install without the extra
    blocker = tmp_path / "block"
    blocker.mkdir()
    (blocker / "sqlalchemy.py").write_text("raise ImportError('blocked', name='sqlalchemy')\n")
    write_reference(tmp_path / "labels.csv")
    env = {**os.environ, "PYTHONPATH": str(blocker)}
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "turn_eval",
            "server",
            "init",
            str(tmp_path / "c"),
            "-r",
            str(tmp_path / "labels.csv"),
            "--name",
            "x",
        ],
        capture_output=True,
        text=True,
        env=env,
    )
    assert out.returncode == 2
    assert out.stderr.strip() == (
        "turn-eval: error: sqlalchemy is not installed; install the server extra: "
        "pip install 'turnbench[server]'"
    )
    assert not (tmp_path / "c").exists()


def test_without_by_no_group_leaves_the_server(tmp_path, capsys):
    # `score` groups by every default column when none is named; the server must not
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    from turn_eval.server.datadir import open_challenge
    from turn_eval.server.scoring import score_upload

    ref = write_reference(tmp_path / "labels.csv")
    root = tmp_path / "c"
    args = ["server", "init", root, "-r", tmp_path / "labels.csv", "--name", "x"]
    assert run([*args, "--bootstrap", "20"], capsys)[0] == 0
    scores = score_upload(
        open_challenge(root), write_predictions(tmp_path / "p.csv", ref, noise_deg=5, seed=0)
    )
    assert scores["public"]["by"] == {} and scores["private"]["by"] == {}
    text = json.dumps(scores)
    assert not any(word in text for word in ("P00", "PD", "scripted", "subject", "cohort"))


def test_scoring_workers_run_at_a_lower_priority_than_the_server():
    # Scoring is queued work: its workers yield the CPU to the requests (os.nice 10 more).
    import concurrent.futures as cf
    import multiprocessing

    from turn_eval.server.scoring import WORKER_NICENESS, scoring_worker_init

    ours = os.nice(0)
    with cf.ProcessPoolExecutor(
        max_workers=1,
        mp_context=multiprocessing.get_context("spawn"),
        initializer=scoring_worker_init,
        initargs=(os.getpid(),),
    ) as pool:
        theirs = pool.submit(os.nice, 0).result(timeout=60)
    assert WORKER_NICENESS == 10
    assert theirs == min(ours + 10, 19)


def test_server_init_checks_by_as_score_does(tmp_path, capsys):
    # one grouping check for score and the server: commas split, a value column is no group
    pytest.importorskip("sqlalchemy", reason="needs the server extra")
    from turn_eval.server.datadir import open_challenge

    write_reference(tmp_path / "labels.csv")
    ok = ["server", "init", tmp_path / "c", "-r", tmp_path / "labels.csv", "--name", "x"]
    assert run([*ok, "--by", "cohort, scenario"], capsys)[0] == 0
    assert open_challenge(tmp_path / "c").by == ("cohort", "scenario")
    bad = ["server", "init", tmp_path / "d", "-r", tmp_path / "labels.csv", "--name", "x"]
    code, out, err = run([*bad, "--by", "angle_deg"], capsys)
    assert code == 2 and out == "" and not (tmp_path / "d").exists()
    assert err.count("\n") == 1 and "--by 'angle_deg': the reference has no such group" in err
    assert "it has bin_deg, subject, cohort, scenario, notes" in err and "angle_deg," not in err
