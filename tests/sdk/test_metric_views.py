"""Typed metric views: every metric type of a ReSim-written output, read field by field with its
data resolved, and the errors for a missing metric, missing data and mismatched values."""

from __future__ import annotations

import uuid
from collections.abc import Callable

import polars as pl
import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    BarChartMetric,
    BatchwiseBarChartMetric,
    Bucket,
    DoubleOverTimeMetric,
    DoubleSummaryMetric,
    FailureLimits,
    HistogramMetric,
    ImageListMetric,
    ImageMetric,
    JobMetricsView,
    LinePlotMetric,
    MetricStatus,
    MetricsWriter,
    MetricType,
    MissingDataError,
    PlotlyMetric,
    ReadError,
    ScalarMetric,
    SeriesKind,
    StatesOverTimeMetric,
    TextMetric,
    TypedMetric,
    UnknownMetric,
    data,
    parse_job_metrics,
    read_job_metrics,
    read_metrics_data,
)
from tests.sdk.support import written

# ---------------------------------------------------------------- every type, as ReSim wrote it


def names(items: tuple[object, ...]) -> list[str]:
    return [d.name for d in items]  # type: ignore[attr-defined]


def test_scalar(view: JobMetricsView) -> None:
    m = view.metric("Max speed", ScalarMetric)
    assert (m.value, m.unit, m.fails_above, m.fails_below) == (2.5, "m/s", None, None)
    assert m.name == "Max speed"
    assert m.type is MetricType.SCALAR
    assert m.status is MetricStatus.PASSED
    assert m.view.tags == (("team", "planning"),)
    assert m.id == m.view.id


def test_double_over_time(view: JobMetricsView) -> None:
    m = view.metric("Speed", DoubleOverTimeMetric)
    assert names(m.doubles_over_time_data) == ["speeds"]
    assert names(m.statuses_over_time_data) == ["speed statuses"]
    assert m.failure_definitions == (FailureLimits(10.0, None),)
    assert (m.start_time_ns, m.end_time_ns) == (0, 2_000_000_000)
    assert (m.y_axis_name, m.legend) == ("v", ("car",))
    speeds = m.doubles_over_time_data[0]
    assert speeds.labelled() == ((500, 1.0), (1_000_000_500, 2.5), (2_000_000_500, -3.0))


def test_line_plot(view: JobMetricsView) -> None:
    m = view.metric("Path", LinePlotMetric)
    assert names(m.x_doubles_data) == ["xs"]
    assert names(m.y_doubles_data) == ["ys"]
    assert names(m.statuses_data) == ["xy statuses"]
    assert (m.x_axis_name, m.y_axis_name, m.legend) == ("x", "y", ("path",))
    assert m.y_doubles_data[0].values() == (4.0, 5.0)
    assert m.statuses_data[0].values() == (MetricStatus.PASSED, MetricStatus.FAIL_WARN)


def test_bar_chart_gives_labels_in_one_call(view: JobMetricsView) -> None:
    m = view.metric("Bars", BarChartMetric)
    assert names(m.values_data) == ["bar values"]
    assert names(m.statuses_data) == ["bar statuses"]
    assert (m.legend, m.stack_bars, m.x_axis_name, m.y_axis_name) == (("v",), True, None, None)
    assert m.values_data[0].labelled() == (("a", 1.0), ("b", 2.0))
    assert m.values_data[0].by_label() == {"a": 1.0, "b": 2.0}
    assert m.values_data[0].index is view.data_by_name["bar names"]


def test_batchwise_bar_chart(view: JobMetricsView) -> None:
    m = view.metric("Batches", BatchwiseBarChartMetric)
    assert names(m.times_data) == ["batch times"]
    assert names(m.values_data) == ["batch values"]
    assert names(m.statuses_data) == ["batch statuses"]
    assert (m.categories, m.colors) == (("cat",), ("#aabbcc",))
    assert (m.x_axis_name, m.y_axis_name, m.project_id) == ("t", "v", uuid.UUID(int=3))
    assert m.values_data[0].labelled() == ((uuid.UUID(int=1), 0.5), (uuid.UUID(int=2), 0.75))


def test_states_over_time(view: JobMetricsView) -> None:
    m = view.metric("States", StatesOverTimeMetric)
    assert names(m.states_over_time_data) == ["states"]
    assert names(m.statuses_over_time_data) == ["state statuses"]
    assert sorted(m.states_set) == ["drive", "idle"]
    assert (m.failure_states, m.legend) == (("drive",), ("s",))
    assert m.states_over_time_data[0].values() == ("idle", "drive", "idle")


def test_histogram(view: JobMetricsView) -> None:
    m = view.metric("Histogram", HistogramMetric)
    assert m.values_data is not None
    assert m.values_data.name == "hist values"
    assert m.statuses_data is not None
    assert m.statuses_data.name == "hist statuses"
    assert m.buckets == (Bucket(0.0, 1.0), Bucket(1.0, 3.0))
    assert (m.lower_bound, m.upper_bound, m.x_axis_name) == (0.0, 3.0, None)
    assert m.values_data.series().to_list() == [0.5, 1.5, 2.0]


def test_double_summary(view: JobMetricsView) -> None:
    m = view.metric("Summary", DoubleSummaryMetric)
    assert m.value_data is not None
    assert m.value_data.name == "hist values"
    assert m.status_data is not None
    assert m.status_data.name == "hist statuses"
    assert m.series_index == 1
    assert (m.timestamp_index_ns, m.uuid_index, m.string_index) == (None, None, None)
    assert (m.fails_above, m.fails_below) == (None, None)


def test_text_plotly_and_images(view: JobMetricsView) -> None:
    assert view.metric("Text", TextMetric).text == "# hello"
    assert view.metric("Plot", PlotlyMetric).json == {"data": [{"x": [1.0, 2.0]}]}
    image = view.metric("Image", ImageMetric).image_data
    assert image is not None
    assert image.external_path == "images/a.png"
    images = view.metric("Images", ImageListMetric).image_data
    assert [i.external_path for i in images] == ["images/0.png", "images/1.png"]


def test_every_metric_reads_as_its_own_class(view: JobMetricsView) -> None:
    classes = {name: type(view.metric(name)).__name__ for name in view.metric_names()}
    assert len(classes) == len(view.metrics) == 13
    for name, cls in classes.items():
        metric_type = view.find_metric(name).type  # type: ignore[union-attr]
        assert isinstance(metric_type, MetricType)
        expected = "".join(w.capitalize() for w in metric_type.name.split("_")) + "Metric"
        assert cls == expected, name


def test_asking_for_another_class_is_a_type_error(view: JobMetricsView) -> None:
    with pytest.raises(TypeError, match="'Bars' is a BAR_CHART metric, not a HistogramMetric"):
        view.metric("Bars", HistogramMetric)
    assert isinstance(view.metric("Bars", TypedMetric), BarChartMetric)


# ---------------------------------------------------------------- per-category data, labels


def test_per_category_data_keep_their_names(view: JobMetricsView) -> None:
    grouped = view.data_by_name["speeds by vehicle"]
    by_category = grouped.by_category()
    assert list(by_category) == ["car", "bike"]
    assert [s.name for s in by_category.values()] == ["car", "bike"]
    assert by_category["car"].to_list() == [1.0, -3.0]
    assert by_category["bike"].dtype == pl.Float64
    with pytest.raises(ValueError, match="per category; use by_category"):
        grouped.values()
    with pytest.raises(ValueError, match="per category"):
        grouped.labelled()
    with pytest.raises(ValueError, match="not per category"):
        view.data_by_name["xs"].by_category()


def test_labels_need_an_index(view: JobMetricsView) -> None:
    with pytest.raises(ValueError, match="'xs' has no index"):
        view.data_by_name["xs"].labelled()
    with pytest.raises(ValueError, match="not indexed by strings"):
        view.data_by_name["speeds"].by_label()
    # Read on its own, the data has an index ID but not the index itself.
    alone = read_metrics_data(view.data_by_name["bar values"].raw.SerializeToString())
    assert alone.index is None
    with pytest.raises(ValueError, match="not at hand"):
        alone.labelled()
    index = read_metrics_data(view.data_by_name["bar names"].raw.SerializeToString())
    assert alone.with_index(index).by_label() == {"a": 1.0, "b": 2.0}
    with pytest.raises(ValueError, match=r"'xs' .* is not the index of 'bar values'"):
        alone.with_index(view.data_by_name["xs"])


def test_repeated_labels() -> None:
    w = MetricsWriter(uuid.uuid4())
    labels = data.strings("labels", ["car", "car"])
    w.bar_chart("Twice", data.doubles("values", [1.0, 2.0], index=labels))
    values = written(w).metric("Twice", BarChartMetric).values_data[0]
    assert values.labelled() == (("car", 1.0), ("car", 2.0))
    with pytest.raises(ValueError, match="repeats the label 'car'"):
        values.by_label()


def test_plain_values_of_every_kind() -> None:
    w = MetricsWriter(uuid.uuid4())
    ids = [uuid.UUID(int=7), uuid.UUID(int=8)]
    for d in (
        data.uuids("ids", ids),
        data.timestamps("times", [5, 6]),
        data.statuses("statuses", [MetricStatus.PASSED, MetricStatus.FAIL_BLOCK]),
        data.external_file("file", "a.png"),
    ):
        w.add_data(d)
    view = written(w)
    assert view.data_by_name["ids"].values() == tuple(ids)
    assert view.data_by_name["times"].values() == (5, 6)
    assert view.data_by_name["statuses"].values() == (MetricStatus.PASSED, MetricStatus.FAIL_BLOCK)
    with pytest.raises(ValueError, match="external file"):
        view.data_by_name["file"].values()


# ---------------------------------------------------------------- what cannot be read


def test_a_missing_metric_names_close_names(view: JobMetricsView) -> None:
    with pytest.raises(KeyError) as caught:
        view.metric("Histogramm")
    assert (
        str(caught.value) == "the output has no metric named 'Histogramm'; close names: 'Histogram'"
    )
    with pytest.raises(KeyError, match=r"no metric named 'zzz'$"):
        view.metric("zzz")
    assert view.find_metric("zzz") is None


def test_missing_data_names_the_metric_and_the_id(view: JobMetricsView) -> None:
    msg = pb.JobMetrics()
    msg.CopyFrom(view.raw)
    gone = view.data_by_name["hist values"]
    kept = [d for d in msg.metrics_data if d.name != "hist values"]
    del msg.metrics_data[:]
    msg.metrics_data.extend(kept)
    broken = parse_job_metrics(msg)
    with pytest.raises(MissingDataError) as caught:
        broken.metric("Histogram")
    assert isinstance(caught.value, ReadError)
    assert (caught.value.metric, caught.value.data_id) == ("Histogram", gone.id)
    assert str(caught.value) == (
        f"metric 'Histogram' references metrics data {gone.id}, which the output does not hold"
    )
    # Metrics that do not reference it still read.
    assert broken.metric("Bars", BarChartMetric).values_data[0].by_label() == {"a": 1.0, "b": 2.0}


def test_values_of_another_type_are_a_read_error(view: JobMetricsView) -> None:
    msg = pb.JobMetrics()
    msg.CopyFrom(view.raw)
    for m in msg.job_level_metrics.metrics:
        if m.name == "Bars":
            m.type = pb.HISTOGRAM_METRIC_TYPE
    with pytest.raises(ReadError, match="'Bars' is a HISTOGRAM metric but holds bar_chart"):
        parse_job_metrics(msg).metric("Bars")


@pytest.mark.parametrize("metric_type", [99, pb.NO_METRIC_TYPE])
def test_an_unknown_type_reads_as_unknown_metric(view: JobMetricsView, metric_type: int) -> None:
    msg = pb.JobMetrics()
    msg.CopyFrom(view.raw)
    for m in msg.job_level_metrics.metrics:
        if m.name == "Histogram":
            m.type = metric_type  # type: ignore[assignment]
    unknown = parse_job_metrics(msg).metric("Histogram")
    assert isinstance(unknown, UnknownMetric)
    assert unknown.type == (99 if metric_type else None)
    assert names(unknown.data) == ["hist values", "hist statuses"]


def test_unset_references_and_fields_are_none() -> None:
    w = MetricsWriter(uuid.uuid4())
    values = data.doubles("v", [1.0, 2.0])
    w.histogram("H", values, buckets=2, lower=0, upper=2)
    view = written(w)
    msg = pb.JobMetrics()
    msg.CopyFrom(view.raw)
    hist = msg.job_level_metrics.metrics[0].metric_values.histogram_metric_values
    hist.ClearField("statuses_data_id")
    hist.ClearField("lower_bound")
    read = parse_job_metrics(msg).metric("H", HistogramMetric)
    assert read.statuses_data is None
    assert read.lower_bound is None
    assert read.values_data is not None
    assert read.values_data.kind is SeriesKind.DOUBLE


def test_typed_views_of_writer_output_round_trip() -> None:
    w = MetricsWriter(uuid.uuid4())
    idx = data.strings("labels", ["x", "y"])
    w.double_summary(
        "By label", data.doubles("vals", [3.0, 4.0], index=idx), index="y", failure=(5.0, 1.0)
    )
    w.scalar("S", 1.0, fails_above=2.0, fails_below=0.0)
    view = read_job_metrics(w.serialize())
    summary = view.metric("By label", DoubleSummaryMetric)
    assert (summary.string_index, summary.series_index) == ("y", None)
    assert (summary.fails_above, summary.fails_below) == (5.0, 1.0)
    assert summary.value_data is not None
    assert summary.value_data.by_label()["y"] == 4.0
    s = view.metric("S", ScalarMetric)
    assert (s.fails_above, s.fails_below, s.unit) == (2.0, 0.0, None)


def _with_data(
    view: JobMetricsView, name: str, edit: Callable[[pb.MetricsData], None]
) -> JobMetricsView:
    msg = pb.JobMetrics()
    msg.CopyFrom(view.raw)
    for d in msg.metrics_data:
        if d.name == name:
            edit(d)
    return parse_job_metrics(msg, source="edited")


def test_plain_values_of_odd_elements(view: JobMetricsView) -> None:
    def odd_statuses(d: pb.MetricsData) -> None:
        d.series.statuses.series[:] = [pb.NO_METRIC_STATUS, 42, pb.RAW_METRIC_STATUS]  # type: ignore[list-item]

    edited = _with_data(view, "speed statuses", odd_statuses)
    assert edited.data_by_name["speed statuses"].values() == (None, 42, MetricStatus.RAW)

    def bad_uuid(d: pb.MetricsData) -> None:
        d.series.uuids.series[0].data = "not-a-uuid"

    edited = _with_data(view, "batch ids", bad_uuid)
    with pytest.raises(ReadError, match=r"'edited'.*'batch ids'.*'not-a-uuid' is not a UUID"):
        edited.data_by_name["batch ids"].values()


def test_labels_and_values_of_different_lengths_are_a_read_error(view: JobMetricsView) -> None:
    def shorter(d: pb.MetricsData) -> None:
        del d.series.strings.series[1]

    edited = _with_data(view, "bar names", shorter)
    with pytest.raises(
        ReadError, match="'bar values' has 2 values but its index 'bar names' has 1"
    ):
        edited.metric("Bars", BarChartMetric).values_data[0].labelled()


def test_a_bad_index_uuid_in_a_summary_is_a_read_error() -> None:
    w = MetricsWriter(uuid.uuid4())
    ids = data.uuids("ids", [uuid.UUID(int=1)])
    w.double_summary("By id", data.doubles("v", [1.0], index=ids), index=uuid.UUID(int=1))
    msg = w.to_proto()
    msg.job_level_metrics.metrics[0].metric_values.double_metric_values.uuid_index.data = "zz"
    with pytest.raises(ReadError, match="metric 'By id': 'zz' is not a UUID"):
        parse_job_metrics(msg).metric("By id")


def test_an_unknown_metric_missing_its_data(view: JobMetricsView) -> None:
    msg = pb.JobMetrics()
    msg.CopyFrom(view.raw)
    for m in msg.job_level_metrics.metrics:
        if m.name == "Histogram":
            m.type = 99  # type: ignore[assignment]
    kept = [d for d in msg.metrics_data if d.name != "hist statuses"]
    del msg.metrics_data[:]
    msg.metrics_data.extend(kept)
    with pytest.raises(MissingDataError, match="metric 'Histogram' references metrics data"):
        parse_job_metrics(msg).metric("Histogram")
