"""Headless Chromium for the browser tests and the page-speed benchmark (Debian's
``chromium`` + ``chromium-driver``, driven by selenium; nothing is downloaded)."""

from __future__ import annotations

import contextlib
import functools
import http.server
import os
import shutil
import threading
from collections.abc import Iterator
from pathlib import Path


def chromium_paths() -> tuple[str | None, str | None, str]:
    """(chromium binary, chromedriver, reason when either is missing)."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return None, None, "selenium is not installed (pip install 'dressmeup[browser]')"
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not binary or not driver:
        return binary, driver, ("Debian's chromium and chromium-driver are not installed "
                                "(apt-get install chromium chromium-driver; .ci/setup.sh "
                                "does it)")
    return binary, driver, ""


@contextlib.contextmanager
def chromium(width: int = 1280, height: int = 900) -> Iterator:
    """A headless Chromium WebDriver that records the browser console."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    binary, driver_path, why = chromium_paths()
    if why:
        raise RuntimeError(why)
    # Selenium Manager sends usage statistics unless told not to (and the network is closed)
    os.environ["SE_AVOID_STATS"] = "true"
    opts = webdriver.ChromeOptions()
    opts.binary_location = binary
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                f"--window-size={width},{height}", "--disable-extensions",
                "--no-first-run", "--disable-background-networking",
                # WebGL on the CPU (SwiftShader) for the 3D views: no GPU in headless runs
                "--enable-unsafe-swiftshader"):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    drv = webdriver.Chrome(service=Service(executable_path=driver_path), options=opts)
    try:
        yield drv
    finally:
        drv.quit()


@contextlib.contextmanager
def serve(folder: Path) -> Iterator[str]:
    """Serve ``folder`` over http on 127.0.0.1 (a free port); yield the base URL."""

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args) -> None:  # keep test output clean
            pass

    handler = functools.partial(Quiet, directory=str(folder))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()
        httpd.server_close()


def console_errors(drv) -> list[dict]:
    """Console entries of level SEVERE since the last call."""
    return [e for e in drv.get_log("browser") if e.get("level") == "SEVERE"]


def images_state(drv) -> list[list]:
    """``[src, complete, naturalWidth]`` of every <img> of the page (scrolled into view)."""
    return drv.execute_script(
        "return Array.from(document.images).map(i => [i.getAttribute('src'), i.complete, "
        "i.naturalWidth]);")
