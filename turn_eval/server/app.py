"""The web app of ``turn-eval serve``: the API and the leaderboard page (FastAPI).

Routes (DESIGN.md, "Scoring server"): ``POST /api/submissions``, ``GET
/api/submissions/{id}``, ``GET /api/submissions`` (the asking team's own, oldest first), ``GET /api/leaderboard``, ``GET /api/receipts/{id}`` and ``GET /``.
Nothing else is served: no static folder, no API schema pages, so no URL reaches the data
directory. Every answer about a submission checks that the asking team made it (another
team's id is answered 404, as an id that does not exist: the missing per-object check was
Codabench's worst bug).

An upload is streamed (python-multipart's push parser) into ``incoming/`` while its bytes are
counted and hashed, and refused with 413 as soon as it passes the size cap, before the rest
is read; a request that announces a larger ``Content-Length`` is refused before reading.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import HTMLResponse, JSONResponse
from jinja2 import Environment, PackageLoader, select_autoescape
from python_multipart import MultipartParser
from python_multipart.multipart import parse_options_header
from starlette.exceptions import HTTPException as StarletteHTTPException

from turn_datasets.errors import TurnbenchError
from turn_eval.server.datadir import Challenge
from turn_eval.server.service import (
    Checker,
    Leaderboard,
    QuotaUsed,
    Scorer,
    accept_upload,
    authenticate,
    new_id,
    receipt_of,
    submission_view,
    submissions_of,
    token_team_id,
)
from turn_eval.server.store import Store

__all__ = ["create_app"]

_MIB = 1 << 20
#: Room for the multipart framing around the file itself.
_FRAMING_BYTES = 16 * 1024
_SAFE_NAME = re.compile(r"[^A-Za-z0-9._ -]")


class _Refused(Exception):
    def __init__(self, status: int, detail: str) -> None:
        super().__init__(detail)
        self.status = status
        self.detail = detail


def _shown_name(filename: str | None) -> str:
    """The upload's name as messages show it: its last path part, plain characters only."""
    if not filename:
        return "the upload"
    base = filename.replace("\\", "/").rsplit("/", 1)[-1]
    return _SAFE_NAME.sub("_", base)[:100] or "the upload"


class _FilePart:
    """Collects the multipart field ``file`` into a file, counting and hashing its bytes."""

    def __init__(self, out, limit: int) -> None:
        self.out = out
        self.limit = limit
        self.total = 0
        self.sha = hashlib.sha256()
        self.found = False
        self.filename: str | None = None
        self._header_field = b""
        self._headers: dict[bytes, bytes] = {}
        self._current = False

    def callbacks(self) -> dict[str, Any]:
        return {
            "on_part_begin": self._begin,
            "on_header_field": self._field,
            "on_header_value": self._value,
            "on_headers_finished": self._headers_done,
            "on_part_data": self._data,
        }

    def _begin(self) -> None:
        self._headers, self._header_field, self._current = {}, b"", False

    def _field(self, data: bytes, start: int, end: int) -> None:
        self._header_field = data[start:end].lower()

    def _value(self, data: bytes, start: int, end: int) -> None:
        key = self._header_field
        self._headers[key] = self._headers.get(key, b"") + data[start:end]

    def _headers_done(self) -> None:
        disposition = self._headers.get(b"content-disposition", b"")
        _, options = parse_options_header(disposition)
        if options.get(b"name") == b"file" and not self.found:
            self.found, self._current = True, True
            raw = options.get(b"filename")
            self.filename = None if raw is None else raw.decode("utf-8", "replace")

    def _data(self, data: bytes, start: int, end: int) -> None:
        if self._current:
            chunk = data[start:end]
            self.total += len(chunk)
            if self.total > self.limit:
                raise _Refused(413, f"the upload is larger than {self.limit} bytes")
            self.sha.update(chunk)
            self.out.write(chunk)


async def _receive(request: Request, challenge: Challenge, path: Path) -> tuple[str, str]:
    """Stream the upload's ``file`` field to ``path`` (a new file, in ``incoming/``); its
    shown name and sha256. Refused: nothing is left at ``path``."""
    limit = int(challenge.params.max_upload_mb * _MIB)
    content_type, options = parse_options_header(request.headers.get("content-type", ""))
    boundary = options.get(b"boundary")
    if content_type != b"multipart/form-data" or not boundary:
        raise _Refused(400, "send the predictions CSV as multipart/form-data, field 'file'")
    announced = request.headers.get("content-length", "")
    if announced.isdigit() and int(announced) > limit + _FRAMING_BYTES:
        raise _Refused(413, f"the upload is larger than {limit} bytes")
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        with os.fdopen(fd, "wb") as out:
            part = _FilePart(out, limit)
            parser = MultipartParser(boundary, part.callbacks())  # type: ignore[arg-type]
            body = 0
            async for chunk in request.stream():
                body += len(chunk)
                if body > limit + _FRAMING_BYTES:
                    raise _Refused(413, f"the upload is larger than {limit} bytes")
                parser.write(chunk)
            parser.finalize()
        if not part.found:
            raise _Refused(400, "the upload has no multipart field 'file'")
    except _Refused:
        path.unlink(missing_ok=True)
        raise
    except Exception:
        path.unlink(missing_ok=True)
        raise _Refused(400, "the multipart body is malformed") from None
    return _shown_name(part.filename), part.sha.hexdigest()


def _templates() -> Environment:
    return Environment(
        loader=PackageLoader("turn_eval.server", "templates"),
        autoescape=select_autoescape(["html"]),
    )


def _unauthorised() -> JSONResponse:
    return JSONResponse(
        {"detail": "a valid team token is needed (Authorization: Bearer TOKEN)"},
        status_code=401,
        headers={"WWW-Authenticate": "Bearer"},
    )


def _not_found() -> JSONResponse:
    return JSONResponse({"detail": "not found"}, status_code=404)


def create_app(
    challenge: Challenge, store: Store, scorer: Scorer | None, checker: Checker | None = None
) -> FastAPI:
    """The app; ``scorer`` and ``checker`` are started and stopped with it (no scorer:
    nothing is scored; no checker: uploads are checked in the server's own process)."""

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        if checker is not None:
            await run_in_threadpool(checker.start)
        if scorer is not None:
            await run_in_threadpool(scorer.start)
        try:
            yield
        finally:
            if scorer is not None:
                await run_in_threadpool(scorer.stop)
            if checker is not None:
                await run_in_threadpool(checker.stop)

    app = FastAPI(
        title=challenge.name, docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan
    )
    board = Leaderboard(challenge, store)
    page = _templates().get_template("leaderboard.html")

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        # the framework's own 404/405 say no more than ours
        detail = "not found" if exc.status_code == 404 else "not allowed"
        return JSONResponse({"detail": detail}, status_code=exc.status_code)

    async def submit(request: Request) -> JSONResponse:
        header = request.headers.get("authorization")
        team_id = token_team_id(header)
        if team_id is not None and store.known_team(team_id) is not None:
            # the team is in memory: checking the token is a hash, with no I/O to wait for
            team = authenticate(store, header)
        else:
            team = await run_in_threadpool(authenticate, store, header)
        if team is None:
            return _unauthorised()
        submission_id = new_id()
        received = challenge.incoming_dir / f"{submission_id}.csv"
        try:
            shown, sha = await _receive(request, challenge, received)
        except _Refused as exc:
            return JSONResponse({"detail": exc.detail}, status_code=exc.status)
        try:
            await run_in_threadpool(
                accept_upload,
                challenge,
                store,
                team,
                received,
                shown,
                sha,
                checker=checker,
                submission_id=submission_id,
            )
        except TurnbenchError as exc:
            return JSONResponse({"detail": str(exc)}, status_code=422)
        except QuotaUsed as exc:
            return JSONResponse({"detail": str(exc)}, status_code=429)
        if scorer is not None:
            scorer.wake()
        return JSONResponse({"id": submission_id, "status": "queued"}, status_code=202)

    # a plain Starlette route: it reads the request itself (streamed, above), so FastAPI's
    # parameter and dependency machinery would run for every upload with nothing to do
    app.router.add_route("/api/submissions", submit, methods=["POST"])

    @app.get("/api/submissions")
    def list_submissions(request: Request) -> JSONResponse:
        team = authenticate(store, request.headers.get("authorization"))
        if team is None:
            return _unauthorised()
        return JSONResponse({"team": team.name, "submissions": submissions_of(store, team)})

    @app.get("/api/submissions/{submission_id}")
    def get_submission(submission_id: str, request: Request) -> JSONResponse:
        team = authenticate(store, request.headers.get("authorization"))
        if team is None:
            return _unauthorised()
        view = submission_view(store, submission_id, team) if submission_id.isalnum() else None
        return _not_found() if view is None else JSONResponse(view)

    @app.get("/api/receipts/{submission_id}")
    def get_receipt(submission_id: str, request: Request) -> JSONResponse:
        team = authenticate(store, request.headers.get("authorization"))
        if team is None:
            return _unauthorised()
        receipt = receipt_of(challenge, store, submission_id, team)
        return _not_found() if receipt is None else JSONResponse(receipt)

    @app.get("/api/leaderboard")
    def leaderboard() -> JSONResponse:
        return JSONResponse(board.board())

    @app.get("/", response_class=HTMLResponse)
    def index() -> HTMLResponse:
        return HTMLResponse(page.render(board=board.board()))

    return app
