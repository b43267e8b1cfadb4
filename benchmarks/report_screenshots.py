"""Screenshots of a report site in headless Chromium, for docs/images/.

    python benchmarks/report_screenshots.py SITE/ docs/images/ [--method SLUG]

Writes ``report-index.png`` (the site's index) and ``report-method.png`` (a method page: the
first one, or ``SITE/<edition>/<SLUG>.html``), each cut to ``--max-height`` pixels.
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("site", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--method", default=None, help="method page slug (default: the first)")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--max-height", type=int, default=1500)
    args = ap.parse_args()
    spec = importlib.util.spec_from_file_location("site_browser",
                                                  REPO / "tests" / "viz" / "browser.py")
    browser = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(browser)
    pages = sorted(p for p in args.site.glob("*/*.html") if p.name != "index.html")
    if args.method:
        pages = [p for p in pages if p.stem == args.method]
    if not pages:
        raise SystemExit(f"no method page in {args.site}")
    args.out.mkdir(parents=True, exist_ok=True)
    with browser.chromium(args.width, 900) as drv:
        for page, name in ((args.site / "index.html", "report-index.png"),
                           (pages[0], "report-method.png")):
            drv.get(page.resolve().as_uri())
            drv.execute_async_script(   # wait for every picture, then measure the page
                "const done = arguments[arguments.length - 1];"
                "Promise.all(Array.from(document.images).map(i => i.decode().catch(() => 0)))"
                ".then(() => done(true));")
            h = drv.execute_script("return document.documentElement.scrollHeight;")
            chrome = drv.execute_script("return window.outerHeight - window.innerHeight;")
            drv.set_window_size(args.width, min(int(h) + int(chrome or 0) + 20,
                                                args.max_height))
            drv.save_screenshot(str(args.out / name))
            print(f"{args.out / name}: {page}")


if __name__ == "__main__":
    main()
