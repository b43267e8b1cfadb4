"""The report site in a real browser (headless Chromium over file:// and a local
http.server on 127.0.0.1): no console errors, one row per method, sorting by a click on a
header, every picture loaded, an HTML-injection method name shown as text, and a method
page's 3D view drawn and answering its checkboxes, item list and mouse.

Skipped with the reason when chromium, chromium-driver or selenium is absent (CI installs
them in .ci/setup.sh)."""

from __future__ import annotations

import importlib.util
import io
import json
from pathlib import Path

import numpy as np
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


def _pixels(drv, css: str) -> np.ndarray:
    from PIL import Image

    png = drv.find_element("css selector", css).screenshot_as_png
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def _open(drv, url: str):
    from selenium.webdriver.support.ui import WebDriverWait

    drv.get(url)
    WebDriverWait(drv, 30).until(lambda d: d.execute_script(
        "const r = document.getElementById('viewer3d'); return r && r.dataset.ready === '1';"))
    drv.execute_script("document.getElementById('viewer3d').scrollIntoView();")


def _differs(a: np.ndarray, b: np.ndarray) -> float:
    """Share of pixels that changed."""
    return float(np.mean(np.any(a != b, axis=-1)))


def _noisy_page(base_url: str, site) -> str:
    page = next(p for p in site.method_pages if p.stem == "noisy")
    return f"{base_url}/{page.relative_to(site.index.parent).as_posix()}"


def test_3d_view_renders_and_responds(drv, base_url, site, tmp_path):
    """The method page's 3D view: three.js loads as classic scripts, the canvas shows a
    varied picture, each checkbox, the item list, a drag and the wheel change what is
    drawn, the colour bar shows the scale, and the console stays free of errors."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select

    _open(drv, _noisy_page(base_url, site))
    assert browser.console_errors(drv) == []
    assert drv.execute_script("return typeof THREE.OrbitControls") == "function"
    canvas = "#viewer3d .v3d-canvas"
    first = _pixels(drv, canvas)
    background = np.array([0xf6, 0xf7, 0xf9])
    drawn = np.any(np.abs(first - background) > 8, axis=-1)
    assert 0.05 < drawn.mean() < 0.95                   # something drawn, not a blank fill
    assert len(np.unique(first.reshape(-1, 3), axis=0)) > 200      # shaded, coloured
    (tmp_path / "view.png").write_bytes(
        drv.find_element(By.CSS_SELECTOR, "#viewer3d").screenshot_as_png)

    box = {b.get_attribute("data-layer"): b for b in
           drv.find_elements(By.CSS_SELECTOR, "#viewer3d input[data-layer]")}
    assert set(box) == {"pred", "gt", "body"}
    assert box["pred"].is_selected() and box["body"].is_selected()
    assert not box["gt"].is_selected()
    seen = [first]
    for layer in ("gt", "pred", "body"):         # truth on, prediction off, body off
        box[layer].click()
        now = _pixels(drv, canvas)
        assert _differs(now, seen[-1]) > 0.005, layer
        seen.append(now)
    # only the see-through truth is left: no error colours from the prediction
    box["pred"].click()
    with_pred = _pixels(drv, canvas)
    assert _differs(with_pred, seen[-1]) > 0.005
    box["body"].click()
    box["gt"].click()                            # back to the first state
    assert _differs(_pixels(drv, canvas), first) < 0.002

    # another item
    select = Select(drv.find_element(By.CSS_SELECTOR, "#viewer3d select.v3d-item"))
    assert len(select.options) >= 2
    select.select_by_index(len(select.options) - 1)
    other = _pixels(drv, canvas)
    assert _differs(other, first) > 0.005
    # drag turns, the wheel zooms
    el = drv.find_element(By.CSS_SELECTOR, canvas)
    ActionChains(drv).move_to_element(el).click_and_hold().move_by_offset(120, 30) \
        .release().perform()
    turned = _pixels(drv, canvas)
    assert _differs(turned, other) > 0.01
    ActionChains(drv).scroll_from_origin(ScrollOrigin.from_element(el), 0, -400).perform()
    assert _differs(_pixels(drv, canvas), turned) > 0.01

    # the colour bar: the scale's top matches the page's data, colours drawn
    vmax = drv.execute_script("return window.DRESSMEUP_VIEWS.vmax")
    ticks = drv.find_element(By.CSS_SELECTOR, "#viewer3d .v3d-ticks").text
    assert f"{vmax:.1f}" in ticks and ticks.startswith("0")
    bar = _pixels(drv, "#viewer3d .v3d-cbar")
    assert len(np.unique(bar.reshape(-1, 3), axis=0)) > 50
    assert browser.console_errors(drv) == []


def test_3d_view_items_are_the_pictured_items(drv, base_url, site):
    """The view's items are the page's pictured items, in the same order."""
    from selenium.webdriver.common.by import By

    _open(drv, _noisy_page(base_url, site))
    captions = [f.text for f in drv.find_elements(By.CSS_SELECTOR, "figure figcaption")]
    items = json.loads(drv.execute_script(
        "return JSON.stringify(window.DRESSMEUP_VIEWS.items.map(i => i.caption))"))
    assert items == captions and len(items) >= 2
