"""The challenge's database (SQLAlchemy 2 Core): teams, submissions, the phase.

SQLite by default, in WAL mode (readers do not wait for the writer) with every writing
transaction opened as ``BEGIN IMMEDIATE``, so the one that takes a quota holds the write lock
from its first count to its insert (the pysqlite recipe of SQLAlchemy's SQLite dialect
documentation, "Serializable isolation / Savepoints / Transactional DDL"); PostgreSQL by URL,
where the quota transaction locks the team's row (``SELECT ... FOR UPDATE``) for the same
effect. Either way concurrent uploads can never take more than the quota: counting and
inserting happen in one transaction that no other upload of the team can interleave with.

A read (a token's team, a submission, the queue, the board) opens a plain deferred
transaction on SQLite: under WAL it sees the last commit and neither waits for the write lock
nor holds it. The server's own writes on SQLite queue on a lock in the process before
``BEGIN IMMEDIATE``, so its threads take turns at once instead of meeting SQLite's busy
handler, which sleeps 1, 2, 5, 10 ms and more between tries; ``busy_timeout`` still covers
the other processes (the ``server`` commands) that write to the same file.

Times are UTC seconds since the epoch; the daily quota counts the team's submissions since
the start of the current UTC day, so it resets by itself when the day turns (no counter to
reset, as Codabench's daily counters failed to).
"""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from sqlalchemy import (
    Boolean,
    Column,
    Connection,
    Engine,
    Float,
    ForeignKey,
    Integer,
    MetaData,
    String,
    Table,
    Text,
    bindparam,
    case,
    create_engine,
    event,
    func,
    insert,
    select,
    update,
)
from sqlalchemy.exc import IntegrityError, SQLAlchemyError

from turn_datasets.errors import TurnbenchError

__all__ = [
    "metadata",
    "teams",
    "submissions",
    "make_engine",
    "create_schema",
    "QuotaUsed",
    "Store",
    "QUEUED",
    "SCORING",
    "SCORED",
    "FAILED",
]

QUEUED, SCORING, SCORED, FAILED = "queued", "scoring", "scored", "failed"
#: The execution option that marks a connection as only reading (a deferred ``BEGIN`` on SQLite).
_READ_ONLY = "turnbench_read_only"

metadata = MetaData()
teams = Table(
    "teams",
    metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("name", String(200), nullable=False, unique=True),
    Column("token_hash", String(64), nullable=False),
    Column("is_baseline", Boolean, nullable=False, default=False),
    Column("created", Float, nullable=False),
)
submissions = Table(
    "submissions",
    metadata,
    Column("id", String(32), primary_key=True),
    Column("team_id", Integer, ForeignKey("teams.id"), nullable=False, index=True),
    Column("created", Float, nullable=False, index=True),
    Column("status", String(16), nullable=False, index=True),
    Column("sha256", String(64), nullable=False),
    Column("n_rows", Integer, nullable=False),
    Column("attempts", Integer, nullable=False, default=0),
    Column("public", Text),
    Column("private", Text),
    Column("error", Text),
    Column("scored", Float),
)
phase = Table(
    "phase",
    metadata,
    Column("key", String(64), primary_key=True),
    Column("value", Text, nullable=False),
)

# What every upload runs, built once: building a statement, and the key SQLAlchemy finds its
# compiled form by, cost more than SQLite takes to run it (0.55 -> 0.21 ms per quota taken).
_LOCK_TEAM = select(teams.c.id).where(teams.c.id == bindparam("team_id")).with_for_update()
# both counts in one statement (COUNT of a CASE counts its non-null values)
_COUNT_MINE = select(
    func.count(), func.count(case((submissions.c.created >= bindparam("since"), 1)))
).where(submissions.c.team_id == bindparam("team_id"))
_INSERT_SUBMISSION = insert(submissions)


def _sqlite_hooks(engine: Engine) -> None:
    @event.listens_for(engine, "connect")
    def _connect(dbapi_connection, connection_record) -> None:
        # pysqlite's own transaction handling off: the "begin" hook below opens each one
        dbapi_connection.isolation_level = None
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA journal_mode=WAL")
        # in WAL, NORMAL syncs at checkpoints, not at each commit: a commit survives the
        # server's crash or kill, though not a power cut (nor would the upload's own bytes,
        # which are renamed into place unsynced); the file is never corrupted either way
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.execute("PRAGMA busy_timeout=60000")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _begin(conn: Connection) -> None:
        reading = conn.get_execution_options().get(_READ_ONLY, False)
        conn.exec_driver_sql("BEGIN" if reading else "BEGIN IMMEDIATE")


def _reason(exc: BaseException) -> str:
    """A database error in one line: the driver's own message where there is one (without
    SQLAlchemy's "Background on this error" line)."""
    orig: Any = getattr(exc, "orig", None)
    text = str(orig if orig is not None else exc)
    return f"{type(orig or exc).__name__}: {' '.join(text.split())[:300]}"


def make_engine(url: str) -> Engine:
    """An engine for ``url`` (``sqlite:///...`` or ``postgresql+psycopg://...``)."""
    try:
        if url.startswith("sqlite"):
            engine = create_engine(url, connect_args={"timeout": 60})
            _sqlite_hooks(engine)
        else:
            engine = create_engine(url, pool_pre_ping=True, pool_size=10, max_overflow=20)
    except (SQLAlchemyError, ImportError, ValueError) as exc:
        raise TurnbenchError(f"cannot use the database URL ({_reason(exc)})") from None
    return engine


def create_schema(engine: Engine) -> None:
    """Create the tables (refusing a database that already holds a challenge)."""
    try:
        with engine.begin() as conn:
            if engine.dialect.has_table(conn, "teams"):
                raise TurnbenchError(
                    "the database already holds a challenge (a 'teams' table)",
                    hint="give each challenge its own database",
                )
            metadata.create_all(conn)
    except SQLAlchemyError as exc:
        raise TurnbenchError(f"cannot create the tables: {_reason(exc)}") from None


class QuotaUsed(Exception):
    """The team's daily or total quota is used; ``str`` says which."""


@dataclass(frozen=True)
class Team:
    id: int
    name: str
    token_hash: str
    is_baseline: bool


def day_start(now: float) -> float:
    """The start of ``now``'s UTC day, in seconds since the epoch."""
    day = dt.datetime.fromtimestamp(now, tz=dt.timezone.utc).date()
    return dt.datetime(day.year, day.month, day.day, tzinfo=dt.timezone.utc).timestamp()


def _loads(text: str | None) -> Any:
    return None if text is None else json.loads(text)


class Store:
    """The challenge's tables behind one engine: every read and write the server makes."""

    def __init__(self, engine: Engine) -> None:
        self.engine = engine
        self.is_sqlite = engine.dialect.name == "sqlite"
        self._reader = engine.execution_options(**{_READ_ONLY: True})
        self._write_turn = threading.Lock() if self.is_sqlite else None
        # A team's row never changes once written (add_team sets the token's hash in the
        # transaction that inserts it; nothing updates or deletes a team), so a team read
        # once is kept, and checking its token again reads nothing. A team not found is not
        # kept: `server add-team` may add it while the server runs.
        self._teams: dict[int, Team] = {}

    def _reading(self) -> Connection:
        """A connection for reads only (module docstring)."""
        return self._reader.connect()

    @contextlib.contextmanager
    def _writing(self) -> Iterator[Connection]:
        """A writing transaction, committed at the end (module docstring)."""
        with self._write_turn or contextlib.nullcontext(), self.engine.begin() as conn:
            yield conn

    def check(self) -> None:
        """Raise a one-line :class:`TurnbenchError` if the database cannot be reached or
        holds no challenge."""
        try:
            with self._reading() as conn:
                if not self.engine.dialect.has_table(conn, "teams"):
                    raise TurnbenchError("the database holds no challenge (no 'teams' table)")
        except SQLAlchemyError as exc:
            raise TurnbenchError(f"cannot reach the database: {_reason(exc)}") from None

    # teams ---------------------------------------------------------------------------------
    def add_team(
        self, name: str, hash_for: Callable[[int], str], *, baseline: bool, now: float
    ) -> int:
        """Insert a team and store ``hash_for(its id)`` as its token's hash, in one
        transaction (the token names its team's id)."""
        try:
            with self._writing() as conn:
                team_id = conn.execute(
                    insert(teams)
                    .values(name=name, token_hash="", is_baseline=baseline, created=now)
                    .returning(teams.c.id)
                ).scalar_one()
                conn.execute(
                    update(teams)
                    .where(teams.c.id == team_id)
                    .values(token_hash=hash_for(int(team_id)))
                )
        except IntegrityError:
            raise TurnbenchError(f"a team named {name!r} already exists") from None
        return int(team_id)

    def team(self, team_id: int) -> Team | None:
        """The team, from memory once read (see ``__init__``); None if there is none."""
        known = self._teams.get(team_id)
        if known is not None:
            return known
        with self._reading() as conn:
            row = conn.execute(select(teams).where(teams.c.id == team_id)).first()
        if row is None:
            return None
        team = self._teams[team_id] = Team(row.id, row.name, row.token_hash, row.is_baseline)
        return team

    def known_team(self, team_id: int) -> Team | None:
        """The team if :meth:`team` has read it before, without a database read; else None."""
        return self._teams.get(team_id)

    def team_by_name(self, name: str) -> Team | None:
        with self._reading() as conn:
            row = conn.execute(select(teams).where(teams.c.name == name)).first()
        return None if row is None else Team(row.id, row.name, row.token_hash, row.is_baseline)

    def all_teams(self) -> list[Team]:
        with self._reading() as conn:
            rows = conn.execute(select(teams).order_by(teams.c.id)).all()
        return [Team(r.id, r.name, r.token_hash, r.is_baseline) for r in rows]

    # submissions ---------------------------------------------------------------------------
    def take_quota(
        self,
        team_id: int,
        submission_id: str,
        *,
        sha256: str,
        n_rows: int,
        now: float,
        daily: int | None,
        total: int | None,
    ) -> None:
        """Count the team's submissions and insert this one in one transaction.

        Raises
        ------
        QuotaUsed
            Inserting would exceed ``daily`` (since the UTC day's start) or ``total``.
        """
        mine = {"team_id": team_id}
        with self._writing() as conn:
            if not self.is_sqlite:
                # the team's row lock serialises this team's quota transactions
                conn.execute(_LOCK_TEAM, mine)
            if total is not None or daily is not None:
                n_total, n_today = conn.execute(
                    _COUNT_MINE, {**mine, "since": day_start(now)}
                ).one()
                if total is not None and n_total >= total:
                    raise QuotaUsed(f"the total quota of {total} submissions is used")
                if daily is not None and n_today >= daily:
                    raise QuotaUsed(
                        f"the daily quota of {daily} submissions is used (it resets at 00:00 UTC)"
                    )
            conn.execute(
                _INSERT_SUBMISSION,
                {
                    **mine,
                    "id": submission_id,
                    "created": now,
                    "status": QUEUED,
                    "sha256": sha256,
                    "n_rows": n_rows,
                    "attempts": 0,
                },
            )

    def submission(self, submission_id: str, team_id: int | None = None) -> dict | None:
        """A submission; with ``team_id``, only if that team made it (else None)."""
        query = select(submissions).where(submissions.c.id == submission_id)
        if team_id is not None:
            query = query.where(submissions.c.team_id == team_id)
        with self._reading() as conn:
            row = conn.execute(query).first()
        if row is None:
            return None
        out = dict(row._mapping)
        out["public"], out["private"] = _loads(out["public"]), _loads(out["private"])
        return out

    def submissions_of(self, team_id: int | None = None) -> list[dict]:
        query = select(submissions).order_by(submissions.c.created, submissions.c.id)
        if team_id is not None:
            query = query.where(submissions.c.team_id == team_id)
        with self._reading() as conn:
            rows = conn.execute(query).all()
        out = []
        for row in rows:
            d = dict(row._mapping)
            d["public"], d["private"] = _loads(d["public"]), _loads(d["private"])
            out.append(d)
        return out

    def queued(self, limit: int | None = None) -> list[tuple[str, int]]:
        """Queued submissions, oldest first (the first ``limit``): (id, attempts so far)."""
        query = (
            select(submissions.c.id, submissions.c.attempts)
            .where(submissions.c.status == QUEUED)
            .order_by(submissions.c.created, submissions.c.id)
            .limit(limit)
        )
        with self._reading() as conn:
            return [(r.id, r.attempts) for r in conn.execute(query).all()]

    def claim(self, submission_id: str) -> bool:
        """Mark a queued submission as being scored (one more attempt); False if it was not
        queued."""
        with self._writing() as conn:
            result = conn.execute(
                update(submissions)
                .where(submissions.c.id == submission_id, submissions.c.status == QUEUED)
                .values(status=SCORING, attempts=submissions.c.attempts + 1)
            )
        return bool(result.rowcount)

    def requeue_interrupted(self) -> int:
        """Put back in the queue what a stopped server was scoring; how many."""
        with self._writing() as conn:
            result = conn.execute(
                update(submissions).where(submissions.c.status == SCORING).values(status=QUEUED)
            )
        return int(result.rowcount)

    def finish(
        self,
        submission_id: str,
        *,
        status: str,
        now: float,
        scores: dict[str, Any] | None = None,
        error: str | None = None,
    ) -> None:
        values: dict[str, Any] = {"status": status, "scored": now, "error": error}
        if scores is not None:
            values["public"] = json.dumps(scores["public"], allow_nan=False)
            values["private"] = json.dumps(scores["private"], allow_nan=False)
        with self._writing() as conn:
            conn.execute(
                update(submissions).where(submissions.c.id == submission_id).values(**values)
            )

    def requeue(self, submission_id: str) -> None:
        with self._writing() as conn:
            conn.execute(
                update(submissions).where(submissions.c.id == submission_id).values(status=QUEUED)
            )

    # the phase -----------------------------------------------------------------------------
    def is_closed(self) -> bool:
        with self._reading() as conn:
            row = conn.execute(select(phase.c.value).where(phase.c.key == "closed")).first()
        return row is not None

    def close_phase(self, now: float) -> bool:
        """Close the phase (reveal private scores); False if it already was."""
        try:
            with self._writing() as conn:
                conn.execute(insert(phase).values(key="closed", value=repr(now)))
        except IntegrityError:
            return False
        return True

    def counts(self) -> dict[str, int]:
        with self._reading() as conn:
            rows = conn.execute(
                select(submissions.c.status, func.count()).group_by(submissions.c.status)
            ).all()
        return {str(status): int(n) for status, n in rows}
