"""render_html without a browser: what the page holds, for every kind of input."""

from __future__ import annotations

import html
import json
import math
import re
import uuid
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    MetricImportance,
    MetricsWriter,
    MetricType,
    ReadError,
    data,
    read_job_metrics,
)
from stook.service.preview import PREVIEW_NAME, render_html, write_preview
from tests.service.preview.support import (
    BATCH_OUTPUT,
    REPORT_OUTPUT,
    expected_points,
    job_metrics,
    write_example,
)

START = datetime(2026, 1, 1, tzinfo=UTC)


def figures(page: str) -> list[dict[str, Any]]:
    found = re.search(r'<script type="application/json" id="stook-figures">(.*?)</script>', page)
    assert found is not None
    specs: list[dict[str, Any]] = json.loads(found.group(1))
    return specs


def figure_of(page: str, metric: str) -> dict[str, Any]:
    ids = re.findall(rf'<div class="plot" id="([^"]+)" data-metric="{re.escape(metric)}">', page)
    assert len(ids) == 1, (metric, ids)
    return next(f for f in figures(page) if f["id"] == ids[0])


def test_the_example_draws_each_chart_metric_once(tmp_path: Path) -> None:
    path = write_example(tmp_path)
    page = render_html([path])
    view = read_job_metrics(path.read_bytes())
    expected = expected_points(view)
    assert len(expected) == 7  # every chart type of the example
    for name, points in expected.items():
        figure = figure_of(page, name)
        assert [len(trace["y"]) for trace in figure["data"]] == points, name
    # one figure per chart metric, and the events' timeline
    assert len(figures(page)) == len(expected) + 1


def test_plotly_js_is_embedded_once_and_nothing_is_fetched(tmp_path: Path) -> None:
    page = render_html(write_example(tmp_path))
    assert page.count("Plotly.newPlot") == 1
    assert len(re.findall(r"plotly\.js v\d", page)) == 1  # the library's banner
    assert re.search(r"<(script|link|img)[^>]+(src|href)=\"(https?:)?//", page) is None


def test_every_metric_card_says_name_status_importance_tags_blocking(tmp_path: Path) -> None:
    writer = MetricsWriter(uuid.UUID(int=2))
    writer.scalar("Gap", 1.5, unit="m", fails_below=2.0, blocking=True).tag("area", "safety")
    writer.scalar("Low", 1.0).importance(MetricImportance.LOW)
    writer.scalar("Top", 2.0).importance(MetricImportance.CRITICAL).describe("the most important")
    page = render_html(read_job_metrics(writer.serialize()))
    # Dashboard order: importance (critical first), then as written.
    assert re.findall(r'<article class="card metric" data-metric="([^"]+)"', page) == [
        "Top",
        "Gap",
        "Low",
    ]
    gap = page[page.index('data-metric="Gap"') :]
    gap = gap[: gap.index("</article>")]
    assert ">FAIL_BLOCK</span>" in gap
    assert "blocking" in gap
    assert "area: safety" in gap
    assert "1.5" in gap
    assert "m</span>" in gap
    assert 'fails below <span title="2.0">2</span>' in gap
    assert "the most important" in page
    assert "critical importance" in page


def test_text_is_markdown_with_html_escaped() -> None:
    writer = MetricsWriter(uuid.UUID(int=3))
    writer.text(
        "Notes",
        "**bold** <script>alert(1)</script> <img src=x onerror=alert(2)> [x](javascript:alert(3))",
    )
    page = render_html(read_job_metrics(writer.serialize()))
    card = page[page.index('data-metric="Notes"') :]
    card = card[: card.index("</article>")]
    assert "<strong>bold</strong>" in card
    assert "<script>" not in card
    assert "<img" not in card
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in card
    assert 'href="javascript:' not in card


def test_a_file_the_validator_refuses_still_renders_and_says_why(tmp_path: Path) -> None:
    metric = pb.Metric(name="Orphan", type=pb.SCALAR_METRIC_TYPE, status=pb.PASSED_METRIC_STATUS)
    metric.metric_id.id.data = str(uuid.UUID(int=9))
    path = tmp_path / "broken.binproto"
    path.write_bytes(job_metrics(metric).SerializeToString())
    page = render_html(path)
    assert "The platform would refuse this file" in page
    assert '<ul class="problems"><li>' in page
    assert 'data-metric="Orphan"' in page


def test_not_job_metrics_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "notes.txt"
    path.write_bytes(b"\xff\xff\xff not protobuf")
    with pytest.raises(ReadError, match=r"notes\.txt"):
        render_html(path)
    with pytest.raises(FileNotFoundError):
        render_html(tmp_path / "absent.binproto")


def test_long_series_are_thinned_for_drawing_and_exact_in_tables() -> None:
    n = 20_000
    times = data.timestamps("t", [START + timedelta(milliseconds=10 * i) for i in range(n)])
    values = [math.sin(i / 500) + (0.1 if i == 12_345 else 0.0) for i in range(n)]
    values[7_000] = math.nan  # a gap
    series = data.doubles("Signal", values, index=times)
    writer = MetricsWriter(uuid.UUID(int=4))
    writer.double_over_time("Signal over time", [series])
    writer.double_summary("Signal at 12345", series, index=START + timedelta(milliseconds=123_450))
    page = render_html(read_job_metrics(writer.serialize()))
    figure = figure_of(page, "Signal over time")
    drawn = figure["data"][0]["y"]
    assert len(drawn) <= 3_000
    assert max(v for v in drawn if v is not None) == max(v for v in values if v == v)
    assert None in drawn  # the gap stays a gap
    assert "of 20,000 points" in json.dumps(figure["layout"]["annotations"])
    assert repr(values[12_345]) in page  # the summary's table: the number as written


def test_images_are_embedded_from_the_files_folder_or_named(tmp_path: Path) -> None:
    page = render_html(write_example(tmp_path / "with"))
    assert page.count('<img src="data:image/png;base64,') == 3  # front, and front + rear
    page = render_html(write_example(tmp_path / "without", frames=False))
    assert "<img" not in page
    assert html.escape("image 'front.png' is not beside the file") in page


def test_an_image_path_out_of_the_folder_is_not_read(tmp_path: Path) -> None:
    (tmp_path / "secret.png").write_bytes(b"\x89PNG secret")
    writer = MetricsWriter(uuid.UUID(int=5))
    writer.image("Escape", data.external_file("Escape", "../secret.png"))
    path = writer.write(tmp_path / "out" / "metrics.binproto")
    page = render_html(path)
    assert html.escape("leads out of the file's folder") in page
    assert "<img" not in page


def test_several_files_align_the_same_metric_in_rows(tmp_path: Path) -> None:
    first, second = MetricsWriter(uuid.UUID(int=6)), MetricsWriter(uuid.UUID(int=7))
    first.scalar("Shared", 1.0)
    first.scalar("Only first", 2.0)
    second.scalar("Shared", 3.0)
    a = first.write(tmp_path / "a" / "metrics.binproto")
    b = second.write(tmp_path / "b" / "metrics.binproto")
    page = render_html([a, b])
    assert "--columns:2" in page
    cells = re.findall(r'<article class="card (?:metric|absent)"[^>]*>(?:<h2>)?([^<]*)', page)
    assert cells[:4] == ["Shared", "Shared", "Only first", "Only first: not in this file"]


def test_batch_and_report_outputs_draw_every_chart(tmp_path: Path) -> None:
    for path in (BATCH_OUTPUT, REPORT_OUTPUT):
        page = render_html(path)
        expected = expected_points(read_job_metrics(path.read_bytes()))
        for name, points in expected.items():
            assert [len(t["y"]) for t in figure_of(page, name)["data"]] == points


def test_write_preview_is_atomic_and_names_metrics_html(tmp_path: Path) -> None:
    source = write_example(tmp_path)
    target = write_preview(source, tmp_path / PREVIEW_NAME)
    assert target.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    before = target.read_bytes()
    bad = tmp_path / "bad.binproto"
    bad.write_bytes(b"junk")
    with pytest.raises(ReadError):
        write_preview([source, bad], target)
    assert target.read_bytes() == before  # no partial page
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_messages_and_views_render_too() -> None:
    writer = MetricsWriter(uuid.UUID(int=8))
    writer.scalar("From a message", 4.0)
    msg = read_job_metrics(writer.serialize()).raw
    page = render_html([msg, read_job_metrics(writer.serialize())])
    assert "message 1" in page
    assert "message 2" in page
    assert page.count('data-metric="From a message"') == 2
    assert MetricType.SCALAR.name in page


def test_histogram_counts_use_the_buckets_as_written() -> None:
    from stook.service.preview._metrics import bucket_counts

    buckets = [(0.0, 1.0), (1.0, 2.5), (2.5, 10.0)]
    numbers = [-1.0, 0.0, 0.999, 1.0, 2.5, 9.99, 10.0, 10.5, math.nan, math.inf]
    # 10.0, the last bucket's upper bound, counts in it; NaN, inf and the rest are outside.
    assert bucket_counts(numbers, buckets) == ([2, 1, 3], 4)
    assert bucket_counts([1.0], []) == ([], 1)


def test_numbers_sizes_and_thinning_of_text_series() -> None:
    from stook.service.preview._sources import human_size
    from stook.service.preview._values import exact_text, thin

    assert [exact_text(v) for v in (None, math.nan, math.inf, -math.inf, 0.1 + 0.2)] == [
        "—",
        "NaN",
        "∞",
        "-∞",
        "0.30000000000000004",
    ]
    assert [human_size(n) for n in (999, 1_500, 2_500_000, 3_000_000_000)] == [
        "999 B",
        "1.5 kB",
        "2.5 MB",
        "3.0 GB",
    ]
    states = ["cruise"] * 5_000
    kept = thin(states, limit=1_000)
    assert len(kept) == 500
    assert list(kept) == sorted(kept)


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        (24.09007622286738, "24.0901"),
        (0.17346938775510204, "0.173469"),
        (0.1 + 0.2, "0.3"),
        (1234.5678, "1,234.57"),
        (123_456.7, "123,457"),
        (999_999.7, "1,000,000"),
        (1_234_567.0, "1,234,567"),
        (-1_234.5, "-1,234.5"),
        (12.0, "12"),
        (0.0, "0"),
        (-0.0, "0"),
        (0.0001, "0.0001"),
        (1.5e-7, "1.5e-07"),
        (2.5e20, "2.5e+20"),
        (None, "—"),
        (math.nan, "NaN"),
        (-math.inf, "-∞"),
    ],
)
def test_numbers_read_as_people_read_them(value: float | None, shown: str) -> None:
    from stook.service.preview._values import number_text

    assert number_text(value) == shown


def test_a_page_shows_values_rounded_and_the_exact_value_on_hover(tmp_path: Path) -> None:
    exact = 24.09007622286738
    writer = MetricsWriter(uuid.UUID(int=12))
    writer.scalar("Distance", exact, unit="m", fails_above=1_234_567.891)
    distances = data.doubles("Distances", [0.17346938775510204, exact])
    writer.double_summary("Last distance", distances, index=1)
    source = tmp_path / "metrics.binproto"
    source.write_bytes(writer.serialize())
    written = source.read_bytes()
    page = write_preview([source], tmp_path / PREVIEW_NAME).read_text()

    card = page[page.index('data-metric="Distance"') :]
    card = card[: card.index("</article>")]
    assert f'data-value="{exact!r}" title="{exact!r}">24.0901<span class="unit">m</span>' in card
    assert 'fails above <span title="1234567.891">1,234,568</span>' in card
    summary = page[page.index('data-metric="Last distance"') :]
    summary = summary[: summary.index("</article>")]
    assert f"<td class='num'><span title=\"{exact!r}\">24.0901</span></td>" in summary
    assert repr(exact) not in page.replace(f'"{exact!r}"', "")  # only ever on hover
    # The file keeps every digit: the preview only reads it.
    assert source.read_bytes() == written
    assert read_job_metrics(written).metrics[0].value == exact


def test_a_metric_that_cannot_be_drawn_says_so_and_the_rest_renders() -> None:
    writer = MetricsWriter(uuid.UUID(int=11))
    speed = data.doubles("Speed", [1.0, 2.0])
    writer.line_plot("Plot", speed, data.doubles("y", [3.0, 4.0]))
    writer.scalar("Fine", 1.0)
    msg = read_job_metrics(writer.serialize()).raw
    # The plot now references data the file does not hold.
    del msg.metrics_data[:]
    page = render_html(msg)
    assert "series 1: data not in the file" in page
    assert 'data-metric="Fine"' in page
    assert "The platform would refuse this file" in page
