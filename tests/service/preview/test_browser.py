"""The previews in a real browser: headless Chromium (the system's, driven by Playwright).

They skip with a reason where Chromium or Playwright is missing, except in CI (CI=true,
set by .ci/run, which installs Chromium): there a missing browser fails them.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from stook.sdk import MetricType, read_job_metrics
from stook.service.preview import write_preview
from stook.service.preview._values import number_text
from tests.service.preview.support import (
    BATCH_OUTPUT,
    REPORT_OUTPUT,
    expected_points,
    write_example,
)

CHROMIUM = Path(os.environ.get("STOOK_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]

pytestmark = pytest.mark.slow


def _unavailable() -> str | None:
    if not CHROMIUM.is_file() and shutil.which(str(CHROMIUM)) is None:
        return f"no Chromium at {CHROMIUM} (apt-get install chromium, or set STOOK_CHROMIUM)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "Playwright for Python is not installed (make setup)"
    return None


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    reason = _unavailable()
    if reason is not None:
        if os.environ.get("CI") == "true":
            pytest.fail(f"browser tests are mandatory in CI: {reason}")
        pytest.skip(reason)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        yield chromium
        chromium.close()


def open_page(browser: Any, html: Path) -> tuple[Any, list[str]]:
    """The page, drawn, and every console error and uncaught exception it raised."""
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    # Offline: any request other than the file itself fails the test.
    requests: list[str] = []
    page.on(
        "request",
        lambda r: requests.append(r.url) if not r.url.startswith(("file:", "data:")) else None,
    )
    page.goto(html.as_uri())
    page.wait_for_selector("body[data-figures]", timeout=30_000)
    assert requests == []
    return page, errors


_DRAWN = """() => Array.from(document.querySelectorAll('.metric .plot')).map(d => ({
  metric: d.dataset.metric,
  drawn: d.classList.contains('js-plotly-plot') && d.querySelector('svg.main-svg') !== null,
  points: (d.data || []).map(t => (t.y || []).length),
}))"""


def check_charts(page: Any, source: Path) -> None:
    view = read_job_metrics(source.read_bytes())
    expected = expected_points(view)
    drawn = page.evaluate(_DRAWN)
    assert sorted(d["metric"] for d in drawn) == sorted(
        m.name for m in view.metrics if m.name in expected
    )
    for figure in drawn:
        assert figure["drawn"], figure["metric"]
        assert figure["points"] == expected[figure["metric"]], figure["metric"]
    # Every scalar's value is on the page as people read it, and as written on hover.
    for metric in view.metrics:
        if (
            metric.type is MetricType.SCALAR
            and metric.value is not None
            and not metric.event_metric
        ):
            card = page.locator(f'.metric[data-metric="{metric.name}"] .scalar')
            assert card.inner_text().startswith(number_text(metric.value)), metric.name
            assert card.get_attribute("title") == repr(metric.value), metric.name


def preview_of(source: Path, folder: Path) -> Path:
    return write_preview([source], folder / "preview.html")


def test_the_every_metric_type_example(browser: Any, tmp_path: Path) -> None:
    source = write_example(tmp_path / "example")
    page, errors = open_page(browser, preview_of(source, tmp_path))
    check_charts(page, source)
    assert page.locator('.metric[data-metric="Notes"] .text strong').inner_text() == "speed"
    images = page.evaluate(
        "() => Array.from(document.images).map(i => i.complete && i.naturalWidth > 0)"
    )
    assert images == [True, True, True]
    # The event, on its timeline, with its own metric.
    assert page.locator('.event[data-event="Hard brake"] .scalar').inner_text().startswith("6.5")
    assert errors == []


@pytest.mark.parametrize("source", [BATCH_OUTPUT, REPORT_OUTPUT], ids=["batch", "report"])
def test_batch_and_report_outputs(browser: Any, tmp_path: Path, source: Path) -> None:
    page, errors = open_page(browser, preview_of(source, tmp_path))
    check_charts(page, source)
    view = read_job_metrics(source.read_bytes())
    texts = [m for m in view.metrics if m.type is MetricType.TEXT]
    for metric in texts:
        shown = page.locator(f'.metric[data-metric="{metric.name}"] .text').inner_text()
        # The first words as written, Markdown marks aside (a table's pipes, emphasis).
        written = metric.raw.metric_values.text_metric_values.text.split()
        words = [w.strip("*_`#|") for w in written]
        first = [w for w in words if w and not set(w) <= set("-:|")][:3]
        assert " ".join(first) in " ".join(shown.split()), metric.name
    assert errors == []


def test_several_files_side_by_side_in_a_narrow_window(browser: Any, tmp_path: Path) -> None:
    html = write_preview([BATCH_OUTPUT, REPORT_OUTPUT], tmp_path / "both.html")
    page, errors = open_page(browser, html)
    page.set_viewport_size({"width": 700, "height": 900})
    columns = page.evaluate(
        "() => getComputedStyle(document.querySelector('main.grid'))"
        ".gridTemplateColumns.split(' ').length"
    )
    assert columns == 2
    files = page.locator(".card.file h3").all_inner_texts()
    assert files == [str(BATCH_OUTPUT), str(REPORT_OUTPUT)]
    assert errors == []


# What a reader would see go wrong at a width: the page wider than the window, a header
# broken inside a word, tick labels cut off at the figure's edge, a figure not drawn.
_LAYOUT_FAULTS = """() => {
  const faults = [];
  if (document.documentElement.scrollWidth > window.innerWidth + 1) {
    faults.push(`page is ${document.documentElement.scrollWidth} px wide`);
  }
  for (const th of document.querySelectorAll('.text th')) {
    const line = parseFloat(getComputedStyle(th).lineHeight) || 20;
    const box = th.getBoundingClientRect();
    if (box.height > 1.5 * line + 8) faults.push(`header "${th.innerText}" is broken`);
  }
  for (const plot of document.querySelectorAll('.plot')) {
    const svg = plot.querySelector('svg.main-svg');
    if (!svg) { faults.push(`${plot.dataset.metric}: not drawn`); continue; }
    const frame = svg.getBoundingClientRect();
    for (const tick of plot.querySelectorAll('.xtick text, .ytick text')) {
      const box = tick.getBoundingClientRect();
      if (box.width === 0) continue;
      if (box.left < frame.left - 1 || box.right > frame.right + 1 ||
          box.bottom > frame.bottom + 1) {
        faults.push(`${plot.dataset.metric}: tick "${tick.textContent}" is cut off`);
      }
    }
  }
  return faults;
}"""

DEMO_PAGES = ["test-mode", ".", "report", "comparison", "metrics-config"]


@pytest.fixture(scope="module")
def demo_output(tmp_path_factory: pytest.TempPathFactory) -> Path:
    # `stook demo` itself, in its own process: Playwright's loop runs in this one.
    output = tmp_path_factory.mktemp("demo")
    stook = Path(sys.executable).with_name("stook")
    command = [str(stook), "demo", "--jobs", "40", "--seed", "7", "--output", str(output)]
    subprocess.run(command, check=True, capture_output=True, timeout=300)
    return output


@pytest.mark.parametrize("width", [1400, 700])
@pytest.mark.parametrize("folder", DEMO_PAGES)
def test_every_demo_page_reads_at_a_wide_and_a_narrow_width(
    browser: Any, demo_output: Path, folder: str, width: int
) -> None:
    page, errors = open_page(browser, demo_output / folder / "metrics.html")
    page.set_viewport_size({"width": width, "height": 900})
    page.wait_for_timeout(300)  # plotly redraws on resize
    assert page.evaluate(_LAYOUT_FAULTS) == []
    assert page.locator(".placeholder").all_inner_texts() == []  # every image is shown
    assert errors == []
