"""The client side of the evaluation server (``dressmeup submit``): pack a submission folder,
upload it, poll its state. Plain ``urllib``: nothing to install on an author's machine."""

from __future__ import annotations

import json
import tempfile
import time
import urllib.error
import urllib.request
import zipfile
from pathlib import Path
from typing import Any

from dressmeup.errors import InputError


def _request(req: urllib.request.Request, timeout: float = 600) -> dict[str, Any]:
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return json.loads(r.read() or b"{}")
    except urllib.error.HTTPError as exc:
        try:
            body = json.loads(exc.read() or b"{}")
        except ValueError:
            body = {}
        if exc.code == 422 and "problems" in body:
            return body
        raise InputError(f"the server answered {exc.code}: "
                         f"{body.get('detail', exc.reason)}") from exc
    except (urllib.error.URLError, OSError) as exc:
        raise InputError(f"cannot reach the server ({exc})") from exc


def submit(folder: Path, edition: str, server: str, token: str) -> dict[str, Any]:
    """Zip ``folder`` and upload it; the server's answer (``id`` and ``status``, or
    ``problems``)."""
    with tempfile.TemporaryDirectory() as tmp:
        archive = Path(tmp) / "submission.zip"
        with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as z:
            for p in sorted(Path(folder).iterdir()):
                if p.is_file() and not p.name.startswith("."):
                    z.write(p, p.name)
        url = f"{server.rstrip('/')}/api/submissions?edition={urllib.request.quote(edition)}"
        with open(archive, "rb") as fh:
            req = urllib.request.Request(
                url, data=fh, method="POST",
                headers={"Authorization": f"Bearer {token}",
                         "Content-Type": "application/octet-stream",
                         "Content-Length": str(archive.stat().st_size)})
            return _request(req)


def status(server: str, token: str, sub_id: str) -> dict[str, Any]:
    """The state of one submission."""
    req = urllib.request.Request(f"{server.rstrip('/')}/api/submissions/{sub_id}",
                                 headers={"Authorization": f"Bearer {token}"})
    return _request(req, timeout=60)


def wait_for(server: str, token: str, sub_id: str, timeout: float = 3600,
             every: float = 2.0) -> dict[str, Any]:
    """Poll until the submission is ``scored`` or ``failed`` (or ``timeout`` seconds)."""
    t0 = time.monotonic()
    while True:
        state = status(server, token, sub_id)
        if state.get("status") in ("scored", "failed") or time.monotonic() - t0 > timeout:
            return state
        time.sleep(every)
