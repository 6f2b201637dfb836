"""MetricsWriter: every metric type, with its options, written and read back.

Each output is checked three ways (see `tests.sdk.support.written`): stook's
validator, ReSim's validator (the oracle) and the SDK reader.
"""

from __future__ import annotations

import math
import uuid
from datetime import timedelta

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    BarChartMetric,
    BatchwiseBarChartMetric,
    DoubleOverTimeMetric,
    DoubleSummaryMetric,
    HistogramMetric,
    ImageListMetric,
    ImageMetric,
    LinePlotMetric,
    MetricImportance,
    MetricStatus,
    MetricsWriter,
    MetricType,
    PlotlyMetric,
    ScalarMetric,
    SeriesKind,
    StatesOverTimeMetric,
    TextMetric,
    data,
)
from tests.sdk.support import (
    JOB,
    PROJECT,
    T0,
    T0_NS,
    data_names,
    epoch_ns,
    metric,
    statuses_of,
    written,
)

# ---------------------------------------------------------------- scalar


def test_scalar_round_trips_value_unit_options_and_failure_definition() -> None:
    w = MetricsWriter(JOB)
    (
        w.scalar(
            "Max speed",
            31.5,
            unit="m/s",
            fails_above=40.0,
            fails_below=2.0,
            description="peak",
            importance=MetricImportance.CRITICAL,
        )
        .tag("area", "safety")
        .tag("area", "speed")
        .display(False)
        .order(3.5)
        .blocking()
    )
    w.scalar("No unit", -0.0)
    w.scalar("Infinite", math.inf)
    view = written(w)
    m = metric(view, "Max speed")
    assert m.type is MetricType.SCALAR
    assert m.value == 31.5
    assert m.unit == "m/s"
    assert m.status is MetricStatus.PASSED
    assert m.description == "peak"
    assert m.importance is MetricImportance.CRITICAL
    assert m.tags == (("area", "safety"), ("area", "speed"))
    assert m.should_display is False
    assert m.order == 3.5
    assert m.blocking is True
    assert m.job_id == JOB
    assert not m.event_metric
    assert m.data_ids == ()
    scalar = view.metric(m.name, ScalarMetric)
    assert (scalar.fails_above, scalar.fails_below) == (40.0, 2.0)
    plain = metric(view, "No unit")
    assert plain.unit is None
    assert plain.importance is MetricImportance.MEDIUM
    assert plain.blocking is None
    assert plain.should_display is None
    assert plain.order is None
    # Wire level: no failure definition at all, not an empty one.
    assert not plain.raw.metric_values.scalar_metric_values.HasField("failure_definition")
    assert plain.value is not None
    assert math.copysign(1.0, plain.value) == -1.0
    assert metric(view, "Infinite").value == math.inf
    assert view.data == ()


@pytest.mark.parametrize(
    ("value", "kwargs", "expected"),
    [
        (5.0, {"fails_above": 4.0}, MetricStatus.FAIL_WARN),
        (5.0, {"fails_above": 5.0}, MetricStatus.PASSED),
        (1.0, {"fails_below": 2.0}, MetricStatus.FAIL_WARN),
        (1.0, {"fails_below": 2.0, "blocking": True}, MetricStatus.FAIL_BLOCK),
        (3.0, {"fails_below": 2.0, "fails_above": 4.0, "blocking": True}, MetricStatus.PASSED),
        (5.0, {"fails_above": 4.0, "blocking": False}, MetricStatus.FAIL_WARN),
        # An explicit status wins over the failure definition.
        (
            5.0,
            {"fails_above": 4.0, "status": MetricStatus.NOT_APPLICABLE},
            MetricStatus.NOT_APPLICABLE,
        ),
        (5.0, {"status": MetricStatus.RAW}, MetricStatus.RAW),
    ],
)
def test_scalar_status_is_computed_from_its_limits(
    value: float, kwargs: dict[str, object], expected: MetricStatus
) -> None:
    w = MetricsWriter(JOB)
    w.scalar("s", value, **kwargs)  # type: ignore[arg-type]
    assert metric(written(w), "s").status is expected


# ---------------------------------------------------------------- double summary


def _timed_speed() -> tuple[data.MetricsData, data.MetricsData]:
    times = data.timestamps("Time", [T0 + timedelta(seconds=i) for i in range(4)])
    return times, data.doubles("Speed", [10.0, 11.0, 12.0, 13.0], unit="m/s", index=times)


def test_double_summary_by_position_with_generated_statuses() -> None:
    w = MetricsWriter(JOB)
    speeds = data.doubles("Speeds", [1.0, 2.0, 3.0], unit="m/s")
    w.double_summary("Second", speeds, index=1, failure=(2.5, 0.5), status=MetricStatus.FAIL_WARN)
    w.double_summary("Whole", speeds)
    view = written(w)
    m = metric(view, "Second")
    assert m.type is MetricType.DOUBLE_SUMMARY
    assert m.status is MetricStatus.FAIL_WARN
    mv = view.metric("Second", DoubleSummaryMetric)
    assert mv.series_index == 1
    assert (mv.timestamp_index_ns, mv.uuid_index, mv.string_index) == (None, None, None)
    assert mv.value_data is not None
    assert mv.value_data.series().to_list() == [1.0, 2.0, 3.0]
    assert mv.value_data.unit == "m/s"
    status = mv.status_data
    assert status is not None
    assert status.name == "Speeds (FAIL_WARN status)"
    assert statuses_of(status) == ["FAIL_WARN"] * 3
    assert (mv.fails_above, mv.fails_below) == (2.5, 0.5)
    whole = view.metric("Whole", DoubleSummaryMetric)
    assert (whole.series_index, whole.timestamp_index_ns) == (None, None)
    assert not whole.view.raw.metric_values.double_metric_values.HasField("failure_definition")
    assert whole.status_data is not None
    assert whole.status_data.name == "Speeds (PASSED status)"
    # Speeds once, and one generated status series per status.
    assert sorted(d.name for d in view.data) == [
        "Speeds",
        "Speeds (FAIL_WARN status)",
        "Speeds (PASSED status)",
    ]
    assert set(m.data_ids) == {view.data_by_name[n].id for n in ("Speeds", status.name)}


def test_double_summary_by_timestamp_index_value() -> None:
    _times, speed = _timed_speed()
    w = MetricsWriter(JOB)
    w.double_summary("At 2 s", speed, index=T0 + timedelta(seconds=2))
    w.double_summary("At ns", speed, index=T0_NS + 3_000_000_001)
    view = written(w)
    mv = view.metric("At 2 s", DoubleSummaryMetric)
    assert (mv.timestamp_index_ns, mv.series_index) == (1_767_268_802 * 10**9, None)
    # With timestamp-indexed values an int is nanoseconds, not a position.
    ns = view.metric("At ns", DoubleSummaryMetric)
    assert ns.timestamp_index_ns == 1_767_268_803 * 10**9 + 1
    status = mv.status_data
    assert status is not None
    assert status.index_id == view.data_by_name["Time"].id
    assert status.raw.data_type == pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE


def test_double_summary_by_uuid_and_string_index_values() -> None:
    ids = data.uuids("Actors", [uuid.UUID(int=1), uuid.UUID(int=2)])
    labels = data.strings("Labels", ["car", "bike"])
    w = MetricsWriter(JOB)
    w.double_summary(
        "By uuid", data.doubles("Gap", [1.0, 2.0], index=ids), index=str(uuid.UUID(int=2)).upper()
    )
    w.double_summary(
        "By uuid obj", data.doubles("Gap2", [3.0, 4.0], index=ids), index=uuid.UUID(int=1)
    )
    w.double_summary("By label", data.doubles("Count", [5.0, 6.0], index=labels), index="bike")
    w.double_summary("By pos", data.doubles("Count2", [7.0, 8.0], index=labels), index=0)
    view = written(w)
    u = metric(view, "By uuid").raw.metric_values.double_metric_values
    assert u.uuid_index.data == str(uuid.UUID(int=2))  # canonical, lower case on the wire
    assert view.metric("By uuid", DoubleSummaryMetric).uuid_index == uuid.UUID(int=2)
    assert view.metric("By uuid obj", DoubleSummaryMetric).uuid_index == uuid.UUID(int=1)
    s = view.metric("By label", DoubleSummaryMetric)
    assert (s.string_index, s.series_index) == ("bike", None)
    p = view.metric("By pos", DoubleSummaryMetric)
    assert (p.series_index, p.string_index) == (0, None)
    # The Actors index is shared by two value series and written once.
    assert [d.name for d in view.data].count("Actors") == 1


def test_double_summary_with_explicit_statuses() -> None:
    w = MetricsWriter(JOB)
    values = data.doubles("v", [1.0, 2.0])
    st_ = data.statuses("v statuses", [MetricStatus.PASSED, MetricStatus.FAIL_BLOCK])
    w.double_summary("d", values, statuses=st_, index=1, status=MetricStatus.FAIL_BLOCK)
    view = written(w)
    mv = view.metric("d", DoubleSummaryMetric)
    assert mv.status_data is not None
    assert mv.status_data.name == "v statuses"
    assert statuses_of(mv.status_data) == ["PASSED", "FAIL_BLOCK"]
    assert len(view.data) == 2


# ---------------------------------------------------------------- double over time


def test_double_over_time_with_two_series_statuses_failures_and_axes() -> None:
    times = data.timestamps("Time", [T0, T0 + timedelta(seconds=1)])
    speed = data.doubles("Speed", [1.0, 2.0], index=times)
    accel = data.doubles("Accel", [0.5, 0.25], index=times)
    speed_st = data.statuses("Speed st", [MetricStatus.PASSED, MetricStatus.FAIL_WARN], index=times)
    accel_st = data.statuses("Accel st", [MetricStatus.PASSED] * 2, index=times)
    w = MetricsWriter(JOB)
    w.double_over_time(
        "Motion",
        [speed, accel],
        statuses=[speed_st, accel_st],
        failures=[(1.5, None), (None, -1.0)],
        start_time=T0,
        end_time=T0_NS + 2_500_000_000,
        y_axis_name="value",
        legend=["speed", "acceleration"],
        status=MetricStatus.FAIL_WARN,
    )
    w.double_over_time("Speed only", speed)
    view = written(w)
    m = metric(view, "Motion")
    assert m.type is MetricType.DOUBLE_OVER_TIME
    assert m.status is MetricStatus.FAIL_WARN
    mv = view.metric("Motion", DoubleOverTimeMetric)
    assert data_names(mv.doubles_over_time_data) == ["Speed", "Accel"]
    assert data_names(mv.statuses_over_time_data) == ["Speed st", "Accel st"]
    assert mv.failure_definitions == ((1.5, None), (None, -1.0))
    assert mv.start_time_ns == 1_767_268_800 * 10**9
    assert mv.end_time_ns == 1_767_268_802 * 10**9 + 500_000_000
    assert mv.y_axis_name == "value"
    assert mv.legend == ("speed", "acceleration")
    one = view.metric("Speed only", DoubleOverTimeMetric)
    # Default legend: the data names; default failure: an empty definition per series.
    assert one.legend == ("Speed",)
    assert one.failure_definitions == ((None, None),)
    assert (one.start_time_ns, one.end_time_ns) == (None, None)
    assert data_names(one.statuses_over_time_data) == ["Speed (PASSED status)"]
    # Time is shared by five series and written once, first.
    assert next(d.name for d in view.data) == "Time"
    assert [d.name for d in view.data].count("Time") == 1
    assert len(view.data) == 6


# ---------------------------------------------------------------- line plot


def test_line_plot_with_several_lines_axes_and_legend() -> None:
    xs = [data.doubles("x1", [0.0, 1.0]), data.doubles("x2", [0.0, 1.0, 2.0])]
    ys = [data.doubles("y1", [5.0, 6.0]), data.doubles("y2", [7.0, 8.0, 9.0])]
    w = MetricsWriter(JOB)
    w.line_plot("Lines", xs, ys, x_axis_name="X", y_axis_name="Y", legend=["one", "two"])
    times = data.timestamps("T", [1, 2])
    w.line_plot(
        "Timed",
        data.doubles("tx", [1.0, 2.0], index=times),
        data.doubles("ty", [3.0, 4.0], index=times),
    )
    view = written(w)
    m = metric(view, "Lines")
    assert m.type is MetricType.LINE_PLOT
    mv = view.metric("Lines", LinePlotMetric)
    assert data_names(mv.x_doubles_data) == ["x1", "x2"]
    assert data_names(mv.y_doubles_data) == ["y1", "y2"]
    assert data_names(mv.statuses_data) == ["x1 (PASSED status)", "x2 (PASSED status)"]
    assert statuses_of(mv.statuses_data[1]) == ["PASSED"] * 3
    assert (mv.x_axis_name, mv.y_axis_name) == ("X", "Y")
    assert mv.legend == ("one", "two")
    timed = view.metric("Timed", LinePlotMetric)
    assert timed.legend == ("ty",)  # default: the y series names
    assert timed.statuses_data[0].index_id == view.data_by_name["T"].id


# ---------------------------------------------------------------- bar chart


def test_bar_chart_with_two_series_legend_axes_and_stacking() -> None:
    labels = data.strings("Classes", ["car", "ped"])
    a = data.doubles("Run A", [4.0, 1.0], index=labels)
    b = data.doubles("Run B", [3.0, 2.0], index=labels)
    w = MetricsWriter(JOB)
    w.bar_chart(
        "Counts", [a, b], x_axis_name="class", y_axis_name="n", legend=["A", "B"], stack_bars=True
    )
    w.bar_chart("Unstacked", a, stack_bars=False)
    w.bar_chart("Default", b)
    view = written(w)
    mv = view.metric("Counts", BarChartMetric)
    assert data_names(mv.values_data) == ["Run A", "Run B"]
    assert data_names(mv.statuses_data) == ["Run A (PASSED status)", "Run B (PASSED status)"]
    assert mv.legend == ("A", "B")
    assert (mv.x_axis_name, mv.y_axis_name) == ("class", "n")
    assert mv.stack_bars is True
    assert [v.by_label() for v in mv.values_data] == [
        {"car": 4.0, "ped": 1.0},
        {"car": 3.0, "ped": 2.0},
    ]
    assert view.metric("Unstacked", BarChartMetric).stack_bars is False
    default = view.metric("Default", BarChartMetric)
    assert default.stack_bars is None
    assert default.legend == ("Run B",)
    # The shared "Run A (PASSED status)" is written once for two metrics.
    assert [d.name for d in view.data].count("Run A (PASSED status)") == 1


def test_bar_chart_from_a_mapping_keeps_label_order() -> None:
    w = MetricsWriter(JOB)
    w.bar_chart_from("Detections", {"car": 41.0, "pedestrian": 7.0, "cyclist": 3.0}).describe("d")
    w.bar_chart_from(
        "Other", {"b": 1.0}, data_name="other data", y_axis_name="n", status=MetricStatus.FAIL_WARN
    )
    view = written(w)
    m = metric(view, "Detections")
    assert m.type is MetricType.BAR_CHART
    assert m.description == "d"
    (values,) = view.metric("Detections", BarChartMetric).values_data
    assert values.name == "Detections"
    assert values.labelled() == (("car", 41.0), ("pedestrian", 7.0), ("cyclist", 3.0))
    assert values.index is not None
    assert values.index.name == "Detections (labels)"
    omv = view.metric("Other", BarChartMetric)
    assert omv.status is MetricStatus.FAIL_WARN
    assert omv.values_data[0].name == "other data"
    assert "other data (labels)" in view.data_by_name
    assert omv.y_axis_name == "n"
    assert statuses_of(omv.statuses_data[0]) == ["FAIL_WARN"]


# ---------------------------------------------------------------- states over time


def test_states_over_time_with_given_and_inferred_states_sets() -> None:
    times = data.timestamps("T", [1, 2, 3])
    states = data.strings("Planner", ["cruise", "stop", "cruise"], index=times)
    other = data.strings("Gear", ["2", "1", "3"], index=times)
    w = MetricsWriter(JOB)
    w.states_over_time(
        "Planner state",
        states,
        states_set=["cruise", "slow", "stop"],
        failure_states=["stop"],
        legend=["planner"],
    )
    w.states_over_time("Gear state", other)
    view = written(w)
    m = metric(view, "Planner state")
    assert m.type is MetricType.STATES_OVER_TIME
    mv = view.metric("Planner state", StatesOverTimeMetric)
    assert mv.states_set == ("cruise", "slow", "stop")
    assert mv.failure_states == ("stop",)
    assert mv.legend == ("planner",)
    assert data_names(mv.states_over_time_data) == ["Planner"]
    status = mv.statuses_over_time_data[0]
    assert status.name == "Planner (PASSED status)"
    assert status.index_id == view.data_by_name["T"].id
    gear = view.metric("Gear state", StatesOverTimeMetric)
    assert gear.states_set == ("1", "2", "3")  # inferred, sorted
    assert gear.failure_states == ()
    assert gear.legend == ("Gear",)


def test_states_over_time_per_category() -> None:
    idx = data.per_category("T", SeriesKind.TIMESTAMP, {"a": [1, 2], "b": [3]})
    states = data.per_category("S", SeriesKind.STRING, {"a": ["on", "off"], "b": ["on"]}, index=idx)
    w = MetricsWriter(JOB)
    w.states_over_time("S over time", states, failure_states=["off"])
    view = written(w)
    mv = view.metric("S over time", StatesOverTimeMetric)
    assert mv.states_set == ("off", "on")
    status = mv.statuses_over_time_data[0]
    assert status.per_category
    assert status.categories == ("a", "b")
    assert status.category_series("a").to_list() == ["PASSED", "PASSED"]


# ---------------------------------------------------------------- histogram


def test_histogram_with_equal_width_buckets() -> None:
    w = MetricsWriter(JOB)
    speeds = data.doubles("Speeds", [1.0, 7.5, 24.0], unit="m/s")
    w.histogram("Speed distribution", speeds, buckets=4, lower=0.0, upper=2.0, x_axis_name="speed")
    view = written(w)
    m = metric(view, "Speed distribution")
    assert m.type is MetricType.HISTOGRAM
    mv = view.metric("Speed distribution", HistogramMetric)
    assert mv.buckets == ((0.0, 0.5), (0.5, 1.0), (1.0, 1.5), (1.5, 2.0))
    assert (mv.lower_bound, mv.upper_bound) == (0.0, 2.0)
    assert mv.x_axis_name == "speed"
    assert mv.values_data is not None
    assert mv.values_data.values() == (1.0, 7.5, 24.0)
    assert mv.statuses_data is not None
    assert mv.statuses_data.name == "Speeds (PASSED status)"


def test_histogram_with_explicit_buckets_and_statuses() -> None:
    w = MetricsWriter(JOB)
    values = data.doubles("v", [1.0, 2.0])
    st_ = data.statuses("v st", [MetricStatus.PASSED, MetricStatus.FAIL_WARN])
    buckets = [(-1.0, 0.0), (0.0, 0.25), (0.25, 10.0)]
    w.histogram("h", values, buckets=buckets, lower=-1.0, upper=10.0, statuses=st_)
    w.histogram("h2", values, buckets=[(0, 1)])
    view = written(w)
    mv = view.metric("h", HistogramMetric)
    assert list(mv.buckets) == buckets
    assert (mv.lower_bound, mv.upper_bound) == (-1.0, 10.0)
    assert mv.statuses_data is not None
    assert mv.statuses_data.name == "v st"
    h2 = view.metric("h2", HistogramMetric)
    assert h2.buckets == ((0.0, 1.0),)
    assert h2.x_axis_name is None


# ---------------------------------------------------------------- batchwise bar chart


def test_batchwise_bar_chart_with_project_categories_colours_and_axes() -> None:
    batches = data.uuids("Batches", [uuid.UUID(int=i + 1) for i in range(3)])
    times = data.timestamps(
        "Batch times", [T0 - timedelta(days=d) for d in (2, 1, 0)], index=batches
    )
    passed = data.doubles("Passed", [18.0, 19.0, 20.0], index=batches)
    failed = data.doubles("Failed", [2.0, 1.0, 0.0], index=batches)
    failed_st = data.statuses(
        "Failed st",
        [MetricStatus.FAIL_WARN, MetricStatus.PASSED, MetricStatus.PASSED],
        index=batches,
    )
    w = MetricsWriter(JOB)
    w.batchwise_bar_chart(
        "Tests per batch",
        project_id=str(PROJECT).upper(),
        times=[times, times],
        values=[passed, failed],
        categories=["PASSED", "FAILED"],
        statuses=[data.status_like(passed, MetricStatus.PASSED, name="Passed st"), failed_st],
        colors=["#2e7d32", "#C62828AA"],
        x_axis_name="batch",
        y_axis_name="tests",
        stack_bars=True,
    )
    w.batchwise_bar_chart(
        "Minimal", project_id=PROJECT, times=times, values=passed, categories=["PASSED"]
    )
    view = written(w)
    m = metric(view, "Tests per batch")
    assert m.type is MetricType.BATCHWISE_BAR_CHART
    assert m.raw.metric_values.batchwise_bar_chart_metric_values.project_id.data == str(PROJECT)
    mv = view.metric("Tests per batch", BatchwiseBarChartMetric)
    assert mv.project_id == PROJECT
    assert mv.categories == ("PASSED", "FAILED")
    assert mv.colors == ("#2e7d32", "#C62828AA")
    assert (mv.x_axis_name, mv.y_axis_name) == ("batch", "tests")
    assert mv.stack_bars is True
    assert data_names(mv.times_data) == ["Batch times", "Batch times"]
    assert data_names(mv.values_data) == ["Passed", "Failed"]
    assert data_names(mv.statuses_data) == ["Passed st", "Failed st"]
    bt = view.data_by_name["Batch times"]
    assert bt.index_id == view.data_by_name["Batches"].id
    assert bt.series().dt.epoch("ns").to_list() == [
        epoch_ns(T0 - timedelta(days=d)) for d in (2, 1, 0)
    ]
    minimal = view.metric("Minimal", BatchwiseBarChartMetric)
    assert minimal.colors == ()
    assert minimal.stack_bars is None
    assert data_names(minimal.statuses_data) == ["Passed (PASSED status)"]
    names = [d.name for d in view.data]
    assert len(names) == len(set(names))
    assert names.index("Batches") < names.index("Batch times")


# ---------------------------------------------------------------- text, plotly, images


def test_text_plotly_image_and_image_list() -> None:
    front = data.external_file("Front", "front.png")
    rear = data.external_file("Rear", "rear.png")
    figure = {
        "data": [{"type": "scatter", "y": [1, 2.5]}],
        "layout": {"title": "t", "show": True, "n": None},
    }
    w = MetricsWriter(JOB)
    w.text("Notes", "**bold**\nsecond line", importance=MetricImportance.LOW)
    w.plotly("Figure", figure)
    w.plotly("Figure text", '{"data": [], "layout": {"height": 300}}')
    w.image("Front camera", front, description="front")
    w.image_list("Frames", [front, rear])
    view = written(w)
    text = metric(view, "Notes")
    assert text.type is MetricType.TEXT
    assert text.importance is MetricImportance.LOW
    assert view.metric("Notes", TextMetric).text == "**bold**\nsecond line"
    plotly = view.metric("Figure", PlotlyMetric)
    assert plotly.type is MetricType.PLOTLY
    assert plotly.json == {
        "data": [{"type": "scatter", "y": [1.0, 2.5]}],
        "layout": {"title": "t", "show": True, "n": None},
    }
    assert view.metric("Figure text", PlotlyMetric).json == {
        "data": [],
        "layout": {"height": 300.0},
    }
    image = view.metric("Front camera", ImageMetric)
    assert image.type is MetricType.IMAGE
    assert image.view.description == "front"
    assert image.image_data is not None
    assert image.image_data.external_path == "front.png"
    lst = view.metric("Frames", ImageListMetric)
    assert lst.type is MetricType.IMAGE_LIST
    assert data_names(lst.image_data) == ["Front", "Rear"]
    assert [d.name for d in view.data] == ["Front", "Rear"]
