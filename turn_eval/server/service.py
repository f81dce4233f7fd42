"""What the commands and the web app do with a challenge: make it, add teams and baselines,
check tokens, queue and score uploads off the request path, rank the leaderboard.

Scoring runs in a pool of worker processes (:class:`Scorer`), fed by one dispatcher thread
from the database's queue, so an upload is answered as soon as it is validated and counted.
A worker that dies (a crash, the OOM killer) breaks the pool: the pool is rebuilt, and the
submissions it held go back to the queue to be scored one at a time, so the one that kills
its worker again is marked failed alone and the server keeps serving. On start, whatever a
stopped server was scoring (even one killed with SIGKILL) goes back to the queue.

The checks an upload waits for run in a worker process of their own too (:class:`Checker`),
at the server's priority: the server's process keeps to the HTTP, the tokens and the
database, on its one GIL, and the check (pandas' work, most of an upload's CPU) runs beside
it, on another core where there is one. The request's thread talks to that worker over a
pipe of its own, with no executor's threads in between to wake.
"""

from __future__ import annotations

import collections
import concurrent.futures as cf
import hashlib
import hmac
import multiprocessing
import os
import secrets
import shutil
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import sha256_file, to_json_text
from turn_eval.clips.submission import read_reference
from turn_eval.scoring.groups import check_groupings
from turn_eval.server.datadir import (
    SETTINGS_FILE,
    Challenge,
    ChallengeParams,
    new_secret,
    open_challenge,
)
from turn_eval.server.ranking import gated_ranks, order_key
from turn_eval.server.receipts import sign_receipt
from turn_eval.server.scoring import (
    check_job,
    check_upload,
    reference_of,
    score_job,
    score_upload,
    scoring_worker_init,
    serve_checks,
    side_arrays,
    warm_job,
)
from turn_eval.server.split import PRIVATE, PUBLIC, draw_split
from turn_eval.server.store import (
    FAILED,
    SCORED,
    QuotaUsed,
    Store,
    Team,
    create_schema,
    make_engine,
)

__all__ = [
    "init_challenge",
    "open_store",
    "add_team",
    "add_baseline",
    "authenticate",
    "token_team_id",
    "new_id",
    "accept_upload",
    "Scorer",
    "Checker",
    "Leaderboard",
    "receipt_of",
    "submission_view",
    "submissions_of",
    "challenge_summary",
    "QuotaUsed",
]

#: Columns of the reference that are its values, never a group the board may show.
_NOT_GROUPS = ("clip_id", "angle_deg", "duration_s", "speed_deg_s")


def _check_by(reference_columns: Sequence[str], by: Sequence[str], path: str) -> tuple[str, ...]:
    """``score``'s own check of the groupings (:func:`check_groupings`), over the reference's
    columns that may be shown as groups."""
    allowed = [c for c in reference_columns if c not in _NOT_GROUPS]
    return tuple(check_groupings(by, allowed, default=(), file=path))


def _fresh_target(root: Path) -> None:
    if root.is_symlink() or (root.exists() and not root.is_dir()):
        raise TurnbenchError("exists and is not a folder", file=str(root))
    if root.is_dir() and any(root.iterdir()):
        raise TurnbenchError("the folder is not empty; a challenge gets a new one", file=str(root))


def init_challenge(
    root: Path,
    *,
    reference: Path,
    name: str,
    params: ChallengeParams,
    by: Sequence[str],
    seed: int,
    n_resamples: int,
    database: str | None,
) -> Challenge:
    """Make a challenge's data directory (:mod:`turn_eval.server.datadir`) and its tables.

    Everything is written into a hidden folder beside ``root`` and renamed into place at
    the end, so a refused reference or an unreachable database leaves nothing behind.
    """
    _fresh_target(root)
    if not name.strip():
        raise TurnbenchError("--name is empty")
    frame = read_reference(reference)
    by = _check_by(list(frame.columns), by, str(reference))
    split = draw_split(frame, private_fraction=params.private_fraction, seed=seed)
    root.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{root.name}.", dir=root.parent))
    try:
        private = stage / "private"
        private.mkdir(mode=0o700)
        shutil.copyfile(reference, private / "reference.csv")
        split.table.to_csv(private / "split.csv", index=False, lineterminator="\n")
        fd = os.open(private / "secret", os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as fh:
            fh.write(new_secret() + "\n")
        (stage / "uploads").mkdir()
        (stage / "incoming").mkdir()
        challenge = Challenge(
            root=stage,
            name=name.strip(),
            params=params,
            by=by,
            seed=seed,
            n_resamples=n_resamples,
            database=database,
            reference_version=sha256_file(private / "reference.csv"),
            split={
                "unit": split.unit,
                "n_units": split.n_units,
                "n_units_private": split.n_units_private,
                "n_clips_private": int(split.mask(PRIVATE).sum()),
                "n_clips_public": int(split.mask(PUBLIC).sum()),
                "sha256": sha256_file(private / "split.csv"),
            },
            created=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        )
        (stage / SETTINGS_FILE).write_text(to_json_text(challenge.as_json()), encoding="utf-8")
        engine = make_engine(challenge.database_url)
        try:
            create_schema(engine)
        finally:
            engine.dispose()
        if root.is_dir():
            root.rmdir()
        os.rename(stage, root)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    return open_challenge(root)


def open_store(challenge: Challenge) -> Store:
    """The challenge's database, checked reachable (a one-line error if not)."""
    store = Store(make_engine(challenge.database_url))
    store.check()
    return store


def _token_hash(token: str) -> str:
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


def add_team(store: Store, name: str, *, baseline: bool = False) -> str:
    """Add a team; return its token (``<team id>.<secret>``), which only its hash keeps."""
    name = name.strip()
    if not name or len(name) > 200 or not name.isprintable():
        raise TurnbenchError(f"a team name is 1 to 200 printable characters, got {name!r}")
    # the id part lets a token find its team without a search by hash
    tokens: dict[int, str] = {}

    def hash_for(team_id: int) -> str:
        tokens[team_id] = f"{team_id}.{secrets.token_urlsafe(32)}"
        return _token_hash(tokens[team_id])

    team_id = store.add_team(name, hash_for, baseline=baseline, now=time.time())
    return tokens[team_id]


def _bearer_token(header: str | None) -> str | None:
    """The token of ``Authorization: Bearer TOKEN`` if it has our shape
    (``<team id>.<secret>``), else None."""
    if not header or not header.startswith("Bearer "):
        return None
    token = header[len("Bearer ") :].strip()
    team_part, _, secret_part = token.partition(".")
    if not team_part.isdigit() or not secret_part or len(token) > 200:
        return None
    return token


def token_team_id(header: str | None) -> int | None:
    """The team id a bearer token names, not yet checked (None: not one of our tokens)."""
    token = _bearer_token(header)
    return None if token is None else int(token.partition(".")[0])


def authenticate(store: Store, header: str | None) -> Team | None:
    """The team whose token is in ``Authorization: Bearer TOKEN``, or None.

    The stored hash is compared with the token's in constant time
    (:func:`hmac.compare_digest`); a baseline has no usable token. It reads the database
    only for a team the store does not hold yet (:meth:`Store.team`).
    """
    token = _bearer_token(header)
    if token is None:
        return None
    team = store.team(int(token.partition(".")[0]))
    if team is None or team.is_baseline:
        # still hash and compare, so a wrong team id costs what a wrong secret does
        hmac.compare_digest(_token_hash(token), "0" * 64)
        return None
    return team if hmac.compare_digest(_token_hash(token), team.token_hash) else None


def new_id() -> str:
    """A submission id: 128 random bits as hex (ids are not guessable, and never a path)."""
    return secrets.token_hex(16)


def accept_upload(
    challenge: Challenge,
    store: Store,
    team: Team,
    received: Path,
    shown_name: str,
    sha256: str,
    *,
    checker: Checker | None = None,
    submission_id: str | None = None,
) -> str:
    """Check a received upload (:func:`check_upload`, in ``checker``'s process if one is
    given), store it under its id (``submission_id``, else a new one) and take the team's
    quota. ``received`` is moved into ``uploads/`` or removed, whatever happens.

    Raises
    ------
    TurnbenchError
        The file is refused (``turn-eval score``'s message); nothing is counted.
    QuotaUsed
        The team's quota is used; nothing is kept.
    """
    submission_id = submission_id or new_id()
    stored = challenge.upload_path(submission_id)
    try:
        if checker is None:
            n_clips = check_upload(challenge, received, shown_name)
        else:
            n_clips = checker.check(received, shown_name)
        os.replace(received, stored)
    except BaseException:
        received.unlink(missing_ok=True)
        raise
    try:
        store.take_quota(
            team.id,
            submission_id,
            sha256=sha256,
            n_rows=n_clips,
            now=time.time(),
            daily=None if team.is_baseline else challenge.params.daily_quota,
            total=None if team.is_baseline else challenge.params.total_quota,
        )
    except BaseException:
        stored.unlink(missing_ok=True)
        raise
    return submission_id


def add_baseline(challenge: Challenge, store: Store, name: str, predictions: Path) -> str:
    """Add a baseline team with one submission, scored here and now; return its id."""
    reference_of(challenge)  # a broken data directory fails before anything is added
    check_upload(challenge, predictions, str(predictions))
    add_team(store, name, baseline=True)
    team = store.team_by_name(name.strip())
    assert team is not None
    fd, tmp = tempfile.mkstemp(suffix=".csv", dir=challenge.incoming_dir)
    os.close(fd)
    try:
        shutil.copyfile(predictions, tmp)
        submission_id = accept_upload(
            challenge, store, team, Path(tmp), str(predictions), sha256_file(tmp)
        )
    finally:
        Path(tmp).unlink(missing_ok=True)
    store.claim(submission_id)
    scores = score_upload(challenge, challenge.upload_path(submission_id))
    store.finish(submission_id, status=SCORED, now=time.time(), scores=scores)
    return submission_id


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, TurnbenchError):
        return str(exc)
    return f"the scorer failed ({type(exc).__name__})"


def _worker_context() -> multiprocessing.context.BaseContext:
    """Where workers come from: a fork server that has imported the scorer once (a pool
    rebuilt after a crash starts in milliseconds, not in a fresh interpreter's seconds), or
    a fresh interpreter where there is no fork server. Never a plain fork: the server has
    threads, and a forked copy of them is unsafe."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(["turn_eval.server.scoring"])
        return context
    return multiprocessing.get_context("spawn")


class _CheckWorker:
    """One check worker process (:func:`serve_checks`) and the server's end of its pipe."""

    def __init__(
        self,
        context: multiprocessing.context.BaseContext,
        root: str,
        job: Callable[[str, str, str], int],
    ) -> None:
        ours, theirs = context.Pipe()
        self.process = context.Process(  # type: ignore[attr-defined]
            target=serve_checks,
            args=(theirs, root, os.getpid(), job),
            name="turnbench-checker",
            daemon=True,
        )
        self.process.start()
        theirs.close()
        self.conn = ours

    def ask(self, args: tuple[str, str, str]) -> tuple[bool, Any]:
        """Send one check and wait for its answer (``EOFError``/``OSError``: the worker
        died)."""
        self.conn.send(args)
        return self.conn.recv()

    def end(self) -> None:
        """Close the pipe (the worker's next read ends it) and reap the process."""
        self.conn.close()
        self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join(timeout=5)


@dataclass
class _Handoff:
    """A thread's place in the queue for a check worker."""

    ready: threading.Event = field(default_factory=threading.Event)
    worker: _CheckWorker | None = None


class Checker:
    """Checks uploads (:func:`check_upload`) in worker processes at the server's priority.

    Each worker has a pipe of its own: the thread that checks an upload sends it on the
    pipe of an idle worker and waits there for the answer. A worker that dies is replaced
    and the check tried once more, in the new one; a second death is raised
    (``BrokenProcessPool``: the request fails, with nothing stored or counted).

    Parameters
    ----------
    challenge
        The challenge (each worker holds its reference once).
    workers
        Worker processes.
    job
        What a worker runs for one upload, ``job(root, upload, shown_name) -> clips`` (a
        top-level function, as another process needs).
    """

    def __init__(
        self,
        challenge: Challenge,
        *,
        workers: int = 1,
        job: Callable[[str, str, str], int] = check_job,
    ) -> None:
        self.challenge = challenge
        self.workers = max(1, int(workers))
        self.job = job
        self._lock = threading.Lock()
        self._idle: list[_CheckWorker] = []
        # threads waiting for a worker, first come first served (a lock's waiters are woken
        # in no particular order, and an upload could wait behind many later ones)
        self._waiting: collections.deque[_Handoff] = collections.deque()
        self._started = 0

    def _take(self) -> _CheckWorker:
        """An idle worker; else a new one while fewer than ``workers`` run; else the next
        one given back, in the order the threads asked."""
        while True:
            with self._lock:
                if self._idle:
                    return self._idle.pop()
                if self._started < self.workers:
                    self._started += 1
                    break
                handoff = _Handoff()
                self._waiting.append(handoff)
            handoff.ready.wait()
            if handoff.worker is not None:
                return handoff.worker
            # a worker was lost: this thread may start the next one
        try:
            return _CheckWorker(_worker_context(), str(self.challenge.root), self.job)
        except BaseException:
            self._lost(None)
            raise

    def _give_back(self, worker: _CheckWorker | None) -> None:
        """Hand ``worker`` to the first waiting thread, else keep it idle (None: a worker
        was lost, and the first waiting thread may start another)."""
        with self._lock:
            if worker is None:
                self._started -= 1
            if self._waiting:
                handoff = self._waiting.popleft()
                handoff.worker = worker
                handoff.ready.set()
            elif worker is not None:
                self._idle.append(worker)

    def _lost(self, worker: _CheckWorker | None) -> None:
        if worker is not None:
            worker.end()
        self._give_back(None)

    def start(self) -> None:
        """Start the workers (each reads the reference before its first check; an upload
        that comes before that waits for it)."""
        with self._lock:
            missing = self.workers - self._started
        for _ in range(missing):
            self._give_back(self._take())

    def stop(self) -> None:
        """End the idle workers (call it when no check is under way)."""
        with self._lock:
            idle, self._idle = self._idle, []
            self._started -= len(idle)
        for worker in idle:
            worker.end()

    def check(self, path: Path, shown_name: str) -> int:
        """:func:`check_upload` in a worker: how many clips the upload scores.

        Raises
        ------
        TurnbenchError
            The upload is refused (the score command's message).
        BrokenProcessPool
            The check killed a worker twice.
        """
        args = (str(self.challenge.root), str(path), shown_name)
        for _ in range(2):
            worker = self._take()
            try:
                ok, value = worker.ask(args)
            except (EOFError, OSError):
                self._lost(worker)  # the next try starts a new worker
                continue
            self._give_back(worker)
            if ok:
                return int(value)
            raise value
        raise BrokenProcessPool("the upload's check killed its worker twice")


class Scorer:
    """Scores queued submissions in worker processes, off the request path.

    Parameters
    ----------
    challenge, store
        The challenge and its database.
    workers
        Worker processes (each holds the reference once).
    job
        What a worker runs for one upload, ``job(root, upload) -> scores`` (a top-level
        function, as a process pool needs).
    """

    def __init__(
        self,
        challenge: Challenge,
        store: Store,
        *,
        workers: int = 2,
        job: Callable[[str, str], dict[str, Any]] = score_job,
    ) -> None:
        self.challenge = challenge
        self.store = store
        self.workers = max(1, int(workers))
        self.job = job
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self._inflight: dict[str, cf.Future] = {}
        self._solo = False
        self._pool: cf.ProcessPoolExecutor | None = None
        self._thread: threading.Thread | None = None
        self.on_scored: Callable[[], None] = lambda: None

    def _new_pool(self) -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=_worker_context(),
            initializer=scoring_worker_init,
            initargs=(os.getpid(),),
        )

    def _warm(self, pool: cf.ProcessPoolExecutor) -> cf.ProcessPoolExecutor:
        # start every worker and read the reference there now, not at the first upload
        for _ in range(self.workers):
            pool.submit(warm_job, str(self.challenge.root))
        return pool

    def start(self) -> int:
        """Requeue what a stopped server was scoring, start the dispatcher; how many
        were requeued."""
        requeued = self.store.requeue_interrupted()
        self._thread = threading.Thread(target=self._run, name="turnbench-scorer", daemon=True)
        self._thread.start()
        return requeued

    def wake(self) -> None:
        """Tell the dispatcher a submission was queued."""
        self._wake.set()

    def stop(self) -> None:
        """Stop dispatching; submissions being scored stay in the database for the next
        start."""
        self._stopping.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=30)
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)

    def _run(self) -> None:
        # the pool starts here, not in start(): the server answers while its workers load
        self._pool = self._warm(self._new_pool())
        while not self._stopping.is_set():
            try:
                self._collect()
                self._dispatch()
            except Exception as exc:  # the database went away for a moment: try again
                print(f"turn-eval serve: scorer: {_one_line(exc)}", file=sys.stderr, flush=True)
                time.sleep(1.0)
            self._wake.wait(timeout=0.5)
            self._wake.clear()

    def _dispatch(self) -> None:
        if self._solo and self._inflight:
            return
        self._solo = False
        free = self.workers - len(self._inflight)
        if free <= 0:
            # every worker is busy: nothing to read (each upload wakes the dispatcher, and
            # this runs in the server's process, beside the uploads)
            return
        for submission_id, attempts in self.store.queued(limit=free):
            if len(self._inflight) >= self.workers:
                return
            if attempts >= 1:
                # interrupted or in a broken pool before: score it alone, so that if it
                # crashes its worker again, it is known to be the one
                if self._inflight:
                    return
                self._solo = True
            if self.store.claim(submission_id):
                self._submit(submission_id)
            if self._solo:
                return

    def _submit(self, submission_id: str) -> None:
        assert self._pool is not None
        upload = str(self.challenge.upload_path(submission_id))
        try:
            future = self._pool.submit(self.job, str(self.challenge.root), upload)
        except BrokenProcessPool:
            # a worker died since the last collection: this one never ran
            self.store.requeue(submission_id)
            self._rebuild()
            return
        future.add_done_callback(lambda _: self._wake.set())
        self._inflight[submission_id] = future

    def _rebuild(self) -> None:
        """Replace a broken pool; what it held goes back to the queue (to run alone)."""
        assert self._pool is not None
        self._pool.shutdown(wait=False, cancel_futures=True)
        for submission_id in list(self._inflight):
            self.store.requeue(submission_id)
        self._inflight.clear()
        self._pool = self._warm(self._new_pool())

    def _collect(self) -> None:
        broken = False
        for submission_id, future in list(self._inflight.items()):
            if not future.done():
                continue
            del self._inflight[submission_id]
            try:
                scores = future.result()
            except BrokenProcessPool:
                broken = True
                if self._solo:
                    self.store.finish(
                        submission_id,
                        status=FAILED,
                        now=time.time(),
                        error="the scorer crashed while scoring this submission",
                    )
                else:
                    self.store.requeue(submission_id)
                continue
            except Exception as exc:
                self.store.finish(
                    submission_id, status=FAILED, now=time.time(), error=_one_line(exc)
                )
                continue
            self.store.finish(submission_id, status=SCORED, now=time.time(), scores=scores)
            self.on_scored()
        if broken:
            self._rebuild()


def _public_view(sub: dict[str, Any], closed: bool) -> dict[str, Any]:
    out: dict[str, Any] = {
        "id": sub["id"],
        "status": "queued" if sub["status"] == "scoring" else sub["status"],
        "submitted": _iso(sub["created"]),
        "sha256": sub["sha256"],
        "n_rows": sub["n_rows"],
    }
    if sub["status"] == SCORED:
        out["public"] = sub["public"]
        if closed:
            out["private"] = sub["private"]
    if sub["status"] == FAILED:
        out["error"] = sub["error"]
    return out


def _iso(seconds: float) -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(seconds))


def submission_view(store: Store, submission_id: str, team: Team) -> dict[str, Any] | None:
    """What a team may see of one of its own submissions; None for any other id."""
    sub = store.submission(submission_id, team_id=team.id)
    return None if sub is None else _public_view(sub, store.is_closed())


def submissions_of(store: Store, team: Team) -> list[dict[str, Any]]:
    """What a team may see of all its own submissions, oldest first."""
    closed = store.is_closed()
    return [_public_view(sub, closed) for sub in store.submissions_of(team.id)]


def receipt_of(
    challenge: Challenge, store: Store, submission_id: str, team: Team
) -> dict[str, Any] | None:
    """The signed receipt of one of the team's scored submissions (None: not its own, or
    not scored yet)."""
    sub = store.submission(submission_id, team_id=team.id)
    if sub is None or sub["status"] != SCORED:
        return None
    return sign_receipt(
        challenge.secret(),
        {
            "submission": sub["id"],
            "team": team.name,
            "sha256": sub["sha256"],
            "reference_version": challenge.reference_version,
            "turnbench_version": __version__,
            "public_scores": sub["public"],
        },
    )


class Leaderboard:
    """The ranked board, recomputed only when the set of entries or the phase changes."""

    def __init__(self, challenge: Challenge, store: Store) -> None:
        self.challenge = challenge
        self.store = store
        self._lock = threading.Lock()
        self._cache: tuple[Any, dict[str, Any]] | None = None

    def board(self) -> dict[str, Any]:
        closed = self.store.is_closed()
        side = PRIVATE if closed else PUBLIC
        entries = self._entries(side)
        key = (closed, tuple((e["team"], e["id"], e["n_submissions"]) for e in entries))
        with self._lock:
            if self._cache is not None and self._cache[0] == key:
                return self._cache[1]
            board = self._rank(entries, side, closed)
            self._cache = (key, board)
            return board

    def _entries(self, side: str) -> list[dict[str, Any]]:
        teams = {t.id: t for t in self.store.all_teams()}
        subs = self.store.submissions_of()
        count: dict[int, int] = {}
        best: dict[int, dict[str, Any]] = {}
        for sub in subs:
            count[sub["team_id"]] = count.get(sub["team_id"], 0) + 1
            if sub["status"] != SCORED:
                continue
            held = best.get(sub["team_id"])
            if held is None or order_key(sub["public"], sub["created"]) < order_key(
                held["public"], held["created"]
            ):
                best[sub["team_id"]] = sub
        entries = [
            {
                "team": teams[team_id].name,
                "baseline": teams[team_id].is_baseline,
                "id": sub["id"],
                "created": sub["created"],
                "n_submissions": count[team_id],
                "public": sub["public"],
                "private": sub["private"],
            }
            for team_id, sub in best.items()
        ]
        entries.sort(key=lambda e: order_key(e[side], e["created"]))
        return entries

    def _rank(self, entries: list[dict[str, Any]], side: str, closed: bool) -> dict[str, Any]:
        c = self.challenge
        ranks = gated_ranks(
            len(entries),
            lambda i: side_arrays(c, c.upload_path(entries[i]["id"]), side),
            alpha=c.params.rank_alpha,
            n_resamples=c.n_resamples,
            seed=c.seed,
        )
        rows = []
        for entry, ranked in zip(entries, ranks, strict=True):
            row = {
                "rank": ranked.rank,
                "team": entry["team"],
                "baseline": entry["baseline"],
                "submissions": entry["n_submissions"],
                "submitted": _iso(entry["created"]),
                "p_value_vs_above": ranked.p_value,
                "public": entry["public"],
            }
            if closed:
                row["private"] = entry["private"]
            rows.append(row)
        return {
            "challenge": c.name,
            "phase": "closed" if closed else "open",
            "ranked_on": side,
            "rank_metric": "accuracy",
            "rank_alpha": c.params.rank_alpha,
            "groups": list(c.by),
            "bootstrap": c.n_resamples,
            "version": __version__,
            "rows": rows,
        }


def challenge_summary(challenge: Challenge, store: Store) -> dict[str, Any]:
    """``server list``: the settings that are public and each team's counts."""
    subs = store.submissions_of()
    teams = []
    for team in store.all_teams():
        mine = [s for s in subs if s["team_id"] == team.id]
        teams.append(
            {
                "team": team.name,
                "baseline": team.is_baseline,
                "submissions": len(mine),
                **{
                    status: sum(s["status"] == status for s in mine)
                    for status in ("queued", "scoring", SCORED, FAILED)
                },
            }
        )
    return {
        "challenge": challenge.name,
        "phase": "closed" if store.is_closed() else "open",
        "params": asdict(challenge.params),
        "groups": list(challenge.by),
        "split": challenge.split,
        "teams": teams,
    }
