"""How long a preview of a large output takes: render_html, and optionally the browser.

    python -m tools.bench_preview                 # render time, median of 5
    python -m tools.bench_preview --browser       # also Chromium's time to draw the page
    python -m tools.bench_preview --small         # a quick check that it runs

Two outputs, written with the SDK's writer: a report of 365 batches (LINE_PLOTs of one
point per batch, BATCHWISE_BAR_CHARTs of four status categories over the 365 batches)
and a batch output with 20,000-point series (DOUBLE_OVER_TIME with statuses and a gap,
STATES_OVER_TIME, a HISTOGRAM of 20,000 values). The target is under 2 s each; measure
on a quiet machine, as timing on a loaded one says nothing.
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
import time
import uuid
from datetime import UTC, datetime, timedelta
from pathlib import Path

from stook.sdk import MetricStatus, MetricsWriter, data
from stook.service.preview import render_html, write_preview

START = datetime(2026, 1, 1, tzinfo=UTC)
STATUSES = ["PASSED", "FAIL_WARN", "FAIL_BLOCK", "NOT_APPLICABLE"]


def report_output(folder: Path, batches: int) -> Path:
    writer = MetricsWriter(uuid.UUID(int=365))
    days = [float(d) for d in range(batches)]
    for k in range(12):
        writer.line_plot(
            f"Batch metric {k} over time",
            data.doubles(f"days {k}", days, unit="days"),
            data.doubles(f"values {k}", [math.sin(d / 30 + k) + k for d in days]),
            x_axis_name="Days since the first batch",
            y_axis_name=f"Batch metric {k}",
        )
    ids = data.uuids("Batches", [uuid.UUID(int=i + 1) for i in range(batches)])
    for chart in range(4):
        times = [
            data.timestamps(
                f"times {chart} {s}", [START + timedelta(days=d) for d in range(batches)], index=ids
            )
            for s in STATUSES
        ]
        values = [
            data.doubles(
                f"counts {chart} {s}",
                [float((d * (i + 3)) % 17) for d in range(batches)],
                index=ids,
            )
            for i, s in enumerate(STATUSES)
        ]
        writer.batchwise_bar_chart(
            f"Tests per status, chart {chart}",
            project_id=uuid.UUID(int=99),
            times=times,
            values=values,
            categories=STATUSES,
            y_axis_name="Tests",
        )
    writer.text("Report summary", f"{batches} batches, synthetic.")
    return writer.write(folder / "report" / "metrics.binproto")


def batch_output(folder: Path, points: int) -> Path:
    writer = MetricsWriter(uuid.UUID(int=20_000))
    times = data.timestamps("Time", [START + timedelta(milliseconds=50 * i) for i in range(points)])
    for k in range(4):
        values = [math.sin(i / 400 + k) * 10 + (i % 97) / 50 for i in range(points)]
        values[points // 3] = math.nan
        series = data.doubles(f"Signal {k}", values, unit="m/s", index=times)
        statuses = data.statuses(
            f"Signal {k} status",
            [MetricStatus.FAIL_WARN if v > 9 else MetricStatus.PASSED for v in values],
            index=times,
        )
        writer.double_over_time(
            f"Signal {k} over time", [series], statuses=[statuses], failures=[(9.0, None)]
        )
        writer.histogram(
            f"Signal {k} distribution",
            data.doubles(f"signal {k} values", [v for v in values if v == v]),
            buckets=40,
            lower=-12.0,
            upper=12.0,
        )
    states = data.strings(
        "Planner state",
        ["cruise" if (i // 700) % 3 else "brake" for i in range(points)],
        index=times,
    )
    writer.states_over_time("Planner state over time", states, states_set=["cruise", "brake"])
    return writer.write(folder / "batch" / "metrics.binproto")


def timed(path: Path, repeats: int) -> list[float]:
    render_html(path)  # plotly.js read once per process, as a command would
    seconds = []
    for _ in range(repeats):
        started = time.perf_counter()
        render_html(path)
        seconds.append(time.perf_counter() - started)
    return seconds


def browser_seconds(page_file: Path) -> float:
    from playwright.sync_api import sync_playwright

    args = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run"]
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path="/usr/bin/chromium", args=args)
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        started = time.perf_counter()
        page.goto(page_file.as_uri())
        page.wait_for_selector("body[data-figures]", timeout=120_000)
        took = time.perf_counter() - started
        browser.close()
    return took


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="small sizes: a smoke test")
    parser.add_argument("--browser", action="store_true", help="also time Chromium's drawing")
    args = parser.parse_args()
    batches, points, repeats = (20, 500, 1) if args.small else (365, 20_000, 5)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for label, path in (
            (f"report of {batches} batches", report_output(folder, batches)),
            (f"batch output, {points:,}-point series", batch_output(folder, points)),
        ):
            seconds = timed(path, repeats)
            size = path.stat().st_size / 1e6
            line = (
                f"{label} ({size:.1f} MB): render_html median {statistics.median(seconds):.3f} s "
                f"(min {min(seconds):.3f}, max {max(seconds):.3f}, n={repeats})"
            )
            if args.browser:
                page_file = write_preview(path, path.with_suffix(".html"))
                # A fresh browser each time: a user opens the page once.
                drawn = [browser_seconds(page_file) for _ in range(3 if repeats > 1 else 1)]
                line += (
                    f"; Chromium opens and draws it in {statistics.median(drawn):.2f} s "
                    f"(median of {len(drawn)}: {', '.join(f'{d:.2f}' for d in drawn)})"
                )
            print(line)


if __name__ == "__main__":
    main()
