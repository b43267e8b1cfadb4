"""The report site in a real browser (headless Chromium over file:// and a local
http.server on 127.0.0.1): no console errors, one row per method, sorting by a click on a
header, every picture loaded, an HTML-injection method name shown as text.

Skipped with the reason when chromium, chromium-driver or selenium is absent (CI installs
them in .ci/setup.sh)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_spec = importlib.util.spec_from_file_location("site_browser",
                                               Path(__file__).with_name("browser.py"))
browser = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(browser)

_, _, WHY = browser.chromium_paths()
pytestmark = pytest.mark.skipif(bool(WHY), reason=WHY or "")

EVIL = '<script>window.__pwned = 1</script><b>evil</b>'


@pytest.fixture(scope="module")
def drv():
    with browser.chromium() as d:
        yield d


@pytest.fixture(scope="module", params=["file", "http"])
def base_url(request, site):
    root = site.index.parent
    if request.param == "file":
        yield root.resolve().as_uri()
    else:
        with browser.serve(root) as url:
            yield url


def _load(drv, url: str):
    drv.get(url)
    drv.execute_script("window.scrollTo(0, document.body.scrollHeight);")
    drv.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "Promise.all(Array.from(document.images).map(i => i.decode().catch(() => null)))"
        ".then(() => done(true));")


def test_index(drv, base_url, site_inputs):
    from selenium.webdriver.common.by import By

    _load(drv, f"{base_url}/index.html")
    assert browser.console_errors(drv) == []
    imgs = browser.images_state(drv)        # the per-category chart of the edition
    assert len(imgs) == 1 and all(ok and width > 0 for _, ok, width in imgs), imgs
    table = drv.find_element(By.CSS_SELECTOR, "table.leaderboard")
    rows = table.find_elements(By.CSS_SELECTOR, "tbody tr")
    assert len(rows) == len(site_inputs["results"])          # one row per method
    # the injected name is text, its script never ran
    names = [r.find_element(By.CSS_SELECTOR, "td.method a").text for r in rows]
    assert EVIL in names
    assert drv.execute_script("return window.__pwned === undefined;")
    assert not drv.find_elements(By.CSS_SELECTOR, "td.method b")

    # click "Method": rows sorted by name; click again: reversed
    head = table.find_element(By.XPATH, ".//th[normalize-space(.)='Method']")
    head.click()
    got = [r.find_element(By.CSS_SELECTOR, "td.method a").text
           for r in table.find_elements(By.CSS_SELECTOR, "tbody tr")]
    assert got == sorted(names, key=str.casefold) or got == sorted(names)
    head.click()
    again = [r.find_element(By.CSS_SELECTOR, "td.method a").text
             for r in table.find_elements(By.CSS_SELECTOR, "tbody tr")]
    assert again == got[::-1]
    # click the ED column (numbers): ascending values, then descending
    ed_col = next(i for i, th in enumerate(table.find_elements(By.CSS_SELECTOR, "thead th"))
                  if th.text.startswith("ED"))
    th = table.find_elements(By.CSS_SELECTOR, "thead th")[ed_col]

    def column():
        return [float(r.find_elements(By.TAG_NAME, "td")[ed_col].get_attribute("data-v"))
                for r in table.find_elements(By.CSS_SELECTOR, "tbody tr")]

    th.click()
    asc = column()
    assert asc == sorted(asc) and asc[0] < asc[-1]
    th.click()
    assert column() == sorted(asc, reverse=True)
    assert browser.console_errors(drv) == []


def test_method_pages(drv, base_url, site):
    from selenium.webdriver.common.by import By

    for page in site.method_pages:
        rel = page.relative_to(site.index.parent).as_posix()
        _load(drv, f"{base_url}/{rel}")
        assert browser.console_errors(drv) == [], rel
        imgs = browser.images_state(drv)
        assert all(ok and width > 0 for _, ok, width in imgs), (rel, imgs)
        if page.stem == "gone":
            assert drv.find_elements(By.CSS_SELECTOR, "p.why") and len(imgs) == 1  # chart
        elif page.stem in ("gt", "noisy"):
            assert len(imgs) == 1 + 4                      # chart + 2 best + 2 worst
        assert drv.execute_script("return window.__pwned === undefined;")
        items = drv.find_element(By.CSS_SELECTOR, "table.items")
        assert len(items.find_elements(By.CSS_SELECTOR, "tbody tr")) == 18
