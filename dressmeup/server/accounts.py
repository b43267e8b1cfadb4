"""Teams and their API tokens.

A token is 32 random bytes (``secrets.token_urlsafe``) shown once when the team is made;
the database keeps only its sha256 (a token is as long as a key, so a plain hash suffices:
no dictionary attack applies). Revoking sets ``revoked_at``; a revoked token is refused.
"""

from __future__ import annotations

import hashlib
import re
import secrets

from sqlalchemy import select
from sqlalchemy.orm import Session

from dressmeup.errors import InputError
from dressmeup.server.db import Team, utcnow

TOKEN_PREFIX = "dmu_"
NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9 ._-]{0,99}$")


def token_sha256(token: str) -> str:
    """The stored form of a token."""
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


def add_team(session: Session, name: str) -> tuple[Team, str]:
    """Create a team; returns it and its token (the only time the token exists in clear).

    Raises
    ------
    InputError
        A name that is not 1-100 letters, digits, spaces, ``. _ -`` (starting with a letter
        or digit), or one already taken.
    """
    if not isinstance(name, str) or not NAME.match(name):
        raise InputError(f"team name {name!r}: use 1-100 letters, digits, spaces, '.', '_' or "
                         "'-', starting with a letter or digit")
    if session.scalar(select(Team).where(Team.name == name)) is not None:
        raise InputError(f"team {name!r} exists already")
    token = TOKEN_PREFIX + secrets.token_urlsafe(32)
    team = Team(name=name, token_sha256=token_sha256(token))
    session.add(team)
    session.commit()
    return team, token


def revoke_team(session: Session, name: str) -> Team:
    """Revoke a team's token (its submissions and results stay).

    Raises
    ------
    InputError
        No such team.
    """
    team = session.scalar(select(Team).where(Team.name == name))
    if team is None:
        raise InputError(f"no team {name!r}")
    if team.revoked_at is None:
        team.revoked_at = utcnow()
        session.commit()
    return team


def team_for_token(session: Session, token: str | None) -> Team | None:
    """The team a token belongs to, or None (missing, unknown or revoked token)."""
    if not token or not token.startswith(TOKEN_PREFIX) or len(token) > 200:
        return None
    team = session.scalar(select(Team).where(Team.token_sha256 == token_sha256(token)))
    if team is None or team.revoked_at is not None:
        return None
    return team
