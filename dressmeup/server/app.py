"""The HTTP side of the evaluation server (FastAPI; its OpenAPI description at
``/openapi.json``).

API (JSON; a team authenticates with ``Authorization: Bearer <token>``):

- ``GET /api/editions``: the editions scored here;
- ``POST /api/submissions?edition=NAME``: the body is the submission archive (``.zip`` or
  ``.tar.gz``); answers ``201 {"id", "status": "queued"}``, or ``422 {"problems": [...]}``
  with every problem the validator found, ``413`` too large, ``429`` daily limit reached;
- ``GET /api/submissions``, ``GET /api/submissions/{id}``: the team's own submissions and
  their state (``queued`` / ``scoring`` / ``scored`` / ``failed`` with the reason);
- ``GET /api/submissions/{id}/result``: the summary of a scored submission;
- ``POST /api/submissions/{id}/publish`` (JSON ``{"method", "paper_url", "description"}``)
  and ``POST /api/submissions/{id}/withdraw``.

Pages: ``/leaderboard/...`` (the public report site of the published results, served from
memory between rebuilds with an ``ETag``; ``If-None-Match`` answers ``304``), ``/team`` (a
team's submissions, the token typed into a form and kept in the page only).
"""

from __future__ import annotations

import contextlib
import errno
import logging
import secrets
from pathlib import Path
from typing import Annotated, Any

from fastapi import Depends, FastAPI, Header, HTTPException, Request
from fastapi.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from pydantic import BaseModel
from sqlalchemy.exc import SQLAlchemyError

from dressmeup.errors import InputError
from dressmeup.server.accounts import team_for_token
from dressmeup.server.config import ServerConfig
from dressmeup.server.db import Submission, Team
from dressmeup.server.editions import registered
from dressmeup.server.pages import PageCache, etag_matches
from dressmeup.server.service import EvaluationServer, LimitReached, NotFound, Rejected
from dressmeup.server.teampage import TEAM_PAGE
from dressmeup.server.uploads import TooLarge, receive

log = logging.getLogger(__name__)


class Publication(BaseModel):
    """What a team publishes with a result."""

    method: str
    paper_url: str = ""
    description: str = ""


def current_team(request: Request,
                 authorization: Annotated[str | None, Header()] = None) -> Team:
    """The team whose token the request carries (``Authorization: Bearer <token>``).

    Raises
    ------
    HTTPException
        401 for a missing, unknown or revoked token.
    """
    token = None
    if authorization and authorization.lower().startswith("bearer "):
        token = authorization[7:].strip()
    with request.app.state.server.sessions() as s:
        t = team_for_token(s, token)
    if t is None:
        raise HTTPException(401, "missing, unknown or revoked token (Authorization: "
                                 "Bearer <token>)")
    return t


TeamDep = Annotated[Team, Depends(current_team)]


def _view(sub: Submission) -> dict[str, Any]:
    return {"id": sub.id, "edition": sub.edition, "status": sub.status, "error": sub.error,
            "method": sub.method, "created_at": sub.created_at.isoformat(),
            "scored_at": sub.scored_at.isoformat() if sub.scored_at else None,
            "published": sub.published, "public_method": sub.public_method,
            "paper_url": sub.paper_url, "description": sub.description}


def create_app(server: EvaluationServer) -> FastAPI:
    """The FastAPI application of ``server`` (the scorer is started and stopped with it)."""
    @contextlib.asynccontextmanager
    async def lifespan(_app: FastAPI):  # the scorer runs while the application does
        server.start()
        try:
            yield
        finally:
            server.stop()

    app = FastAPI(title="dressmeup evaluation server", lifespan=lifespan,
                  description="Submit retargeting, UV, registration and fusion results; they "
                              "are scored against withheld answers (docs/server.md).",
                  version="1", docs_url=None, redoc_url=None)
    app.state.server = server
    _add_error_answers(app)
    _add_api(app, server)
    _add_pages(app, server.pages)
    return app


def _add_error_answers(app: FastAPI) -> None:
    """What a failure answers: a user's mistake 400 (404 unknown, 413 too large, 429 over the
    daily limit, 422 with every problem of an invalid submission), the database 503, a full
    or read-only disk 507, another i/o error 500; nothing recorded in the last three."""
    @app.exception_handler(InputError)
    async def _input_error(_request: Request, exc: InputError) -> JSONResponse:
        if isinstance(exc, Rejected):
            return JSONResponse({"detail": "the submission is invalid",
                                 "problems": exc.problems}, status_code=422)
        code = 404 if isinstance(exc, NotFound) else 429 if isinstance(exc, LimitReached) \
            else 413 if isinstance(exc, TooLarge) else 400
        return JSONResponse({"detail": str(exc)}, status_code=code)

    @app.exception_handler(SQLAlchemyError)
    async def _database_error(_request: Request, exc: SQLAlchemyError) -> JSONResponse:
        log.error("database error: %s", exc)
        return JSONResponse({"detail": "the server's database cannot be written or read "
                                       "(read-only, full disk or unreachable); nothing was "
                                       "recorded: try again later"}, status_code=503)

    @app.exception_handler(OSError)
    async def _disk_error(_request: Request, exc: OSError) -> JSONResponse:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EROFS):
            return JSONResponse({"detail": "the server's disk is full or read-only; nothing "
                                           "was recorded: try again later"}, status_code=507)
        log.error("i/o error: %s", exc)
        return JSONResponse({"detail": "the server could not read or write a file; nothing "
                                       "was recorded"}, status_code=500)


def _add_api(app: FastAPI, server: EvaluationServer) -> None:
    """The JSON API of the module docstring."""
    cfg = server.config

    @app.get("/api/editions")
    def editions() -> list[dict[str, str]]:
        with server.sessions() as s:
            return [{"name": e.name, "edition_hash": e.edition_hash} for e in registered(s)]

    @app.post("/api/submissions", status_code=201)
    async def submit(request: Request, edition: str, t: TeamDep) -> dict:
        length = request.headers.get("content-length")
        limit = cfg.max_upload_mb << 20
        if length is not None and length.isdigit() and int(length) > limit:
            raise TooLarge(f"the upload is larger than the server's limit of "
                           f"{cfg.max_upload_mb} MB")
        dest = cfg.folder("uploads") / f"{secrets.token_hex(16)}.upload"
        upload = await receive(request.stream(), dest, limit)
        sub = server.accept(t, edition, upload)
        return {"id": sub.id, "status": sub.status}

    @app.get("/api/submissions")
    def mine(t: TeamDep) -> list[dict]:
        return [_view(s) for s in server.mine(t)]

    @app.get("/api/submissions/{sub_id}")
    def one(sub_id: str, t: TeamDep) -> dict:
        return _view(server.get(t, sub_id))

    @app.get("/api/submissions/{sub_id}/result")
    def result(sub_id: str, t: TeamDep) -> dict:
        return server.result(t, sub_id)

    @app.post("/api/submissions/{sub_id}/publish")
    def publish(sub_id: str, body: Publication, t: TeamDep) -> dict:
        return _view(server.publish(t, sub_id, body.method, body.paper_url, body.description))

    @app.post("/api/submissions/{sub_id}/withdraw")
    def withdraw(sub_id: str, t: TeamDep) -> dict:
        return _view(server.withdraw(t, sub_id))


def _add_pages(app: FastAPI, cache: PageCache) -> None:
    """``/`` (to the leaderboards), ``/team`` and ``/leaderboard/...`` (the published report
    site, files served only from inside it, from memory between rebuilds)."""
    @app.get("/", include_in_schema=False)
    def root() -> RedirectResponse:
        return RedirectResponse("/leaderboard/")

    @app.get("/team", include_in_schema=False, response_class=HTMLResponse)
    def team_page() -> str:
        return TEAM_PAGE

    # async: a cached page is answered on the event loop, without a worker thread's hand-off
    @app.get("/leaderboard/{path:path}", include_in_schema=False)
    async def leaderboard(path: str, request: Request) -> Response:
        page = cache.get(path)
        if page is None:
            raise HTTPException(404, "no such page")
        headers = {"ETag": page.etag, "Cache-Control": "no-cache",
                   "X-Content-Type-Options": "nosniff"}
        if etag_matches(request.headers.get("if-none-match"), page.etag):
            return Response(status_code=304, headers=headers)
        return Response(page.body, media_type=page.media_type, headers=headers)


def app_for(root: str | Path) -> FastAPI:
    """The application of the server whose folder is ``root`` (for ``uvicorn --factory``)."""
    return create_app(EvaluationServer(ServerConfig.from_env(root)))
