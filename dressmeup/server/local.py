"""A server on this machine for a demonstration: started in a thread, given the team
``demo`` and an edition's private part, sent submission folders over HTTP like any author
would (``dressmeup demo --serve``)."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import uvicorn

from dressmeup.server.accounts import add_team, team_for_token
from dressmeup.server.app import create_app
from dressmeup.server.client import submit, wait_for
from dressmeup.server.config import ServerConfig
from dressmeup.server.service import EvaluationServer


class LocalServer:
    """A running server on 127.0.0.1 (a free port unless one is given)."""

    def __init__(self, root: Path, port: int = 0) -> None:
        self.server = EvaluationServer(ServerConfig(Path(root), daily_limit=1000,
                                                    poll_seconds=0.2))
        if not port:
            with socket.socket() as s:
                s.bind(("127.0.0.1", 0))
                port = s.getsockname()[1]
        self.url = f"http://127.0.0.1:{port}"
        self._uv = uvicorn.Server(uvicorn.Config(create_app(self.server), host="127.0.0.1",
                                                 port=port, log_level="warning"))
        self._thread = threading.Thread(target=self._uv.run, daemon=True)

    def __enter__(self) -> LocalServer:
        self._thread.start()
        for _ in range(300):
            if self._uv.started:
                return self
            time.sleep(0.1)
        raise RuntimeError("the local evaluation server did not start")

    def __exit__(self, *exc: Any) -> None:
        self._uv.should_exit = True
        self._thread.join(timeout=600)

    def wait_forever(self) -> None:
        """Serve until interrupted (Ctrl-C)."""
        try:
            while self._thread.is_alive():
                self._thread.join(timeout=1.0)
        except KeyboardInterrupt:
            pass


def submit_all(local: LocalServer, edition: str, private: Path,
               submissions: Sequence[Path], log: Callable[[str], Any]) -> list[dict]:
    """Add the team ``demo`` and the edition, submit each folder, wait for its score and
    publish it under its method name; the final states."""
    with local.server.sessions() as s:
        token = add_team(s, "demo")[1]
    local.server.add_edition(edition, private)
    states = []
    for sub in submissions:
        ans = submit(Path(sub), edition, local.url, token)
        if "problems" in ans:
            log(f"  server refused {Path(sub).name}: {ans['problems'][0]}")
            continue
        state = wait_for(local.url, token, ans["id"], timeout=1800, every=0.5)
        if state["status"] == "scored":
            local.server.publish(_team(local, token), ans["id"], state["method"])
        log(f"  {state['method']}: {state['status']}"
            + (f" ({state['error']})" if state.get("error") else ""))
        states.append(state)
    return states


def _team(local: LocalServer, token: str):
    with local.server.sessions() as s:
        return team_for_token(s, token)
