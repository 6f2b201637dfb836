"""MetricsWriter's refusals: each metric method names the metric and the mistake."""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable
from datetime import datetime

import pytest

from stook.sdk import MetricStatus, MetricsWriter, SeriesKind, WriterError, data
from tests.sdk.support import JOB, PROJECT, writer_error


def test_scalar_errors() -> None:
    w = MetricsWriter(JOB)
    with writer_error("metric 's': a scalar value cannot be NaN"):
        w.scalar("s", math.nan)
    with writer_error("a metric needs a non-empty name"):
        w.scalar("", 1.0)
    with writer_error("metric 's': a tag needs a non-empty key and value"):
        w.scalar("s", 1.0).tag("", "v")
    with writer_error("metric 't': a tag needs a non-empty key and value"):
        w.text("t", "x").tag("k", "")


def test_wrong_data_kinds_are_refused() -> None:
    w = MetricsWriter(JOB)
    strings = data.strings("s", ["a"])
    plain = data.doubles("d", [1.0])
    by_str = data.doubles("ds", [1.0], index=data.strings("l", ["a"]))
    by_ts = data.doubles("dt", [1.0], index=data.timestamps("t", [1]))
    with writer_error("metric 'x': data 's' holds string values, double needed"):
        w.double_summary("x", strings)
    with writer_error("metric 'x': data 'd' must be indexed by a timestamp series"):
        w.double_over_time("x", plain)
    with writer_error("metric 'x': data 'ds' must be indexed by a timestamp series"):
        w.double_over_time("x", by_str)
    with writer_error("metric 'x': data 'dt' must be indexed by a string series"):
        w.bar_chart("x", by_ts)
    with writer_error("metric 'x': data 's' must be indexed by a timestamp series"):
        w.states_over_time("x", strings)
    with writer_error("metric 'x': data 'd' holds double values, string needed"):
        w.states_over_time("x", plain)
    with writer_error("metric 'x': data 's' holds string values, double needed"):
        w.histogram("x", strings, buckets=1, lower=0, upper=1)
    with writer_error("metric 'x': data 's' holds string values, double needed"):
        w.line_plot("x", strings, plain)
    with writer_error("metric 'x': data 'd' holds double values, external_file needed"):
        w.image("x", plain)
    with writer_error("metric 'x': data 'd' holds double values, external_file needed"):
        w.image_list("x", [data.external_file("f", "f.png"), plain])
    with writer_error("metric 'x': index 'a' needs values indexed by timestamps, UUIDs or strings"):
        w.double_summary("x", plain, index="a")


def test_single_series_metrics_check_their_statuses() -> None:
    plain = data.doubles("d", [1.0])
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError, match="status"):
        w.histogram("h", plain, buckets=1, lower=0, upper=1, statuses=data.doubles("n", [1.0]))
    with pytest.raises(WriterError, match="status"):
        w.double_summary("s", plain, statuses=data.statuses("st", [MetricStatus.PASSED] * 3))


def test_shape_and_count_mismatches_are_refused() -> None:
    w = MetricsWriter(JOB)
    t = data.timestamps("t", [1, 2])
    t2 = data.timestamps("t2", [1, 2])
    a = data.doubles("a", [1.0, 2.0], index=t)
    b = data.doubles("b", [1.0, 2.0], index=t2)
    x3 = data.doubles("x3", [1.0, 2.0, 3.0])
    with writer_error("metric 'x': give as many x series as y series (at least 1)"):
        w.line_plot("x", [a, b], [a])
    with writer_error("metric 'x': give as many x series as y series (at least 1)"):
        w.line_plot("x", [], [])
    with writer_error("metric 'x': x series 'a' and y series 'b' differ in shape or index"):
        w.line_plot("x", a, b)
    with writer_error("metric 'x': x series 'a' and y series 'x3' differ in shape or index"):
        w.line_plot("x", a, x3)
    with writer_error("metric 'x': give one status series per value series"):
        w.double_over_time("x", [a, b], statuses=[data.status_like(a, MetricStatus.PASSED)])
    with writer_error("metric 'x': status series 'st' must have the shape and index of 'a'"):
        w.double_over_time("x", a, statuses=[data.statuses("st", [MetricStatus.PASSED] * 2)])
    with writer_error("metric 'x': status series 'st' must have the shape and index of 'a'"):
        w.double_over_time(
            "x", a, statuses=[data.statuses("st", [MetricStatus.PASSED] * 2, index=t2)]
        )
    with writer_error("metric 'x': give one failure definition per series"):
        w.double_over_time("x", [a, b], failures=[(1.0, None)])
    with writer_error("metric 'x': data 'st' holds string values, status needed"):
        w.bar_chart(
            "x",
            data.doubles("bc", [1.0], index=data.strings("l", ["a"])),
            statuses=[data.strings("st", ["a"])],
        )


def test_legend_count_mismatch_is_refused() -> None:
    labels = data.strings("l", ["a"])
    times = data.timestamps("t", [1])
    cases: list[Callable[[MetricsWriter], object]] = [
        lambda w: w.bar_chart("x", data.doubles("v", [1.0], index=labels), legend=[]),
        lambda w: w.line_plot(
            "x", data.doubles("p", [1.0]), data.doubles("q", [1.0]), legend=["a", "b"]
        ),
        lambda w: w.states_over_time("x", data.strings("s", ["a"], index=times), legend=["a", "b"]),
        lambda w: w.double_over_time("x", data.doubles("v", [1.0], index=times), legend=[]),
    ]
    for case in cases:
        with writer_error("metric 'x': give one legend name per series"):
            case(MetricsWriter(JOB))


def test_states_errors() -> None:
    w = MetricsWriter(JOB)
    states = data.strings("s", ["go", "halt", "zz"], index=data.timestamps("t", [1, 2, 3]))
    with writer_error("metric 'x': states ['halt', 'zz'] are not in the states set"):
        w.states_over_time("x", states, states_set=["go"])
    with writer_error("metric 'y': failure states must be in the states set"):
        w.states_over_time("y", states, failure_states=["crash"])


def test_batchwise_errors() -> None:
    batches = data.uuids("b", [uuid.UUID(int=1)])
    other = data.uuids("b2", [uuid.UUID(int=1)])
    times = data.timestamps("t", [1], index=batches)
    values = data.doubles("v", [1.0], index=batches)
    w = MetricsWriter(JOB)
    with writer_error("metric 'x': give one times and one values series per category"):
        w.batchwise_bar_chart(
            "x", project_id=PROJECT, times=times, values=values, categories=["a", "b"]
        )
    with writer_error("metric 'x': 't' and 'v2' need one index"):
        w.batchwise_bar_chart(
            "x",
            project_id=PROJECT,
            times=times,
            values=data.doubles("v2", [1.0], index=other),
            categories=["a"],
        )
    with writer_error("metric 'x': data 'v' holds double values, timestamp needed"):
        w.batchwise_bar_chart(
            "x", project_id=PROJECT, times=values, values=values, categories=["a"]
        )
    with writer_error("metric 'x': data 'plain' must be indexed by a uuid series"):
        w.batchwise_bar_chart(
            "x",
            project_id=PROJECT,
            times=times,
            values=data.doubles("plain", [1.0]),
            categories=["a"],
        )
    for colour in ["red", "#12345", "#1234567", "#GGGGGG", "", "2e7d32", "#aabbcc\n"]:
        with writer_error(f"metric 'x': colour {colour!r} is not #RRGGBB or #RRGGBBAA"):
            w.batchwise_bar_chart(
                "x",
                project_id=PROJECT,
                times=times,
                values=values,
                categories=["a"],
                colors=[colour],
            )


def test_batchwise_refuses_a_project_id_that_is_not_a_uuid_with_writer_error() -> None:
    batches = data.uuids("b", [uuid.UUID(int=1)])
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError, match="not a UUID"):
        w.batchwise_bar_chart(
            "x",
            project_id="project-1",
            times=data.timestamps("t", [1], index=batches),
            values=data.doubles("v", [1.0], index=batches),
            categories=["a"],
        )


def test_text_plotly_and_image_list_errors() -> None:
    w = MetricsWriter(JOB)
    with writer_error("metric 't': text cannot be empty"):
        w.text("t", "")
    with pytest.raises(WriterError, match=r"^metric 'p': plotly figure is not JSON \("):
        w.plotly("p", "{not json")
    with pytest.raises(WriterError, match=r"^metric 'p': plotly figure is not JSON \("):
        w.plotly("p", 42)  # type: ignore[arg-type]
    with writer_error("metric 'i': an image list needs at least one image"):
        w.image_list("i", [])
    assert w.metrics == []


def test_plotly_refuses_json_that_is_not_an_object_with_writer_error() -> None:
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError, match="plotly"):
        w.plotly("p", "[1, 2]")


def test_double_over_time_refuses_a_naive_start_time() -> None:
    w = MetricsWriter(JOB)
    values = data.doubles("v", [1.0], index=data.timestamps("t", [1]))
    with writer_error("timestamp 2026-01-01T00:00:00 has no time zone; use an aware one"):
        w.double_over_time("d", values, start_time=datetime(2026, 1, 1))


def test_line_plot_refuses_series_indexed_by_strings() -> None:
    labels = data.strings("l", ["a", "b"])
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError):
        w.line_plot(
            "lp",
            data.doubles("x", [1.0, 2.0], index=labels),
            data.doubles("y", [3.0, 4.0], index=labels),
        )


def test_double_summary_refuses_a_uuid_index_that_is_not_a_uuid_with_writer_error() -> None:
    ids = data.uuids("ids", [uuid.UUID(int=1)])
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError, match="not a UUID"):
        w.double_summary("d", data.doubles("v", [1.0], index=ids), index="actor-1")


def test_double_summary_refuses_an_index_kind_its_values_lack() -> None:
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError):
        w.double_summary(
            "d", data.doubles("v", [1.0]), index=str(uuid.UUID(int=1)), index_kind=SeriesKind.UUID
        )
