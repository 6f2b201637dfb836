"""Screenshots of the demo's previews for docs/: the first screen of each, as a reader sees it.

    make demo && python -m tools.screenshot_previews            # demo-output/ -> docs/
    python -m tools.screenshot_previews --demo /tmp/demo --out /tmp/shots

Uses the system's Chromium (STOOK_CHROMIUM, default /usr/bin/chromium) through Playwright.
Prints each page's header line beside its screenshot: docs/preview.md's captions quote
its numbers, and tests/service/preview/test_screenshots.py checks them against the pages
the demo writes today.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

PAGES = {
    "test": Path("test-mode") / "metrics.html",
    "batch": Path("metrics.html"),
    "report": Path("report") / "metrics.html",
    "comparison": Path("comparison") / "metrics.html",
    "config": Path("metrics-config") / "metrics.html",
}
"""Each screenshot's name (docs/preview-NAME.png) and the demo's page it shows."""
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--hide-scrollbars"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--demo", type=Path, default=Path("demo-output"))
    parser.add_argument("--out", type=Path, default=Path("docs"))
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=860)
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    chromium = os.environ.get("STOOK_CHROMIUM", "/usr/bin/chromium")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=ARGS)
        for name, relative in PAGES.items():
            page = browser.new_page(viewport={"width": args.width, "height": args.height})
            page.goto((args.demo / relative).resolve().as_uri())
            page.wait_for_selector("body[data-figures]", timeout=60_000)
            target = args.out / f"preview-{name}.png"
            page.screenshot(path=str(target))
            header = " ".join(page.locator(".card.file .meta").first.inner_text().split())
            print(f"{target}: {target.stat().st_size / 1000:.0f} kB; {header}")
            page.close()
        browser.close()


if __name__ == "__main__":
    main()
