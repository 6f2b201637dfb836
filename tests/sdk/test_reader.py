"""The SDK reader: bytes -> typed views and polars frames, and its refusals."""

from __future__ import annotations

import contextlib
import math
import struct
import uuid
from datetime import UTC, datetime

import numpy as np
import polars as pl
import pytest
from hypothesis import given
from hypothesis import strategies as st
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate
from resim.metrics.python import metrics as rm
from resim.metrics.python.metrics_utils import (
    DoubleFailureDefinition,
    HistogramBucket,
    MetricImportance,
    MetricStatus,
    Timestamp,
)
from resim.metrics.python.metrics_writer import ResimMetricsWriter

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    KIND_DTYPE,
    STATUS_DTYPE,
    JobMetricsView,
    MetricsDataView,
    MetricsWriter,
    MetricType,
    ReadError,
    SeriesKind,
    find_problems,
    parse_job_metrics,
    parse_metric,
    parse_metrics_data,
    read_job_metrics,
    read_metric,
    read_metrics_data,
)
from stook.sdk import MetricStatus as StookStatus
from tests.hypothesis_profiles import examples
from tests.strategies import valid_job_metrics

JOB_ID = uuid.UUID("11111111-2222-4333-8444-555555555555")
PASSED = MetricStatus.PASSED_METRIC_STATUS
HIGH = MetricImportance.HIGH_IMPORTANCE


# ---------------------------------------------------------------- a ReSim-written output


def _common(metric: rm.Metric) -> None:
    metric.with_status(PASSED).with_importance(HIGH).with_should_display(True).with_blocking(
        False
    ).with_description("described")


def resim_written() -> resim_pb.JobMetrics:
    """Every metric type and data kind, written by ReSim's own writer."""
    w = ResimMetricsWriter(JOB_ID)
    times = rm.SeriesMetricsData(
        "times", series=np.array([Timestamp(secs=i, nanos=500) for i in range(3)])
    )
    speeds = rm.SeriesMetricsData(
        "speeds", series=np.array([1.0, 2.5, -3.0]), unit="m/s", index_data=times
    )
    speed_statuses = rm.SeriesMetricsData(
        "speed statuses", series=np.array([PASSED] * 3), index_data=times
    )
    m = w.add_double_over_time_metric("Speed")
    m.append_doubles_over_time_data(speeds, "car").append_statuses_over_time_data(speed_statuses)
    m.with_failure_definitions([DoubleFailureDefinition(fails_above=10.0, fails_below=None)])
    m.with_start_time(Timestamp(0, 0)).with_end_time(Timestamp(2, 0)).with_y_axis_name("v")
    _common(m)

    scalar = w.add_scalar_metric("Max speed").with_value(2.5).with_unit("m/s")
    _common(scalar.with_tag("team", "planning"))

    xs = rm.SeriesMetricsData("xs", series=np.array([0.0, 1.0]))
    ys = rm.SeriesMetricsData("ys", series=np.array([4.0, 5.0]))
    xy_statuses = rm.SeriesMetricsData(
        "xy statuses", series=np.array([PASSED, MetricStatus.FAIL_WARN_METRIC_STATUS])
    )
    line = w.add_line_plot_metric("Path").append_series_data(xs, ys, "path")
    _common(line.append_statuses_data(xy_statuses).with_x_axis_name("x").with_y_axis_name("y"))

    bar_names = rm.SeriesMetricsData("bar names", series=np.array(["a", "b"]))
    bar_values = rm.SeriesMetricsData(
        "bar values", series=np.array([1.0, 2.0]), index_data=bar_names
    )
    bar_statuses = rm.SeriesMetricsData(
        "bar statuses", series=np.array([PASSED, PASSED]), index_data=bar_names
    )
    bar = w.add_bar_chart_metric("Bars").append_values_data(bar_values, "v")
    _common(bar.append_statuses_data(bar_statuses).with_stack_bars(True))

    batch_ids = rm.SeriesMetricsData(
        "batch ids", series=np.array([uuid.UUID(int=1), uuid.UUID(int=2)])
    )
    batch_values = rm.SeriesMetricsData(
        "batch values", series=np.array([0.5, 0.75]), index_data=batch_ids
    )
    batch_times = rm.SeriesMetricsData(
        "batch times", series=np.array([Timestamp(1, 0), Timestamp(2, 0)]), index_data=batch_ids
    )
    batch_statuses = rm.SeriesMetricsData(
        "batch statuses", series=np.array([PASSED, PASSED]), index_data=batch_ids
    )
    batch = w.add_batchwise_bar_chart_metric("Batches").with_project_id(uuid.UUID(int=3))
    batch.append_category_data("cat", batch_times, batch_values, batch_statuses)
    _common(batch.with_colors(["#aabbcc"]).with_x_axis_name("t").with_y_axis_name("v"))

    states = rm.SeriesMetricsData(
        "states", series=np.array(["idle", "drive", "idle"]), index_data=times
    )
    state_statuses = rm.SeriesMetricsData(
        "state statuses", series=np.array([PASSED] * 3), index_data=times
    )
    sot = w.add_states_over_time_metric("States").with_states_set({"idle", "drive"})
    sot.append_states_over_time_data(states, "s").append_statuses_over_time_data(state_statuses)
    _common(sot.with_failure_states({"drive"}))

    hist_values = rm.SeriesMetricsData("hist values", series=np.array([0.5, 1.5, 2.0]))
    hist_statuses = rm.SeriesMetricsData("hist statuses", series=np.array([PASSED] * 3))
    hist = w.add_histogram_metric("Histogram").with_values_data(hist_values)
    hist.with_statuses_data(hist_statuses).with_lower_bound(0.0).with_upper_bound(3.0)
    _common(hist.with_buckets([HistogramBucket(0.0, 1.0), HistogramBucket(1.0, 3.0)]))

    summary = w.add_double_summary_metric("Summary").with_value_data(hist_values)
    _common(summary.with_status_data(hist_statuses).with_index(1))

    _common(w.add_plotly_metric("Plot").with_plotly_data('{"data": [{"x": [1, 2]}]}'))
    image = rm.ExternalFileMetricsData("picture", "images/a.png")
    _common(w.add_image_metric("Image").with_image_data(image))
    more = [rm.ExternalFileMetricsData(f"picture {i}", f"images/{i}.png") for i in range(2)]
    _common(w.add_image_list_metric("Images").with_image_list_data(more))
    _common(w.add_text_metric("Text").with_text("# hello"))

    ev_metric = w.add_scalar_metric("Stop speed").with_value(0.0).is_event_metric()
    _common(ev_metric)
    event = w.add_event("Stop").with_absolute_timestamp(Timestamp(7, 9)).with_metrics([ev_metric])
    event.with_status(PASSED).with_importance(HIGH).with_tags(["stops"])

    grouping = rm.SeriesMetricsData("vehicle", series=np.array(["car", "bike", "car"]))
    grouped = speeds.group_by(grouping, "speeds by vehicle", "times by vehicle")
    w.add_metrics_data(grouped)
    return w.write().metrics_msg


@pytest.fixture(scope="module")
def resim_msg() -> resim_pb.JobMetrics:
    return resim_written()


@pytest.fixture(scope="module")
def view(resim_msg: resim_pb.JobMetrics) -> JobMetricsView:
    return read_job_metrics(resim_msg.SerializeToString(), source="resim.binproto")


def test_resim_output_is_valid_for_both_validators(resim_msg: resim_pb.JobMetrics) -> None:
    resim_validate(resim_msg)
    assert find_problems(pb.JobMetrics.FromString(resim_msg.SerializeToString())) == []


def test_resim_output_is_read_with_nothing_lost(
    resim_msg: resim_pb.JobMetrics, view: JobMetricsView
) -> None:
    wire = resim_msg.SerializeToString(deterministic=True)
    assert view.raw.SerializeToString(deterministic=True) == wire
    for metric, theirs in zip(view.metrics, resim_msg.job_level_metrics.metrics, strict=True):
        assert metric.raw.SerializeToString() == theirs.SerializeToString()
        single = read_metric(theirs.SerializeToString())
        assert single == metric
    for data, theirs_data in zip(view.data, resim_msg.metrics_data, strict=True):
        wire_data = theirs_data.SerializeToString(deterministic=True)
        assert read_metrics_data(wire_data).raw.SerializeToString(deterministic=True) == wire_data
        assert data.raw.SerializeToString(deterministic=True) == wire_data


def test_every_metric_type_is_read(view: JobMetricsView) -> None:
    assert {m.type for m in view.metrics} == set(MetricType)
    assert view.job_id == JOB_ID
    assert view.status is StookStatus.PASSED
    for metric in view.metrics:
        assert metric.job_id == JOB_ID
        assert metric.status is StookStatus.PASSED
        assert metric.description == "described"
        assert metric.should_display is True
        assert metric.blocking is False
        assert metric.order is not None


def test_metric_fields(view: JobMetricsView) -> None:
    by_name = {m.name: m for m in view.metrics}
    scalar = by_name["Max speed"]
    assert (scalar.value, scalar.unit, scalar.tags) == (2.5, "m/s", (("team", "planning"),))
    assert scalar.data_ids == ()
    assert scalar.event_metric is False
    assert by_name["Stop speed"].event_metric is True
    assert by_name["Speed"].value is None
    assert by_name["Speed"].unit is None
    # Every referenced data, whatever the field, exists in the output.
    for metric in view.metrics:
        for data_id in metric.data_ids:
            assert data_id in view.data_by_id
    names = {m.name: {view.data_by_id[i].name for i in m.data_ids} for m in view.metrics}
    assert names["Speed"] == {"speeds", "speed statuses"}
    assert names["Path"] == {"xs", "ys", "xy statuses"}
    assert names["Batches"] == {"batch values", "batch times", "batch statuses"}
    assert names["Histogram"] == names["Summary"] == {"hist values", "hist statuses"}
    assert names["Image"] == {"picture"}
    assert names["Images"] == {"picture 0", "picture 1"}
    assert names["Text"] == names["Plot"] == set()


def test_events(view: JobMetricsView) -> None:
    (event,) = view.events
    assert event.name == "Stop"
    assert event.timestamp_ns == 7_000_000_009
    assert event.timestamp_type == "absolute"
    assert event.tags == ("stops",)
    assert [view.metrics_by_id[i].name for i in event.metric_ids] == ["Stop speed"]
    assert event.status is StookStatus.PASSED


def test_every_data_kind_has_the_right_dtype(view: JobMetricsView) -> None:
    d = view.data_by_name
    speeds = d["speeds"].series()
    assert speeds.dtype == pl.Float64
    assert speeds.name == "speeds"
    assert speeds.to_list() == [1.0, 2.5, -3.0]
    assert d["speeds"].unit == "m/s"
    assert d["speeds"].indexed
    assert d["speeds"].index_id == d["times"].id
    assert d["speeds"].index_kind is SeriesKind.TIMESTAMP
    times = d["times"].series()
    assert times.dtype == pl.Datetime("ns", "UTC")
    assert times.to_list()[1] == datetime(1970, 1, 1, 0, 0, 1, tzinfo=UTC).replace(microsecond=0)
    assert times.cast(pl.Int64).to_list() == [500, 1_000_000_500, 2_000_000_500]
    ids = d["batch ids"].series()
    assert ids.dtype == pl.String
    assert ids.to_list() == [str(uuid.UUID(int=1)), str(uuid.UUID(int=2))]
    assert d["bar names"].series().to_list() == ["a", "b"]
    statuses = d["xy statuses"].series()
    assert statuses.dtype == STATUS_DTYPE
    assert statuses.to_list() == ["PASSED", "FAIL_WARN"]


def test_per_category_frame(view: JobMetricsView) -> None:
    grouped = view.data_by_name["speeds by vehicle"]
    assert grouped.per_category
    assert grouped.categories == ("car", "bike")
    with pytest.raises(ValueError, match="per category"):
        grouped.series()
    frame = grouped.frame()
    assert dict(frame.schema) == (
        {"category": pl.String, "position": pl.UInt32, "value": pl.Float64}
    )
    assert frame.rows() == [("car", 0, 1.0), ("car", 1, -3.0), ("bike", 0, 2.5)]
    assert grouped.category_series("bike").to_list() == [2.5]
    with pytest.raises(KeyError):
        grouped.category_series("truck")
    assert grouped.index_id is not None
    assert view.data_by_id[grouped.index_id].name == "times by vehicle"


def test_plain_frame(view: JobMetricsView) -> None:
    frame = view.data_by_name["xs"].frame()
    assert frame.rows() == [(None, 0, 0.0), (None, 1, 1.0)]
    assert frame["category"].dtype == pl.String


def test_external_files_have_no_series(view: JobMetricsView) -> None:
    picture = view.data_by_name["picture"]
    assert picture.is_external
    assert picture.kind is SeriesKind.EXTERNAL_FILE
    assert picture.external_path == "images/a.png"
    with pytest.raises(ValueError, match="external file"):
        picture.series()
    with pytest.raises(ValueError, match="external file"):
        picture.frame()


def test_scalars_frame(view: JobMetricsView) -> None:
    frame = view.scalars_frame()
    assert dict(frame.schema) == (
        {
            "metric_id": pl.String,
            "name": pl.String,
            "value": pl.Float64,
            "unit": pl.String,
            "status": STATUS_DTYPE,
        }
    )
    assert frame.select("name", "value", "unit", "status").rows() == [
        ("Max speed", 2.5, "m/s", "PASSED"),
        ("Stop speed", 0.0, None, "PASSED"),
    ]


def test_series_frame(view: JobMetricsView) -> None:
    frame = view.series_frame()
    assert dict(frame.schema) == (
        {
            "data_id": pl.String,
            "data_name": pl.String,
            "kind": KIND_DTYPE,
            "category": pl.String,
            "position": pl.UInt32,
            "value_double": pl.Float64,
            "value_timestamp": pl.Datetime("ns", "UTC"),
            "value_uuid": pl.String,
            "value_string": pl.String,
            "value_status": STATUS_DTYPE,
        }
    )
    external = {d.name for d in view.data if d.is_external}
    assert external
    assert not external & set(frame["data_name"].to_list())
    assert len(frame) == sum(len(d.frame()) for d in view.data if not d.is_external)
    speeds = frame.filter(pl.col("data_name") == "speeds")
    assert speeds["value_double"].to_list() == [1.0, 2.5, -3.0]
    assert speeds["value_string"].null_count() == 3
    states = frame.filter(pl.col("kind") == "string", pl.col("data_name") == "states")
    assert states["value_string"].to_list() == ["idle", "drive", "idle"]


def test_empty_output_frames() -> None:
    job = pb.JobMetrics()
    job.job_id.id.data = str(JOB_ID)
    view = read_job_metrics(job.SerializeToString())
    assert view.series_frame().is_empty()
    assert view.scalars_frame().is_empty()
    assert view.series_frame().columns[0] == "data_id"
    assert view.metrics == ()
    assert view.data == ()
    assert view.events == ()


# ---------------------------------------------------------------- hand-made messages


def _data(kind: int, **fields: object) -> pb.MetricsData:
    d = pb.MetricsData(data_type=kind, name="d", **fields)  # type: ignore[arg-type]
    d.metrics_data_id.id.data = str(uuid.uuid4())
    return d


@pytest.mark.parametrize(
    ("data_type", "dtype"),
    [
        (pb.DOUBLE_SERIES_DATA_TYPE, pl.Float64),
        (pb.TIMESTAMP_SERIES_DATA_TYPE, pl.Datetime("ns", "UTC")),
        (pb.UUID_SERIES_DATA_TYPE, pl.String),
        (pb.STRING_SERIES_DATA_TYPE, pl.String),
        (pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, STATUS_DTYPE),
    ],
)
def test_empty_series_are_tolerated(data_type: int, dtype: pl.DataType) -> None:
    for d in (_data(data_type), _data(data_type, is_per_category=True)):
        if not d.is_per_category:
            d.series.SetInParent()
        view = parse_metrics_data(d)
        if not view.per_category:
            assert view.series().dtype == dtype
            assert len(view.series()) == 0
        frame = view.frame()
        assert frame.is_empty()
        assert frame["value"].dtype == dtype


def test_unset_optional_fields_read_as_none() -> None:
    m = pb.Metric(name="bare")
    m.metric_id.id.data = str(uuid.uuid4())
    view = read_metric(m.SerializeToString())
    for name in ("type", "status", "importance", "job_id", "order", "blocking", "should_display"):
        assert getattr(view, name) is None, name
    assert view.value is None
    assert view.data_ids == ()
    scalar = pb.Metric(name="s", type=pb.SCALAR_METRIC_TYPE)
    scalar.metric_id.id.data = str(uuid.uuid4())
    scalar.metric_values.scalar_metric_values.SetInParent()
    assert parse_metric(scalar).value is None


@pytest.mark.parametrize("copies", [1, 100])  # below and above the packed-bytes path
def test_special_doubles_keep_their_bits_on_both_paths(copies: int) -> None:
    values = [0.0, -0.0, math.inf, -math.inf, 5e-324, 1.7976931348623157e308, math.nan] * copies
    d = _data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(values)
    got = read_metrics_data(d.SerializeToString()).series()
    assert got.dtype == pl.Float64
    assert got.name == d.name
    assert [struct.pack("<d", v) for v in got] == [struct.pack("<d", v) for v in values]


@pytest.mark.parametrize("length", [1, 399, 400, 401, 4096, 70_000])
def test_double_series_of_any_length_match_the_proto(length: int) -> None:
    d = _data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(float(i) * 0.1 - 7.0 for i in range(length))
    got = read_metrics_data(d.SerializeToString()).series()
    assert got.equals(pl.Series(d.name, list(d.series.doubles.series), dtype=pl.Float64))


def test_unknown_fields_in_a_long_series_fall_back_to_copying() -> None:
    d = _data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(float(i) for i in range(1000))
    d.series.doubles.MergeFromString(b"\x10\x07")
    assert read_metrics_data(d.SerializeToString()).series().to_list() == [
        float(i) for i in range(1000)
    ]


def test_large_double_series_matches_the_proto() -> None:
    d = _data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(float(i) * 0.1 for i in range(200_000))
    got = read_metrics_data(d.SerializeToString()).series()
    assert got.equals(pl.Series("d", list(d.series.doubles.series), dtype=pl.Float64))


def test_unknown_fields_inside_a_series_do_not_break_doubles() -> None:
    # Nested unknown fields are kept; the fast path then falls back to copying.
    d = _data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend([1.0, 2.0])
    d.series.doubles.MergeFromString(b"\x10\x07")  # field 2, varint 7: not in DoubleSeries
    view = read_metrics_data(d.SerializeToString())
    assert view.series().to_list() == [1.0, 2.0]
    assert view.raw.SerializeToString(deterministic=True) == d.SerializeToString(deterministic=True)


def test_status_zero_is_null() -> None:
    d = _data(pb.METRIC_STATUS_SERIES_DATA_TYPE)
    d.series.statuses.series.extend(pb.MetricStatus.ValueType(v) for v in (0, 5, 3, 4))
    assert parse_metrics_data(d).series().to_list() == [None, "FAIL_BLOCK", "NOT_APPLICABLE", "RAW"]


def test_uuids_are_canonicalised() -> None:
    d = _data(pb.UUID_SERIES_DATA_TYPE)
    u = uuid.UUID(int=0xABCDEF)
    for text in (str(u).upper(), u.hex, "{" + str(u) + "}", u.urn):
        d.series.uuids.series.add().data = text
    assert set(parse_metrics_data(d).series().to_list()) == {str(u)}


def test_bad_uuid_in_a_series_is_a_read_error_on_conversion() -> None:
    d = _data(pb.UUID_SERIES_DATA_TYPE)
    d.series.uuids.series.add().data = "nope"
    view = read_metrics_data(d.SerializeToString(), source="ids.bin")
    with pytest.raises(ReadError, match=r"could not read MetricsData from 'ids.bin'.*'nope'"):
        view.series()


def test_timestamp_out_of_range_is_a_read_error_on_conversion() -> None:
    d = _data(pb.TIMESTAMP_SERIES_DATA_TYPE)
    d.series.timestamps.series.add().seconds = 2**62
    with pytest.raises(ReadError, match="too far"):
        parse_metrics_data(d).frame()


def test_parse_variants_copy_the_message() -> None:
    d = _data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.append(1.0)
    view = parse_metrics_data(d)
    d.series.doubles.series.append(2.0)
    assert view.series().to_list() == [1.0]
    job = pb.JobMetrics()
    job.metrics_data.append(d)
    assert len(parse_job_metrics(job).data) == 1


# ---------------------------------------------------------------- refusals


@pytest.mark.parametrize("reader", [read_job_metrics, read_metric, read_metrics_data])
def test_empty_bytes_are_refused(reader: object) -> None:
    with pytest.raises(ReadError, match=r"from 'empty.bin': no bytes"):
        reader(b"", source="empty.bin")  # type: ignore[operator]


def _top_level_boundaries(msg: pb.JobMetrics) -> set[int]:
    """Offsets at which a cut leaves a shorter but well-formed JobMetrics."""
    boundaries, partial = {0}, pb.JobMetrics()
    for fd, value in msg.ListFields():
        for item in list(value) if fd.is_repeated else [value]:
            if fd.is_repeated:
                getattr(partial, fd.name).append(item)
            elif fd.message_type is not None:
                getattr(partial, fd.name).CopyFrom(item)
            else:
                setattr(partial, fd.name, item)
            boundaries.add(len(partial.SerializeToString(deterministic=True)))
    return boundaries


def test_truncated_bytes_are_refused_at_every_cut(resim_msg: resim_pb.JobMetrics) -> None:
    # Deterministic on both sides: map entries (per-category series) may otherwise come out
    # in a different order, which made this comparison flaky.
    wire = resim_msg.SerializeToString(deterministic=True)
    ours = pb.JobMetrics.FromString(wire)
    boundaries = _top_level_boundaries(ours)
    assert wire == ours.SerializeToString(deterministic=True)
    refused = 0
    for cut in range(len(wire)):
        if cut in boundaries and cut:
            read_job_metrics(wire[:cut])  # a well-formed prefix: protobuf cannot tell
            continue
        with pytest.raises(ReadError) as info:
            read_job_metrics(wire[:cut], source="cut.bin")
        assert str(info.value).startswith("could not read JobMetrics from 'cut.bin': ")
        assert "\n" not in str(info.value)
        refused += 1
    assert refused > len(wire) * 0.9


def test_truncation_error_is_chained_from_protobuf(resim_msg: resim_pb.JobMetrics) -> None:
    wire = resim_msg.SerializeToString()
    with pytest.raises(ReadError, match="not a valid protobuf message") as info:
        read_job_metrics(wire[: len(wire) // 2], source="half.bin")
    assert type(info.value.__cause__).__name__ == "DecodeError"


def test_another_message_type_is_refused(resim_msg: resim_pb.JobMetrics) -> None:
    metric = resim_msg.job_level_metrics.metrics[0].SerializeToString()
    with pytest.raises(ReadError, match=r"could not read MetricsData from 'm.bin': "):
        read_metrics_data(metric, source="m.bin")
    # Parses, but Metric's name (2) and type (3) have the wrong wire types for
    # MetricsData's data_type (2) and name (3): protobuf keeps them as unknown fields.
    small = pb.Metric(name="x", type=pb.SCALAR_METRIC_TYPE).SerializeToString()
    with pytest.raises(ReadError, match=r"field number\(s\) 2, 3 do not fit MetricsData"):
        read_metrics_data(small, source="m.bin")
    data = resim_msg.metrics_data[0].SerializeToString()
    with pytest.raises(ReadError, match="could not read Metric from"):
        read_metric(data)
    with pytest.raises(ReadError, match="could not read JobMetrics from"):
        read_job_metrics(metric)


def test_unknown_enum_values_are_read_and_kept() -> None:
    """A newer schema's enum values (ReSim's validator accepts them) are read, not refused."""
    m = pb.Metric(name="odd", type=99, status=42, importance=9)  # type: ignore[arg-type]
    m.metric_id.id.data = str(uuid.uuid4())
    metric = read_metric(m.SerializeToString(), source="odd.bin")
    assert (metric.type, metric.status, metric.importance) == (99, 42, 9)
    assert not isinstance(metric.status, StookStatus)  # the number, not a member

    d = _data(77)
    d.series.doubles.series.append(1.0)
    unknown = read_metrics_data(d.SerializeToString())
    assert unknown.kind is None
    assert unknown.raw.data_type == 77
    with pytest.raises(ValueError, match="data type 77, which this schema does not know"):
        unknown.frame()

    s = _data(pb.METRIC_STATUS_SERIES_DATA_TYPE)
    s.series.statuses.series.extend(pb.MetricStatus.ValueType(v) for v in (1, 40))
    statuses = read_metrics_data(s.SerializeToString())
    assert statuses.series().to_list() == ["PASSED", None]  # frames hold known names only
    assert list(statuses.raw.series.statuses.series) == [1, 40]

    e = pb.Event(name="e", status=43, timestamp_type=7)  # type: ignore[arg-type]
    e.event_id.id.data = str(uuid.uuid4())
    job = pb.JobMetrics(metrics_status=44)  # type: ignore[arg-type]
    job.job_id.id.data = str(uuid.uuid4())
    job.job_level_metrics.metrics.append(m)
    job.metrics_data.extend([d, s])
    job.events.append(e)
    view = read_job_metrics(job.SerializeToString())
    assert view.status == 44
    assert (view.events[0].status, view.events[0].timestamp_type) == (43, 7)
    assert view.scalars_frame().height == 0  # type 99 is not SCALAR
    # The unknown data type has no series to put in the frame; the statuses have.
    assert view.series_frame()["data_name"].to_list() == ["d", "d"]


def test_unknown_status_of_a_scalar_reads_as_null_in_the_frame() -> None:
    w = MetricsWriter(uuid.uuid4(), deterministic=True)
    w.scalar("x", 1.5)
    msg = w.to_proto()
    msg.job_level_metrics.metrics[0].status = 42  # type: ignore[assignment]
    view = read_job_metrics(msg.SerializeToString())
    assert view.metrics[0].status == 42
    assert view.scalars_frame()["status"].to_list() == [None]


def test_series_of_the_wrong_kind_is_refused() -> None:
    d = _data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.strings.series.append("x")
    with pytest.raises(ReadError, match="declared double but its series holds strings"):
        read_metrics_data(d.SerializeToString())


def test_missing_or_bad_ids_are_refused() -> None:
    m = pb.Metric(name="no id")
    with pytest.raises(ReadError, match="metric 'no id': id is missing"):
        read_metric(m.SerializeToString())
    m.metric_id.id.data = "xyz"
    with pytest.raises(ReadError, match="metric 'no id': id 'xyz' is not a UUID"):
        read_metric(m.SerializeToString())


_FUZZ = examples(300)


def _read_everything(data: bytes) -> None:
    """Read data as each message type; only ReadError may escape."""
    views: list[object] = []
    for reader in (read_job_metrics, read_metric, read_metrics_data):
        try:
            views.append(reader(data, source="fuzz"))
        except ReadError as exc:
            message = str(exc)
            assert message.startswith("could not read ")
            assert "from 'fuzz': " in message
    for view in views:
        if isinstance(view, JobMetricsView):
            datas = list(view.data)
        elif isinstance(view, MetricsDataView):
            datas = [view]
        else:
            datas = []
        for d in datas:
            if d.is_external or d.kind is None:
                continue
            with contextlib.suppress(ReadError):  # e.g. a bad UUID inside a series
                d.frame()


@_FUZZ
@given(st.binary(max_size=200))
def test_garbage_raises_only_read_error(data: bytes) -> None:
    _read_everything(data)


@_FUZZ
@given(valid_job_metrics(max_metrics=2), st.data())
def test_corrupted_outputs_raise_only_read_error(msg: pb.JobMetrics, data: st.DataObject) -> None:
    wire = bytearray(msg.SerializeToString())
    if not wire:
        return
    for _ in range(data.draw(st.integers(1, 4))):
        pos = data.draw(st.integers(0, len(wire) - 1))
        wire[pos] = data.draw(st.integers(0, 255))
    _read_everything(bytes(wire))


@examples(40)
@given(valid_job_metrics())
def test_generated_outputs_read_back_completely(msg: pb.JobMetrics) -> None:
    wire = msg.SerializeToString(deterministic=True)
    view = read_job_metrics(wire)
    assert view.raw.SerializeToString(deterministic=True) == wire
    frame = view.series_frame()
    assert len(frame) == sum(len(d.frame()) for d in view.data if not d.is_external)
