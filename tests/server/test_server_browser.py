"""The server's pages in headless Chromium: the public leaderboard (rows, sorting by a click,
a ``<script>`` method name shown as text) and the team page (token typed into its form)."""

from __future__ import annotations

import importlib.util
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("fastapi")
uvicorn = pytest.importorskip("uvicorn")

_b = importlib.util.spec_from_file_location(
    "site_browser", Path(__file__).resolve().parents[1] / "viz" / "browser.py")
browser = importlib.util.module_from_spec(_b)
_b.loader.exec_module(browser)
_, _, WHY = browser.chromium_paths()
pytestmark = pytest.mark.skipif(bool(WHY), reason=WHY or "")

_s = importlib.util.spec_from_file_location(
    "server_api", Path(__file__).resolve().parent / "test_server_api.py")
api = importlib.util.module_from_spec(_s)
_s.loader.exec_module(api)

EVIL = "<script>window.__pwned = 1</script>Rigid"


@pytest.fixture(scope="module")
def live(tiny_parts, submission, tmp_path_factory):
    """A server on 127.0.0.1 with two published results (one named with a script tag)."""
    import socket

    from fastapi.testclient import TestClient

    from dressmeup.server.app import create_app

    _, _, private, _ = tiny_parts
    srv, tokens = api.make_server(tmp_path_factory.mktemp("live"), private)
    app = create_app(srv)
    with TestClient(app) as c:
        for team, name in (("lab-a", EVIL), ("lab-b", "Plain")):
            r = c.post(f"/api/submissions?edition={api.EDITION}",
                       headers=api.auth(tokens[team]), content=api.fx.zip_folder(submission))
            sub_id = r.json()["id"]
            assert api.wait(c, tokens[team], sub_id)["status"] == "scored"
            c.post(f"/api/submissions/{sub_id}/publish", headers=api.auth(tokens[team]),
                   json={"method": name})
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(create_app(srv), host="127.0.0.1", port=port,
                                           log_level="warning"))
    t = threading.Thread(target=server.run, daemon=True)
    t.start()
    for _ in range(100):
        if server.started:
            break
        time.sleep(0.1)
    yield f"http://127.0.0.1:{port}", tokens
    server.should_exit = True
    t.join(timeout=30)


@pytest.fixture(scope="module")
def drv():
    with browser.chromium() as d:
        yield d


def test_public_leaderboard_rows_sorting_and_escaping(drv, live):
    from selenium.webdriver.common.by import By

    base, _ = live
    drv.get(f"{base}/leaderboard/")
    assert browser.console_errors(drv) == []
    assert drv.execute_script("return window.__pwned === undefined")
    table = drv.find_element(By.CSS_SELECTOR, "table.leaderboard")
    rows = table.find_elements(By.CSS_SELECTOR, "tbody tr")
    assert len(rows) == 2
    names = [r.find_element(By.CSS_SELECTOR, "td.method").text for r in rows]
    assert any(EVIL in n for n in names)                       # the tag shown as text
    header = table.find_elements(By.CSS_SELECTOR, "thead th")[1]
    header.click()
    after = [r.find_element(By.CSS_SELECTOR, "td.method").text
             for r in table.find_elements(By.CSS_SELECTOR, "tbody tr")]
    assert sorted(after) == sorted(names)


def test_team_page_lists_the_teams_own_submissions(drv, live):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support import expected_conditions as ec
    from selenium.webdriver.support.ui import WebDriverWait

    base, tokens = live
    drv.get(f"{base}/team")
    drv.find_element(By.ID, "token").send_keys(tokens["lab-a"])
    drv.find_element(By.CSS_SELECTOR, "#login button").click()
    WebDriverWait(drv, 20).until(ec.visibility_of_element_located((By.ID, "subs")))
    rows = drv.find_elements(By.CSS_SELECTOR, "#subs tbody tr")
    assert len(rows) == 1 and "scored" in rows[0].text and EVIL in rows[0].text
    assert drv.execute_script("return window.__pwned === undefined")
    drv.find_element(By.ID, "token").clear()
    drv.find_element(By.ID, "token").send_keys("dmu_wrong")
    drv.find_element(By.CSS_SELECTOR, "#login button").click()
    WebDriverWait(drv, 20).until(lambda d: "refused" in d.find_element(By.ID, "error").text)
