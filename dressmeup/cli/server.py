"""``dressmeup serve``, ``dressmeup server ...`` (teams, editions) and ``dressmeup submit``
(docs/server.md)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from dressmeup.cli.checks import host, http_url, integer, new_output, number, team_name
from dressmeup.cli.executor_args import add_executor_args
from dressmeup.errors import InputError
from dressmeup.server.client import submit, wait_for
from dressmeup.server.config import ServerConfig


def _root_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--root", required=True, type=new_output,
                   help="the server's folder (database, uploads, results, public pages)")
    p.add_argument("--database", default=None, help="SQLAlchemy URL (default: SQLite in "
                   "ROOT/server.db; e.g. postgresql+psycopg://user:pw@host/db)")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register ``serve``, ``server`` and ``submit``."""
    p = subparsers.add_parser(
        "serve", help="run the evaluation server (method authors submit, it scores)",
        description="Run the evaluation server: the HTTP API (/api/..., OpenAPI at "
                    "/openapi.json), the public leaderboards (/leaderboard/) and a team page "
                    "(/team); a background scorer scores accepted submissions against the "
                    "editions' private parts. Add teams and editions with 'dressmeup server'.")
    _root_args(p)
    p.add_argument("--host", default="127.0.0.1", type=host, help="address to listen on (default "
                   "127.0.0.1; put a reverse proxy in front for the internet)")
    p.add_argument("--port", type=integer(0, 65535), default=8000)
    p.add_argument("--daily-limit", type=integer(1), default=3,
                   help="accepted submissions per team, edition and UTC day (default 3)")
    p.add_argument("--max-upload-mb", type=integer(1, 1 << 20), default=512)
    add_executor_args(p, default_workers=1, what="scored item of a submission")
    p.set_defaults(func=_serve)

    p = subparsers.add_parser("server", help="manage an evaluation server's teams and "
                              "editions", description="Teams (API tokens, shown once and "
                              "stored as hashes) and editions (with their private parts) of "
                              "an evaluation server.")
    ssub = p.add_subparsers(dest="server_command", metavar="ACTION", required=True)
    c = ssub.add_parser("add-team", help="create a team and print its API token once")
    _root_args(c)
    c.add_argument("name", type=team_name)
    c.set_defaults(func=_add_team)
    c = ssub.add_parser("revoke-team", help="revoke a team's token")
    _root_args(c)
    c.add_argument("name", type=team_name)
    c.set_defaults(func=_revoke_team)
    c = ssub.add_parser("add-edition", help="score an edition, given its private part")
    _root_args(c)
    c.add_argument("name", help="a shipped edition")
    c.add_argument("--private", required=True, help="the edition's private part (checked "
                   "against its pin first)")
    c.set_defaults(func=_add_edition)
    c = ssub.add_parser("list", help="teams, editions and submission counts")
    _root_args(c)
    c.set_defaults(func=_list)

    p = subparsers.add_parser(
        "submit", help="send a submission folder to an evaluation server",
        description="Pack SUBMISSION (submission.json + one file per item) and upload it; "
                    "prints the submission id, or every problem the server's validator found. "
                    "With --wait, polls until it is scored and prints the summary.")
    p.add_argument("submission", help="submission folder")
    p.add_argument("--edition", "-e", required=True)
    p.add_argument("--server", required=True, type=http_url,
                   help="base URL, e.g. http://127.0.0.1:8000")
    p.add_argument("--token", required=True, help="your team's API token")
    p.add_argument("--wait", action="store_true", help="wait for the score")
    p.add_argument("--timeout", type=number(0.0, 1e7, lo_open=True), default=3600,
                   help="seconds --wait waits")
    p.set_defaults(func=_submit)


def _server(args: argparse.Namespace, **kw):
    # start-up: the stage loads when the command runs
    from sqlalchemy.exc import ArgumentError, NoSuchModuleError

    from dressmeup.server.service import EvaluationServer

    try:
        return EvaluationServer(ServerConfig(Path(args.root), database=args.database, **kw))
    except (ArgumentError, NoSuchModuleError) as exc:
        raise InputError(f"--database {args.database}: not a database URL this server can use "
                         f"({exc}); e.g. sqlite:///server.db or "
                         "postgresql+psycopg://user:pw@host/db") from exc


def _serve(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    import uvicorn

    from dressmeup.server.app import create_app

    server = _server(args, daily_limit=args.daily_limit, max_upload_mb=args.max_upload_mb,
                     workers=args.workers or 1, executor=args.executor or "local",
                     scheduler=args.scheduler)
    sys.stdout.write(f"dressmeup evaluation server on http://{args.host}:{args.port} "
                     f"(folder {args.root}); leaderboards at /leaderboard/, API at /api\n")
    sys.stdout.flush()
    uvicorn.run(create_app(server), host=args.host, port=args.port, log_level="warning")
    return 0


def _add_team(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.server.accounts import add_team

    server = _server(args)
    with server.sessions() as s:
        team, token = add_team(s, args.name)
    sys.stdout.write(f"team {team.name} created; its API token (shown only now, keep it "
                     f"secret):\n{token}\n")
    return 0


def _revoke_team(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.server.accounts import revoke_team

    server = _server(args)
    with server.sessions() as s:
        team = revoke_team(s, args.name)
    sys.stdout.write(f"team {team.name}: token revoked\n")
    return 0


def _add_edition(args: argparse.Namespace) -> int:
    server = _server(args)
    row = server.add_edition(args.name, args.private)
    sys.stdout.write(f"edition {row.name} scored from {row.private_root}\n")
    return 0


def _list(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from sqlalchemy import func, select

    from dressmeup.server.db import Submission, Team
    from dressmeup.server.editions import registered

    server = _server(args)
    with server.sessions() as s:
        for t in s.scalars(select(Team).order_by(Team.name)):
            n = s.scalar(select(func.count()).select_from(Submission)
                         .where(Submission.team_id == t.id))
            state = "revoked" if t.revoked_at else "active"
            sys.stdout.write(f"team {t.name}: {state}, {n} submission(s)\n")
        for e in registered(s):
            sys.stdout.write(f"edition {e.name}: {e.private_root}\n")
    return 0


def _submit(args: argparse.Namespace) -> int:
    sub = Path(args.submission)
    if not (sub / "submission.json").is_file():
        raise InputError(f"{sub} is not a submission folder (no submission.json)")
    answer = submit(sub, args.edition, args.server, args.token)
    if "problems" in answer:
        sys.stdout.write("the server refused the submission:\n  "
                         + "\n  ".join(answer["problems"]) + "\n")
        return 1
    sys.stdout.write(f"submission {answer['id']} accepted ({answer['status']})\n")
    if not args.wait:
        return 0
    state = wait_for(args.server, args.token, answer["id"], timeout=args.timeout)
    sys.stdout.write(json.dumps(state, indent=2) + "\n")
    return 0 if state.get("status") == "scored" else 1


