"""What a chart says beyond its points: colours that follow what a bar is, units once,
time axes that read as time, intervals as error bars, text as written (issue 36)."""

from __future__ import annotations

import re
import uuid
from pathlib import Path

from stook.sdk import MetricStatus, MetricsWriter, data, read_job_metrics
from stook.service.preview import render_html, summary_lines
from tests.service.preview.support import write_example
from tests.service.preview.test_render import figure_of

GREEN, ORANGE, RED = "#1e8e3e", "#e37400", "#d93025"  # PASSED, FAIL_WARN, FAIL_BLOCK
BLUE = "#1a73e8"  # the first series colour: no status


def page_of(writer: MetricsWriter) -> str:
    return render_html(read_job_metrics(writer.serialize()))


def card(page: str, metric: str) -> str:
    found = page[page.index(f'data-metric="{metric}"') :]
    return found[: found.index("</article>")]


def test_bars_named_for_statuses_take_their_colours_not_the_metrics() -> None:
    writer = MetricsWriter(uuid.UUID(int=1))
    counts = {"PASSED": 141.0, "WARNING": 36.0, "BLOCKER": 15.0, "ERROR": 7.0, "CANCELLED": 1.0}
    writer.bar_chart_from("Job statuses", counts, status=MetricStatus.FAIL_BLOCK)
    writer.bar_chart_from(
        "Job metric statuses",
        {"PASSED": 3.0, "FAIL_WARN": 2.0, "FAIL_BLOCK": 1.0},
        status=MetricStatus.FAIL_BLOCK,
    )
    page = page_of(writer)
    colors = figure_of(page, "Job statuses")["data"][0]["marker"]["color"]
    assert colors[:3] == [GREEN, ORANGE, RED]
    assert len(set(colors)) == 5
    colors = figure_of(page, "Job metric statuses")["data"][0]["marker"]["color"]
    assert colors == [GREEN, ORANGE, RED]


def test_point_statuses_colour_bars_only_where_they_say_more_than_the_metric() -> None:
    writer = MetricsWriter(uuid.UUID(int=2))
    # Every point PASSED, as the writer records by default: newly failing bars not green.
    writer.bar_chart_from("Newly failing and fixed experiences", {"Cut-in": 1.0, "Merge": -1.0})
    labels = data.strings("labels", ["a", "b"])
    writer.bar_chart(
        "Mixed",
        data.doubles("Mixed", [1.0, 2.0], index=labels),
        statuses=[
            data.statuses(
                "Mixed statuses", [MetricStatus.PASSED, MetricStatus.FAIL_BLOCK], index=labels
            )
        ],
    )
    page = page_of(writer)
    flips = figure_of(page, "Newly failing and fixed experiences")["data"][0]
    assert flips["marker"]["color"] == BLUE
    assert figure_of(page, "Mixed")["data"][0]["marker"]["color"] == [GREEN, RED]


def test_a_plotly_figure_of_statuses_gets_their_colours_unless_it_sets_its_own() -> None:
    writer = MetricsWriter(uuid.UUID(int=3))
    pie = {"type": "pie", "labels": ["BLOCKER", "PASSED", "WARNING"], "values": [1, 8, 2]}
    writer.plotly("Job outcomes", {"data": [pie], "layout": {"title": {"text": "Outcomes"}}})
    own = {**pie, "marker": {"colors": ["#000000", "#111111", "#222222"]}}
    writer.plotly("Own colours", {"data": [own]})
    bars = {"type": "bar", "x": ["Cut-in 01", "Night rain 01"], "y": [1.0, 2.0]}
    writer.plotly("Per experience", {"data": [bars], "layout": {"yaxis": {"title": "m/s"}}})
    page = page_of(writer)
    assert figure_of(page, "Job outcomes")["data"][0]["marker"]["colors"] == [RED, GREEN, ORANGE]
    assert figure_of(page, "Own colours")["data"][0]["marker"]["colors"][0] == "#000000"
    figure = figure_of(page, "Per experience")
    assert "marker" not in figure["data"][0]
    # The page's frame where the figure sets none: axes make room for their labels.
    assert figure["layout"]["xaxis"]["automargin"] is True
    assert figure["layout"]["margin"]["l"] < 80  # not plotly's default 80 px on each side


def test_points_beyond_the_bound_of_a_passing_metric_are_explained(tmp_path: Path) -> None:
    page = render_html(write_example(tmp_path))
    speed = card(page, "Speed over time")
    figure = figure_of(page, "Speed over time")
    colors = figure["data"][0]["marker"]["color"]
    assert set(colors) == {BLUE, ORANGE}  # the line's colour, and what fails
    assert ">PASSED</span>" in speed
    assert re.search(
        r"Points failing by their own status, in its colour: \d+ FAIL_WARN of 60", speed
    )
    assert "The metric&#x27;s status, as written, is PASSED" in speed
    # The bound is drawn in ink: a line, not a status.
    assert {s["line"]["color"] for s in figure["layout"]["shapes"]} == {"#5f6368"}


def test_a_value_with_its_interval_is_drawn_with_error_bars() -> None:
    writer = MetricsWriter(uuid.UUID(int=4))
    labels = data.strings("Batches", ["Baseline", "Candidate"])
    parts = [
        data.doubles(f"Speed ({part})", values, unit="m/s", index=labels)
        for part, values in (("mean", [10.0, 12.0]), ("low", [9.0, 11.5]), ("high", [10.5, 13.0]))
    ]
    writer.bar_chart(
        "Speed vs baseline",
        parts,
        legend=["Mean", "95 % low", "95 % high"],
        y_axis_name="Speed (m/s)",
    )
    writer.bar_chart("Three series", parts, legend=["Mean", "Min", "Max"])
    page = page_of(writer)
    [trace] = figure_of(page, "Speed vs baseline")["data"]
    assert trace["y"] == [10.0, 12.0]
    assert trace["error_y"]["array"] == [0.5, 1.0]
    assert trace["error_y"]["arrayminus"] == [1.0, 0.5]
    assert "95 % interval" in trace["hovertemplate"]
    assert len(figure_of(page, "Three series")["data"]) == 3  # other charts as written


def test_text_keeps_its_line_breaks() -> None:
    writer = MetricsWriter(uuid.UUID(int=5))
    writer.text("Compared", "Pass rate: 82.5 % -> 75.0 %\nNewly failing (3): a, b, c\n\nNext")
    text = card(page_of(writer), "Compared")
    assert "75.0 %<br />\nNewly failing" in text
    assert text.count("<p>") == 2


def test_axis_units_appear_once_in_parentheses(tmp_path: Path) -> None:
    writer = MetricsWriter(uuid.UUID(int=6))
    writer.line_plot(
        "Braking",
        data.doubles("Speed", [1.0, 2.0], unit="m/s"),
        data.doubles("Distance", [3.0, 4.0], unit="m"),
        x_axis_name="Speed",
        y_axis_name="Braking distance [m]",
    )
    layout = figure_of(page_of(writer), "Braking")["layout"]
    assert layout["xaxis"]["title"]["text"] == "Speed (m/s)"
    assert layout["yaxis"]["title"]["text"] == "Braking distance (m)"
    layout = figure_of(render_html(write_example(tmp_path)), "Speed vs acceleration")["layout"]
    assert layout["xaxis"]["title"]["text"] == "Speed (m/s)"
    assert layout["yaxis"]["title"]["text"] == "Acceleration (m/s^2)"


def _relative(writer: MetricsWriter) -> None:
    times = data.timestamps("Sim time", [0.0, 0.5, 10.25])
    speed = data.doubles("Speed", [1.0, 2.0, 3.0], unit="m/s", index=times)
    states = data.strings("State", ["cruise", "stop", "cruise"], index=times)
    writer.double_over_time("Speed over time", [speed], start_time=0.0, end_time=11.0)
    writer.states_over_time("State over time", [states])
    writer.double_summary("Speed at 0.5 s", speed, index=0.5)


def test_relative_timestamps_are_seconds_from_the_start_not_1970() -> None:
    writer = MetricsWriter(uuid.UUID(int=7))
    _relative(writer)
    page = page_of(writer)
    for name in ("Speed over time", "State over time"):
        figure = figure_of(page, name)
        assert "type" not in figure["layout"]["xaxis"], name
        assert figure["layout"]["xaxis"]["title"]["text"] == "time from the start (s)"
        assert figure["data"][0]["x"] == [0.0, 0.5, 10.25], name
    assert figure_of(page, "Speed over time")["layout"]["xaxis"]["range"] == [0.0, 11.0]
    summary = card(page, "Speed at 0.5 s")
    assert "at 0.5 s</th>" in summary
    assert 'title="2.0">2</span>' in summary
    assert "1970" not in page[page.index("<main") : page.index("</main>")]


def test_the_reports_days_since_axis_reads_as_dates() -> None:
    writer = MetricsWriter(uuid.UUID(int=8))
    writer.line_plot(
        "Failed tests over time",
        data.doubles("Days", [0.0, 1.5]),
        data.doubles("Failed tests", [3.0, 4.0]),
        x_axis_name="Days since 2025-01-06 09:06 UTC",
        y_axis_name="Failed tests",
    )
    figure = figure_of(page_of(writer), "Failed tests over time")
    assert figure["data"][0]["x"] == ["2025-01-06 09:06:00", "2025-01-07 21:06:00"]
    assert figure["layout"]["xaxis"]["type"] == "date"
    assert figure["layout"]["xaxis"]["title"]["text"] == "batch time (UTC)"


def test_long_descriptions_fold_to_their_lead() -> None:
    writer = MetricsWriter(uuid.UUID(int=9))
    long = (
        "'Failed tests' is stable: 16 in nightly-2025-01-19 against a median of 13.5 (MAD 4) "
        "over 10 batches from nightly-2025-01-09 to nightly-2025-01-18: +2.5 (+18.5%), 0.4 "
        "robust deviations."
    )
    writer.scalar("Long", 1.0).describe(long)
    writer.scalar("Short", 1.0).describe("Mean of 'Collisions' over the 196 jobs.")
    page = page_of(writer)
    assert "<summary>&#x27;Failed tests&#x27; is stable:</summary><p>16 in nightly" in card(
        page, "Long"
    )
    assert '<p class="desc">Mean of &#x27;Collisions&#x27;' in card(page, "Short")


def test_counts_of_one_are_singular() -> None:
    writer = MetricsWriter(uuid.UUID(int=10))
    writer.add_data(data.strings("stook batch summary", ["{}"]))
    writer.bar_chart_from("One bar", {"a": 1.0})
    page = page_of(writer)
    assert "<td>1 value</td>" in page
    assert "1 values" not in page
    lines = summary_lines(read_job_metrics(writer.serialize()))
    assert any(line.endswith(" 1 value") for line in lines), lines


def test_the_page_says_how_values_are_shown() -> None:
    writer = MetricsWriter(uuid.UUID(int=11))
    writer.scalar("Distance", 24.09007622286738, unit="m")
    page = page_of(writer)
    assert "values to six significant digits, exact on hover" in page
    assert "values are exact" not in page
    docs = (Path(__file__).resolve().parents[3] / "docs" / "preview.md").read_text()
    assert "never rounded" not in docs
    assert "six significant digits" in docs


def test_a_config_metric_that_failed_reads_as_an_error() -> None:
    # As `stook metrics-config` writes one: NOT_APPLICABLE, its message as the text, a tag.
    writer = MetricsWriter(uuid.UUID(int=12))
    settings = '{"xaxis": {"label": "Speed (m/s)", "min": 0, "max": 40}, "display": {"bins": 20}}'
    writer.text("Broken", "column 'speed' does not exist", status=MetricStatus.NOT_APPLICABLE).tag(
        "error", "ERROR"
    ).tag("template_settings", settings)
    writer.scalar("Fine", 1.0).tag("area", "safety")
    page = page_of(writer)
    broken = card(page, "Broken")
    assert '<article class="card metric failed" data-metric="Broken"' in page
    assert ">ERROR</span>" in broken
    assert "error: ERROR" not in broken  # said once, as the chip
    assert '<details class="tag"><summary>template_settings</summary>' in broken
    assert '<article class="card metric" data-metric="Fine"' in page
    assert '<span class="tag">area: safety</span>' in card(page, "Fine")


def test_series_colours_never_look_like_a_status() -> None:
    writer = MetricsWriter(uuid.UUID(int=13))
    x = data.doubles("Day", [0.0, 1.0])
    writer.line_plot("Seven series", [x] * 7, [data.doubles(f"s{i}", [1.0, 2.0]) for i in range(7)])
    traces = figure_of(page_of(writer), "Seven series")["data"]
    assert len({t["line"]["color"] for t in traces}) == 7
    assert {t["line"]["color"] for t in traces}.isdisjoint({GREEN, ORANGE, RED})
