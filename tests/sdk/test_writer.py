"""MetricsWriter and the data constructors: every metric type and data kind, read back.

Each output is checked three ways: stook's validator, ReSim's validator (the oracle)
and the SDK reader, whose views must give back exactly what was written.
"""

from __future__ import annotations

import itertools
import math
import re
import struct
import uuid
from array import array
from collections.abc import Callable, Iterable, Mapping
from contextlib import AbstractContextManager
from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import polars as pl
import pytest
import resim.metrics.proto.metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    STATUS_DTYPE,
    JobMetricsView,
    MetricImportance,
    MetricsDataView,
    MetricStatus,
    MetricsWriter,
    MetricType,
    MetricView,
    SeriesKind,
    WriterError,
    data,
    find_problems,
    read_job_metrics,
)
from stook.sdk._buckets import histogram_buckets

JOB = uuid.UUID("0b7a4c1e-5d2f-4e8a-9c3b-6f1d2e3a4b5c")
OTHER_JOB = uuid.UUID("9e8d7c6b-5a49-4382-9170-6f5e4d3c2b1a")
PROJECT = uuid.UUID("7b0e6a4e-2f1d-4c55-9a3e-0d6c2b9f1a11")
T0 = datetime(2026, 1, 1, 12, 0, tzinfo=UTC)
T0_NS = 1_767_268_800 * 1_000_000_000


def _ns(dt: datetime) -> int:
    return int((dt - datetime(1970, 1, 1, tzinfo=UTC)) / timedelta(microseconds=1)) * 1_000


def resim_accepts(payload: bytes) -> None:
    resim_validate(rp.JobMetrics.FromString(payload))


def written(w: MetricsWriter) -> JobMetricsView:
    """Serialize, check both validators accept, read back."""
    payload = w.serialize()
    problems = find_problems(w.to_proto())
    assert problems == [], "\n".join(map(str, problems))
    resim_accepts(payload)
    view = read_job_metrics(payload)
    assert view.job_id == w.job_id
    return view


def metric(view: JobMetricsView, name: str) -> MetricView:
    found = [m for m in view.metrics if m.name == name]
    assert len(found) == 1, f"{len(found)} metrics named {name!r}"
    return found[0]


def data_of(view: JobMetricsView, ref: pb.MetricsDataId) -> MetricsDataView:
    return view.data_by_id[uuid.UUID(ref.id.data)]


def names_of(view: JobMetricsView, refs: object) -> list[str]:
    return [data_of(view, r).name for r in refs]  # type: ignore[attr-defined]


def statuses_of(d: MetricsDataView) -> list[str]:
    return d.series().to_list()


def float_bits(values: Iterable[float]) -> bytes:
    return array("d", values).tobytes()


# ---------------------------------------------------------------- every data kind


def test_every_plain_data_kind_round_trips_with_exact_values_and_units() -> None:
    u1, u2 = uuid.UUID(int=1), uuid.UUID("12345678-1234-5678-1234-567812345678")
    w = MetricsWriter(JOB)
    w.add_data(
        data.doubles("d", [1.5, -2.25, 1e300], unit="m/s"),
        data.timestamps("t", [T0, T0_NS + 1, 0], unit="utc"),
        data.uuids("u", [u1, str(u2).upper(), u2.urn]),
        data.strings("s", ["a", "", "ü x"], unit="label"),
        data.statuses("st", [MetricStatus.PASSED, MetricStatus.FAIL_BLOCK, MetricStatus.RAW]),
    )
    view = written(w)
    assert [d.name for d in view.data] == ["d", "t", "u", "s", "st"]
    by = view.data_by_name
    assert {n: by[n].kind for n in by} == {
        "d": SeriesKind.DOUBLE,
        "t": SeriesKind.TIMESTAMP,
        "u": SeriesKind.UUID,
        "s": SeriesKind.STRING,
        "st": SeriesKind.STATUS,
    }
    assert {n: by[n].unit for n in by} == {"d": "m/s", "t": "utc", "u": "", "s": "label", "st": ""}
    assert all(not d.indexed and not d.per_category and d.index_id is None for d in view.data)
    assert by["d"].series().to_list() == [1.5, -2.25, 1e300]
    assert by["d"].series().dtype == pl.Float64
    ts = by["t"].series()
    assert ts.dtype == pl.Datetime("ns", "UTC")
    assert ts.dt.epoch("ns").to_list() == [T0_NS, T0_NS + 1, 0]
    raw_t = by["t"].raw.series.timestamps.series
    assert [(t.seconds, t.nanos) for t in raw_t] == [(1_767_268_800, 0), (1_767_268_800, 1), (0, 0)]
    assert by["u"].series().to_list() == [str(u1), str(u2), str(u2)]
    assert [x.data for x in by["u"].raw.series.uuids.series] == [str(u1), str(u2), str(u2)]
    assert by["s"].series().to_list() == ["a", "", "ü x"]
    assert by["st"].series().dtype == STATUS_DTYPE
    assert statuses_of(by["st"]) == ["PASSED", "FAIL_BLOCK", "RAW"]
    data_types = {d.name: d.raw.data_type for d in view.data}
    assert data_types == {
        "d": pb.DOUBLE_SERIES_DATA_TYPE,
        "t": pb.TIMESTAMP_SERIES_DATA_TYPE,
        "u": pb.UUID_SERIES_DATA_TYPE,
        "s": pb.STRING_SERIES_DATA_TYPE,
        "st": pb.METRIC_STATUS_SERIES_DATA_TYPE,
    }


@pytest.mark.parametrize(
    ("index_kind", "make_index"),
    [
        (SeriesKind.DOUBLE, lambda: data.doubles("idx", [0.0, 0.5, 1.0])),
        (SeriesKind.TIMESTAMP, lambda: data.timestamps("idx", [T0, T0 + timedelta(1), 5])),
        (SeriesKind.UUID, lambda: data.uuids("idx", [uuid.UUID(int=i) for i in (1, 2, 3)])),
        (SeriesKind.STRING, lambda: data.strings("idx", ["x", "y", "z"])),
        (SeriesKind.STATUS, lambda: data.statuses("idx", [MetricStatus.PASSED] * 3)),
    ],
)
@pytest.mark.parametrize(
    ("kind", "make"),
    [
        (SeriesKind.DOUBLE, lambda i: data.doubles("v", [1.0, 2.0, 3.0], index=i)),
        (SeriesKind.TIMESTAMP, lambda i: data.timestamps("v", [1, 2, 3], index=i)),
        (SeriesKind.UUID, lambda i: data.uuids("v", [uuid.UUID(int=9)] * 3, index=i)),
        (SeriesKind.STRING, lambda i: data.strings("v", ["p", "q", "r"], index=i)),
        (SeriesKind.STATUS, lambda i: data.statuses("v", [MetricStatus.FAIL_WARN] * 3, index=i)),
    ],
)
def test_indexed_data_of_every_kind_links_to_its_index(
    kind: SeriesKind, make: object, index_kind: SeriesKind, make_index: object
) -> None:
    index = make_index()  # type: ignore[operator]
    values = make(index)  # type: ignore[operator]
    w = MetricsWriter(JOB)
    w.add_data(values)
    view = written(w)
    # The index is written with the data, before it.
    assert [d.name for d in view.data] == ["idx", "v"]
    idx, v = view.data_by_name["idx"], view.data_by_name["v"]
    assert v.kind is kind
    assert v.indexed
    assert v.index_id == idx.id
    assert v.index_kind is index_kind
    assert idx.kind is index_kind
    assert not idx.indexed
    assert v.raw.index_data_type == idx.raw.data_type
    assert v.series().len() == 3


def test_per_category_data_round_trips_with_category_order_and_index() -> None:
    idx = data.per_category("frames", SeriesKind.TIMESTAMP, {"car": [1, 2], "ped": [3]})
    ranges = data.per_category(
        "ranges", SeriesKind.DOUBLE, {"car": [30.5, 42.0], "ped": [12.25]}, unit="m", index=idx
    )
    st_ = data.per_category(
        "range statuses",
        SeriesKind.STATUS,
        {"car": [MetricStatus.PASSED, MetricStatus.FAIL_WARN], "ped": [MetricStatus.FAIL_BLOCK]},
    )
    kinds: dict[SeriesKind, Mapping[str, list[object]]] = {
        SeriesKind.UUID: {"b": [uuid.UUID(int=4)]},
        SeriesKind.STRING: {"z": ["s1", "s2"], "a": ["s3"]},
    }
    w = MetricsWriter(JOB)
    w.add_data(ranges, st_)
    w.add_data(*(data.per_category(f"pc {k.value}", k, v) for k, v in kinds.items()))
    view = written(w)
    r = view.data_by_name["ranges"]
    assert r.per_category
    assert r.indexed
    assert r.unit == "m"
    assert r.categories == ("car", "ped")
    assert r.index_id == view.data_by_name["frames"].id
    assert r.category_series("car").to_list() == [30.5, 42.0]
    assert r.category_series("ped").to_list() == [12.25]
    assert r.raw.data_type == pb.INDEXED_DOUBLE_SERIES_DATA_TYPE
    frame = r.frame()
    assert frame["category"].to_list() == ["car", "car", "ped"]
    assert frame["position"].to_list() == [0, 1, 0]
    frames = view.data_by_name["frames"]
    assert frames.per_category
    assert frames.category_series("car").dt.epoch("ns").to_list() == [1, 2]
    statuses = view.data_by_name["range statuses"]
    assert statuses.category_series("car").to_list() == ["PASSED", "FAIL_WARN"]
    assert statuses.category_series("ped").to_list() == ["FAIL_BLOCK"]
    assert view.data_by_name["pc uuid"].category_series("b").to_list() == [str(uuid.UUID(int=4))]
    strings = view.data_by_name["pc string"]
    assert strings.categories == ("z", "a")
    assert strings.category_series("z").to_list() == ["s1", "s2"]


def test_external_file_data_keeps_its_path() -> None:
    w = MetricsWriter(JOB)
    w.add_data(data.external_file("Front", "images/front camera.png"))
    view = written(w)
    (d,) = view.data
    assert d.is_external
    assert d.kind is SeriesKind.EXTERNAL_FILE
    assert d.external_path == "images/front camera.png"
    assert d.raw.data_type == pb.EXTERNAL_FILE_DATA_TYPE
    assert not d.indexed
    assert not d.per_category


def test_timestamps_accept_aware_datetimes_of_any_zone_and_before_1970() -> None:
    plus2 = timezone(timedelta(hours=2))
    values = [
        datetime(2026, 1, 1, 14, 0, 0, 123456, tzinfo=plus2),
        datetime(1969, 12, 31, 23, 59, 59, 999999, tzinfo=UTC),
    ]
    d = data.timestamps("t", values)
    assert d.values == [T0_NS + 123_456_000, -1_000]
    w = MetricsWriter(JOB)
    w.add_data(d)
    raw = written(w).data_by_name["t"].raw.series.timestamps.series
    # Before 1970: floor division, so nanos stay in [0, 1e9).
    assert [(t.seconds, t.nanos) for t in raw] == [(1_767_268_800, 123_456_000), (-1, 999_999_000)]


# ---------------------------------------------------------------- doubles, exactly


SPECIAL = [0.0, -0.0, math.inf, -math.inf, 5e-324, -1.7976931348623157e308, 1 / 3]


def test_doubles_from_a_list_round_trip_bit_for_bit() -> None:
    w = MetricsWriter(JOB)
    w.add_data(data.doubles("x", SPECIAL))
    d = written(w).data_by_name["x"]
    assert float_bits(d.raw.series.doubles.series) == float_bits(SPECIAL)
    assert float_bits(d.series().to_list()) == float_bits(SPECIAL)
    assert math.copysign(1.0, d.series()[1]) == -1.0


def test_doubles_from_a_polars_series_round_trip_and_nulls_become_nan() -> None:
    w = MetricsWriter(JOB)
    w.add_data(
        data.doubles("f", pl.Series([1.25, None, -0.0, math.inf])),
        data.doubles("i", pl.Series([1, None, 3], dtype=pl.Int64)),
        data.doubles("f32", pl.Series([0.1], dtype=pl.Float32)),
    )
    by = written(w).data_by_name
    f = list(by["f"].raw.series.doubles.series)
    assert f[0] == 1.25
    assert math.isnan(f[1])
    assert f[3] == math.inf
    assert struct.pack("<d", f[2]) == struct.pack("<d", -0.0)
    assert list(by["i"].raw.series.doubles.series)[::2] == [1.0, 3.0]
    assert math.isnan(by["i"].raw.series.doubles.series[1])
    # Float32 widens exactly to the double nearest the float32, not to 0.1.
    assert by["f32"].raw.series.doubles.series[0] == float(np.float32(0.1))


def test_a_million_doubles_round_trip_bit_for_bit() -> None:
    rng = np.random.default_rng(7)
    values = rng.normal(size=1_000_000) * 1e6
    values[:6] = [-0.0, math.inf, -math.inf, 5e-324, 0.0, math.nan]
    w = MetricsWriter(JOB, deterministic=True)
    w.add_data(data.doubles("big", values), data.doubles("big polars", pl.Series(values)))
    payload = w.serialize()
    resim_accepts(payload)
    view = read_job_metrics(payload)
    for name in ("big", "big polars"):
        d = view.data_by_name[name]
        assert d.series().len() == 1_000_000
        assert d.series().to_numpy().tobytes() == values.tobytes()
        assert float_bits(d.raw.series.doubles.series) == values.tobytes()


def test_doubles_refuse_values_that_are_not_numbers() -> None:
    with pytest.raises(WriterError, match=r"metrics data 'x': values must be numbers"):
        data.doubles("x", ["a"])  # type: ignore[list-item]
    with pytest.raises(WriterError, match=r"metrics data 'x': values must be numbers"):
        data.doubles("x", [None])  # type: ignore[list-item]


def test_doubles_refuse_a_polars_series_of_strings_with_writer_error() -> None:
    with pytest.raises(WriterError, match=r"metrics data 'x'"):
        data.doubles("x", pl.Series(["a"]))


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
    fd = m.raw.metric_values.scalar_metric_values.failure_definition
    assert (fd.fails_above, fd.fails_below) == (40.0, 2.0)
    plain = metric(view, "No unit")
    assert plain.unit is None
    assert plain.importance is MetricImportance.MEDIUM
    assert plain.blocking is None
    assert plain.should_display is None
    assert plain.order is None
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
    mv = m.raw.metric_values.double_metric_values
    assert mv.WhichOneof("index") == "series_index"
    assert mv.series_index == 1
    assert data_of(view, mv.value_data_id).series().to_list() == [1.0, 2.0, 3.0]
    assert data_of(view, mv.value_data_id).unit == "m/s"
    status = data_of(view, mv.status_data_id)
    assert status.name == "Speeds (FAIL_WARN status)"
    assert statuses_of(status) == ["FAIL_WARN"] * 3
    assert (mv.failure_definition.fails_above, mv.failure_definition.fails_below) == (2.5, 0.5)
    whole = metric(view, "Whole").raw.metric_values.double_metric_values
    assert whole.WhichOneof("index") is None
    assert not whole.HasField("failure_definition")
    assert data_of(view, whole.status_data_id).name == "Speeds (PASSED status)"
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
    mv = metric(view, "At 2 s").raw.metric_values.double_metric_values
    assert mv.WhichOneof("index") == "timestamp_index"
    assert (mv.timestamp_index.seconds, mv.timestamp_index.nanos) == (1_767_268_802, 0)
    # With timestamp-indexed values an int is nanoseconds, not a position.
    ns = metric(view, "At ns").raw.metric_values.double_metric_values
    assert (ns.timestamp_index.seconds, ns.timestamp_index.nanos) == (1_767_268_803, 1)
    status = data_of(view, mv.status_data_id)
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
    assert u.WhichOneof("index") == "uuid_index"
    assert u.uuid_index.data == str(uuid.UUID(int=2))
    u2 = metric(view, "By uuid obj").raw.metric_values.double_metric_values
    assert u2.uuid_index.data == str(uuid.UUID(int=1))
    s = metric(view, "By label").raw.metric_values.double_metric_values
    assert s.WhichOneof("index") == "string_index"
    assert s.string_index == "bike"
    p = metric(view, "By pos").raw.metric_values.double_metric_values
    assert p.WhichOneof("index") == "series_index"
    assert p.series_index == 0
    # The Actors index is shared by two value series and written once.
    assert [d.name for d in view.data].count("Actors") == 1


def test_double_summary_with_explicit_statuses() -> None:
    w = MetricsWriter(JOB)
    values = data.doubles("v", [1.0, 2.0])
    st_ = data.statuses("v statuses", [MetricStatus.PASSED, MetricStatus.FAIL_BLOCK])
    w.double_summary("d", values, statuses=st_, index=1, status=MetricStatus.FAIL_BLOCK)
    view = written(w)
    mv = metric(view, "d").raw.metric_values.double_metric_values
    assert data_of(view, mv.status_data_id).name == "v statuses"
    assert statuses_of(data_of(view, mv.status_data_id)) == ["PASSED", "FAIL_BLOCK"]
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
    mv = m.raw.metric_values.double_over_time_metric_values
    assert names_of(view, mv.doubles_over_time_data_id) == ["Speed", "Accel"]
    assert names_of(view, mv.statuses_over_time_data_id) == ["Speed st", "Accel st"]
    fds = [
        (f.HasField("fails_above"), f.fails_above, f.HasField("fails_below"), f.fails_below)
        for f in mv.failure_definition
    ]
    assert fds == [(True, 1.5, False, 0.0), (False, 0.0, True, -1.0)]
    assert (mv.start_time.seconds, mv.start_time.nanos) == (1_767_268_800, 0)
    assert (mv.end_time.seconds, mv.end_time.nanos) == (1_767_268_802, 500_000_000)
    assert mv.y_axis_name == "value"
    assert list(mv.legend_series_names) == ["speed", "acceleration"]
    one = metric(view, "Speed only").raw.metric_values.double_over_time_metric_values
    # Default legend: the data names; default failure: an empty definition per series.
    assert list(one.legend_series_names) == ["Speed"]
    assert len(one.failure_definition) == 1
    assert not one.failure_definition[0].HasField("fails_above")
    assert not one.HasField("start_time")
    assert not one.HasField("end_time")
    assert names_of(view, one.statuses_over_time_data_id) == ["Speed (PASSED status)"]
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
    mv = m.raw.metric_values.line_plot_metric_values
    assert names_of(view, mv.x_doubles_data_id) == ["x1", "x2"]
    assert names_of(view, mv.y_doubles_data_id) == ["y1", "y2"]
    assert names_of(view, mv.statuses_data_id) == ["x1 (PASSED status)", "x2 (PASSED status)"]
    assert statuses_of(data_of(view, mv.statuses_data_id[1])) == ["PASSED"] * 3
    assert (mv.x_axis_name, mv.y_axis_name) == ("X", "Y")
    assert list(mv.legend_series_names) == ["one", "two"]
    timed = metric(view, "Timed").raw.metric_values.line_plot_metric_values
    assert list(timed.legend_series_names) == ["ty"]  # default: the y series names
    assert data_of(view, timed.statuses_data_id[0]).index_id == view.data_by_name["T"].id


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
    mv = metric(view, "Counts").raw.metric_values.bar_chart_metric_values
    assert names_of(view, mv.values_data_id) == ["Run A", "Run B"]
    assert names_of(view, mv.statuses_data_id) == ["Run A (PASSED status)", "Run B (PASSED status)"]
    assert list(mv.legend_series_names) == ["A", "B"]
    assert (mv.x_axis_name, mv.y_axis_name) == ("class", "n")
    assert mv.HasField("stack_bars")
    assert mv.stack_bars is True
    un = metric(view, "Unstacked").raw.metric_values.bar_chart_metric_values
    assert un.HasField("stack_bars")
    assert un.stack_bars is False
    default = metric(view, "Default").raw.metric_values.bar_chart_metric_values
    assert not default.HasField("stack_bars")
    assert list(default.legend_series_names) == ["Run B"]
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
    mv = m.raw.metric_values.bar_chart_metric_values
    values = data_of(view, mv.values_data_id[0])
    assert values.name == "Detections"
    assert values.series().to_list() == [41.0, 7.0, 3.0]
    labels = view.data_by_id[values.index_id]  # type: ignore[index]
    assert labels.name == "Detections (labels)"
    assert labels.series().to_list() == ["car", "pedestrian", "cyclist"]
    other = metric(view, "Other")
    assert other.status is MetricStatus.FAIL_WARN
    omv = other.raw.metric_values.bar_chart_metric_values
    assert data_of(view, omv.values_data_id[0]).name == "other data"
    assert "other data (labels)" in view.data_by_name
    assert omv.y_axis_name == "n"
    assert statuses_of(data_of(view, omv.statuses_data_id[0])) == ["FAIL_WARN"]


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
    mv = m.raw.metric_values.states_over_time_metric_values
    assert list(mv.states_set) == ["cruise", "slow", "stop"]
    assert list(mv.failure_states) == ["stop"]
    assert list(mv.legend_series_names) == ["planner"]
    assert names_of(view, mv.states_over_time_data_id) == ["Planner"]
    status = data_of(view, mv.statuses_over_time_data_id[0])
    assert status.name == "Planner (PASSED status)"
    assert status.index_id == view.data_by_name["T"].id
    gear = metric(view, "Gear state").raw.metric_values.states_over_time_metric_values
    assert list(gear.states_set) == ["1", "2", "3"]  # inferred, sorted
    assert list(gear.failure_states) == []
    assert list(gear.legend_series_names) == ["Gear"]


def test_states_over_time_per_category() -> None:
    idx = data.per_category("T", SeriesKind.TIMESTAMP, {"a": [1, 2], "b": [3]})
    states = data.per_category("S", SeriesKind.STRING, {"a": ["on", "off"], "b": ["on"]}, index=idx)
    w = MetricsWriter(JOB)
    w.states_over_time("S over time", states, failure_states=["off"])
    view = written(w)
    mv = metric(view, "S over time").raw.metric_values.states_over_time_metric_values
    assert list(mv.states_set) == ["off", "on"]
    status = data_of(view, mv.statuses_over_time_data_id[0])
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
    mv = m.raw.metric_values.histogram_metric_values
    assert [(b.lower, b.upper) for b in mv.buckets] == [
        (0.0, 0.5),
        (0.5, 1.0),
        (1.0, 1.5),
        (1.5, 2.0),
    ]
    assert (mv.lower_bound, mv.upper_bound) == (0.0, 2.0)
    assert mv.x_axis_name == "speed"
    assert data_of(view, mv.values_data_id).series().to_list() == [1.0, 7.5, 24.0]
    assert data_of(view, mv.statuses_data_id).name == "Speeds (PASSED status)"


def test_histogram_with_explicit_buckets_and_statuses() -> None:
    w = MetricsWriter(JOB)
    values = data.doubles("v", [1.0, 2.0])
    st_ = data.statuses("v st", [MetricStatus.PASSED, MetricStatus.FAIL_WARN])
    buckets = [(-1.0, 0.0), (0.0, 0.25), (0.25, 10.0)]
    w.histogram("h", values, buckets=buckets, lower=-1.0, upper=10.0, statuses=st_)
    w.histogram("h2", values, buckets=[(0, 1)])
    view = written(w)
    mv = metric(view, "h").raw.metric_values.histogram_metric_values
    assert [(b.lower, b.upper) for b in mv.buckets] == buckets
    assert (mv.lower_bound, mv.upper_bound) == (-1.0, 10.0)
    assert data_of(view, mv.statuses_data_id).name == "v st"
    h2 = metric(view, "h2").raw.metric_values.histogram_metric_values
    assert [(b.lower, b.upper) for b in h2.buckets] == [(0.0, 1.0)]
    assert h2.x_axis_name == ""


def test_histogram_buckets_helper_ends_exactly_at_upper() -> None:
    edges = histogram_buckets("h", 3, 0.0, 0.3)
    assert len(edges) == 3
    assert edges[0][0] == 0.0
    assert edges[-1][1] == 0.3
    assert all(a[1] == b[0] for a, b in itertools.pairwise(edges))


def test_equal_width_buckets_that_round_to_empty_are_refused() -> None:
    w = MetricsWriter(JOB)
    values = data.doubles("v", [1e16])
    try:
        w.histogram("h", values, buckets=8, lower=1e16, upper=1e16 + 4)
    except WriterError:
        return
    assert find_problems(w.to_proto()) == []


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
    mv = m.raw.metric_values.batchwise_bar_chart_metric_values
    assert mv.project_id.data == str(PROJECT)
    assert list(mv.categories) == ["PASSED", "FAILED"]
    assert list(mv.colors) == ["#2e7d32", "#C62828AA"]
    assert (mv.x_axis_name, mv.y_axis_name) == ("batch", "tests")
    assert mv.stack_bars is True
    assert names_of(view, mv.times_data_id) == ["Batch times", "Batch times"]
    assert names_of(view, mv.values_data_id) == ["Passed", "Failed"]
    assert names_of(view, mv.statuses_data_id) == ["Passed st", "Failed st"]
    bt = view.data_by_name["Batch times"]
    assert bt.index_id == view.data_by_name["Batches"].id
    assert bt.series().dt.epoch("ns").to_list() == [_ns(T0 - timedelta(days=d)) for d in (2, 1, 0)]
    minimal = metric(view, "Minimal").raw.metric_values.batchwise_bar_chart_metric_values
    assert list(minimal.colors) == []
    assert not minimal.HasField("stack_bars")
    assert names_of(view, minimal.statuses_data_id) == ["Passed (PASSED status)"]
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
    assert text.raw.metric_values.text_metric_values.text == "**bold**\nsecond line"
    plotly = metric(view, "Figure")
    assert plotly.type is MetricType.PLOTLY
    from google.protobuf.json_format import MessageToDict

    assert MessageToDict(plotly.raw.metric_values.plotly_metric_values.json) == {
        "data": [{"type": "scatter", "y": [1.0, 2.5]}],
        "layout": {"title": "t", "show": True, "n": None},
    }
    from_text = metric(view, "Figure text").raw.metric_values.plotly_metric_values.json
    assert MessageToDict(from_text) == {"data": [], "layout": {"height": 300.0}}
    image = metric(view, "Front camera")
    assert image.type is MetricType.IMAGE
    assert image.description == "front"
    assert (
        data_of(view, image.raw.metric_values.image_metric_values.image_data_id).external_path
        == "front.png"
    )
    lst = metric(view, "Frames")
    assert lst.type is MetricType.IMAGE_LIST
    assert names_of(view, lst.raw.metric_values.image_list_metric_values.image_data_ids) == [
        "Front",
        "Rear",
    ]
    assert [d.name for d in view.data] == ["Front", "Rear"]


# ---------------------------------------------------------------- events


def test_events_with_their_metrics_round_trip() -> None:
    w = MetricsWriter(JOB, deterministic=True)
    brake1 = w.scalar("Deceleration", 6.5, unit="m/s^2", event=True)
    brake2 = w.scalar("Deceleration", 7.0, unit="m/s^2", event=True, status=MetricStatus.FAIL_WARN)
    note = w.text("Why", "wet road", event=True)
    w.event(
        "Hard brake",
        timestamp=T0 + timedelta(seconds=21, microseconds=5),
        metrics=[brake1, note],
        status=MetricStatus.FAIL_WARN,
        importance=MetricImportance.HIGH,
        description="decel above 6",
        tags=["braking", "wet"],
    )
    w.event("Second brake", timestamp=T0_NS + 1, metrics=[brake2])
    w.event("Bare", timestamp=T0)
    view = written(w)
    assert [m.name for m in view.metrics] == ["Deceleration", "Deceleration", "Why"]
    assert all(m.event_metric for m in view.metrics)
    assert len({m.id for m in view.metrics}) == 3
    e1, e2, e3 = view.events
    assert e1.name == "Hard brake"
    assert e1.description == "decel above 6"
    assert e1.tags == ("braking", "wet")
    assert e1.metric_ids == (brake1.id, note.id)
    assert e1.status is MetricStatus.FAIL_WARN
    assert e1.importance is MetricImportance.HIGH
    assert e1.timestamp_ns == T0_NS + 21_000_005_000
    assert e1.timestamp_type == "absolute"
    assert e2.metric_ids == (brake2.id,)
    assert e2.status is MetricStatus.PASSED
    assert e2.importance is MetricImportance.MEDIUM
    assert e2.timestamp_ns == T0_NS + 1
    assert e3.metric_ids == ()
    assert e3.description == ""
    assert e3.tags == ()
    assert len({e.id for e in view.events}) == 3
    # Event metrics count towards the overall status.
    assert view.status is MetricStatus.FAIL_WARN


def test_relative_events() -> None:
    w = MetricsWriter(JOB)
    w.event("start", timestamp=0, relative=True)
    w.event("later", timestamp=1_500_000_000, relative=True)
    view = written(w)
    assert [(e.timestamp_type, e.timestamp_ns) for e in view.events] == [
        ("relative", 0),
        ("relative", 1_500_000_000),
    ]
    assert view.events[1].raw.timestamp_type == pb.RELATIVE_TIMESTAMP
    assert (view.events[1].raw.timestamp.seconds, view.events[1].raw.timestamp.nanos) == (
        1,
        500_000_000,
    )


def test_event_metrics_may_share_a_name_with_each_other_and_with_a_normal_metric() -> None:
    w = MetricsWriter(JOB)
    w.scalar("x", 1.0)
    e1 = w.scalar("x", 2.0, event=True)
    e2 = w.scalar("x", 3.0, event=True)
    w.event("e1", timestamp=1, metrics=[e1])
    w.event("e2", timestamp=2, metrics=[e2])
    view = written(w)
    assert [m.value for m in view.metrics] == [1.0, 2.0, 3.0]
    assert w.has_metric("x")
    with pytest.raises(WriterError, match=r"^a metric named 'x' was already written$"):
        w.scalar("x", 4.0)


# ---------------------------------------------------------------- data written transitively


def test_index_chains_are_written_transitively_once_index_first() -> None:
    root = data.timestamps("root", [1, 2])
    mid = data.uuids("mid", [uuid.UUID(int=1), uuid.UUID(int=2)], index=root)
    leaf = data.strings("leaf", ["a", "b"], index=mid)
    values = data.doubles("values", [1.0, 2.0], index=leaf)
    other = data.doubles("other", [3.0, 4.0], index=mid)
    w = MetricsWriter(JOB)
    w.histogram("h1", values, buckets=1, lower=0, upper=1)
    w.histogram("h2", other, buckets=1, lower=0, upper=1)
    w.double_summary("s", values, index=0)
    view = written(w)
    names = [d.name for d in view.data]
    assert names[:4] == ["root", "mid", "leaf", "values"]
    assert sorted(names) == sorted(
        [
            "root",
            "mid",
            "leaf",
            "values",
            "values (PASSED status)",
            "other",
            "other (PASSED status)",
        ]
    )
    by = view.data_by_name
    assert by["values"].index_id == by["leaf"].id
    assert by["leaf"].index_id == by["mid"].id
    assert by["mid"].index_id == by["root"].id
    assert by["other"].index_id == by["mid"].id
    assert by["values (PASSED status)"].index_id == by["leaf"].id
    assert [d.name for d in w.data] == names


def test_add_data_writes_data_that_no_metric_uses() -> None:
    idx = data.strings("labels", ["a"])
    alone = data.doubles("alone", [1.0], index=idx)
    w = MetricsWriter(JOB)
    w.add_data(alone)
    w.add_data(alone, idx)  # the same objects again: no change
    view = written(w)
    assert view.metrics == ()
    assert [d.name for d in view.data] == ["labels", "alone"]
    assert view.status is MetricStatus.PASSED


def test_two_different_data_with_one_name_are_refused() -> None:
    w = MetricsWriter(JOB)
    w.add_data(data.doubles("x", [1.0]))
    msg = r"^two different metrics data are named 'x'$"
    with pytest.raises(WriterError, match=msg):
        w.add_data(data.doubles("x", [1.0]))  # equal values, still another item
    with pytest.raises(WriterError, match=msg):
        w.add_data(data.doubles("y", [1.0], index=data.strings("x", ["a"])))
    with pytest.raises(WriterError, match=msg):
        w.histogram("h", data.doubles("x", [2.0]), buckets=1, lower=0, upper=1)


def test_a_failed_metric_call_leaves_the_writer_unchanged() -> None:
    w = MetricsWriter(JOB)
    w.add_data(data.doubles("v", [1.0]))
    with pytest.raises(WriterError):
        w.histogram("h", data.doubles("v", [2.0]), buckets=1, lower=0, upper=1)
    times = data.timestamps("t", [1])
    with pytest.raises(WriterError):
        w.double_over_time("d", data.doubles("dv", [1.0], index=times), legend=["a", "b"])
    assert not w.has_metric("h")
    assert not w.has_metric("d")
    assert w.metrics == []
    assert find_problems(w.to_proto()) == []


def test_duplicate_metric_names_are_refused_across_types() -> None:
    w = MetricsWriter(JOB)
    w.text("n", "t")
    with pytest.raises(WriterError, match=r"^a metric named 'n' was already written$"):
        w.scalar("n", 1.0)
    with pytest.raises(WriterError, match=r"^a metric named 'n' was already written$"):
        w.image("n", data.external_file("f", "f.png"))


# ---------------------------------------------------------------- overall status


@pytest.mark.parametrize(
    ("statuses", "expected"),
    [
        ([], MetricStatus.PASSED),
        ([MetricStatus.PASSED, MetricStatus.NOT_APPLICABLE, MetricStatus.RAW], MetricStatus.PASSED),
        ([MetricStatus.PASSED, MetricStatus.FAIL_WARN], MetricStatus.FAIL_WARN),
        (
            [MetricStatus.FAIL_WARN, MetricStatus.FAIL_BLOCK, MetricStatus.PASSED],
            MetricStatus.FAIL_BLOCK,
        ),
        ([MetricStatus.FAIL_BLOCK], MetricStatus.FAIL_BLOCK),
    ],
)
def test_overall_status_is_computed_from_the_metrics(
    statuses: list[MetricStatus], expected: MetricStatus
) -> None:
    w = MetricsWriter(JOB)
    for i, s in enumerate(statuses):
        w.text(f"m{i}", "x", status=s)
    assert w.status is expected
    view = written(w)
    assert view.status is expected
    assert view.raw.job_level_metrics.metrics_status == int(expected)


def test_status_follows_handle_changes_and_override_can_be_cleared() -> None:
    w = MetricsWriter(JOB)
    h = w.scalar("s", 1.0)
    before = w.status
    h.status(MetricStatus.FAIL_BLOCK)
    assert before is MetricStatus.PASSED
    assert w.status is MetricStatus.FAIL_BLOCK
    w.override_status(MetricStatus.PASSED)
    view = written(w)
    assert view.status is MetricStatus.PASSED
    assert view.raw.job_level_metrics.metrics_status == pb.PASSED_METRIC_STATUS
    assert metric(view, "s").status is MetricStatus.FAIL_BLOCK
    w.override_status(MetricStatus.NOT_APPLICABLE)
    assert written(w).status is MetricStatus.NOT_APPLICABLE
    w.override_status(None)
    assert w.status is MetricStatus.FAIL_BLOCK
    assert written(w).status is MetricStatus.FAIL_BLOCK


def test_handle_reports_name_type_and_id() -> None:
    w = MetricsWriter(JOB)
    h = w.histogram("h", data.doubles("v", [1.0]), buckets=2, lower=0, upper=1)
    view = written(w)
    assert (h.name, h.type) == ("h", MetricType.HISTOGRAM)
    assert metric(view, "h").id == h.id
    assert [m.name for m in w.metrics] == ["h"]


# ---------------------------------------------------------------- IDs


def _build(w: MetricsWriter) -> None:
    times = data.timestamps("T", [1, 2], id=uuid.UUID(int=77))
    speed = data.doubles("speed", [1.0, 2.0], index=times, id=uuid.UUID(int=78))
    w.double_over_time("dot", speed)
    w.scalar("s", 1.0)
    e = w.scalar("em", 2.0, event=True)
    e2 = w.scalar("em", 3.0, event=True)
    w.event("e", timestamp=5, metrics=[e])
    w.event("f", timestamp=6, metrics=[e2])
    w.add_data(data.strings("alone", ["x"]))


def _ids(view: JobMetricsView) -> set[uuid.UUID]:
    return {m.id for m in view.metrics} | {d.id for d in view.data} | {e.id for e in view.events}


def test_deterministic_ids_give_byte_identical_output() -> None:
    a = MetricsWriter(JOB, deterministic=True)
    b = MetricsWriter(str(JOB), deterministic=True)
    _build(a)
    _build(b)
    first = a.serialize()
    assert a.serialize() == first
    assert b.serialize() == first
    view = written(a)
    ids = _ids(view)
    # 4 metrics, 4 data (T, speed, its status series, alone), 2 events
    assert len(ids) == 4 + 4 + 2
    # IDs are derived from names, not taken from the data items.
    assert uuid.UUID(int=77) not in ids
    assert uuid.UUID(int=78) not in ids
    assert all(i.version == 5 for i in ids)


def test_deterministic_ids_differ_between_jobs() -> None:
    a = MetricsWriter(JOB, deterministic=True)
    b = MetricsWriter(OTHER_JOB, deterministic=True)
    _build(a)
    _build(b)
    assert a.serialize() != b.serialize()
    assert _ids(written(a)).isdisjoint(_ids(written(b)))


def test_random_ids_differ_between_writers_but_data_keeps_its_own_id() -> None:
    a = MetricsWriter(JOB)
    b = MetricsWriter(JOB)
    _build(a)
    _build(b)
    va, vb = written(a), written(b)
    assert {m.id for m in va.metrics}.isdisjoint({m.id for m in vb.metrics})
    assert {e.id for e in va.events}.isdisjoint({e.id for e in vb.events})
    assert all(i.version == 4 for i in {m.id for m in va.metrics})
    # Without determinism a data item's own id is used.
    assert va.data_by_name["T"].id == uuid.UUID(int=77)
    assert va.data_by_name["speed"].id == uuid.UUID(int=78)
    assert va.data_by_name["alone"].id != vb.data_by_name["alone"].id


def test_deterministic_ids_do_not_collide_for_names_with_a_hash_suffix() -> None:
    w = MetricsWriter(JOB, deterministic=True)
    a1 = w.scalar("a", 1.0, event=True)
    a2 = w.scalar("a", 2.0, event=True)
    w.scalar("a#2", 3.0)
    w.event("e1", timestamp=1, metrics=[a1])
    w.event("e2", timestamp=2, metrics=[a2])
    assert find_problems(w.to_proto()) == []


# ---------------------------------------------------------------- writer errors


def _err(match: str) -> AbstractContextManager[pytest.ExceptionInfo[WriterError]]:
    return pytest.raises(WriterError, match=re.escape(match))


def test_writer_refuses_a_job_id_that_is_not_a_uuid() -> None:
    with _err("job ID 'job-1' is not a UUID"):
        MetricsWriter("job-1")


def test_scalar_errors() -> None:
    w = MetricsWriter(JOB)
    with _err("metric 's': a scalar value cannot be NaN"):
        w.scalar("s", math.nan)
    with _err("a metric needs a non-empty name"):
        w.scalar("", 1.0)
    with _err("metric 's': a tag needs a non-empty key and value"):
        w.scalar("s", 1.0).tag("", "v")
    with _err("metric 't': a tag needs a non-empty key and value"):
        w.text("t", "x").tag("k", "")


def test_data_constructor_errors() -> None:
    with _err("metrics data needs a non-empty name"):
        data.doubles("", [1.0])
    with _err("metrics data needs a non-empty name"):
        data.external_file("", "a.png")
    with _err("metrics data 'f': an external file needs a path"):
        data.external_file("f", "")
    with _err("metrics data 'x': its shape 2 differs from its index 'i' shape 3"):
        data.doubles("x", [1.0, 2.0], index=data.strings("i", ["a", "b", "c"]))
    with _err("metrics data 'x': its shape {'a': 1} differs from its index 'i' shape {'a': 2}"):
        data.per_category(
            "x",
            SeriesKind.DOUBLE,
            {"a": [1.0]},
            index=data.per_category("i", SeriesKind.STRING, {"a": ["p", "q"]}),
        )
    with _err("metrics data 'x': its shape {'a': 1} differs from its index 'i' shape 1"):
        data.per_category("x", SeriesKind.DOUBLE, {"a": [1.0]}, index=data.strings("i", ["p"]))
    with _err("metrics data 'x': an external file cannot be an index"):
        data.doubles("x", [1.0], index=data.external_file("f", "f.png"))
    with _err("metrics data 'x': a per-category series needs a category"):
        data.per_category("x", SeriesKind.DOUBLE, {})
    with _err("metrics data 'x': an external file has no series"):
        data.per_category("x", SeriesKind.EXTERNAL_FILE, {"a": ["p.png"]})
    with _err("timestamp 2026-01-01T00:00:00 has no time zone; use an aware one"):
        data.timestamps("t", [datetime(2026, 1, 1)])
    with _err("timestamp 1.5 must be an aware datetime or integer nanoseconds"):
        data.timestamps("t", [1.5])  # type: ignore[list-item]
    with _err("timestamp True must be an aware datetime or integer nanoseconds"):
        data.timestamps("t", [True])
    with _err("'not-a-uuid' is not a UUID"):
        data.uuids("u", ["not-a-uuid"])
    with _err("12 is not a UUID"):
        data.uuids("u", [12])  # type: ignore[list-item]


def test_statuses_refuse_unknown_values_with_writer_error() -> None:
    with pytest.raises(WriterError, match="statuses"):
        data.statuses("s", [99])  # type: ignore[list-item]


def test_wrong_data_kinds_are_refused() -> None:
    w = MetricsWriter(JOB)
    strings = data.strings("s", ["a"])
    plain = data.doubles("d", [1.0])
    by_str = data.doubles("ds", [1.0], index=data.strings("l", ["a"]))
    by_ts = data.doubles("dt", [1.0], index=data.timestamps("t", [1]))
    with _err("metric 'x': data 's' holds string values, double needed"):
        w.double_summary("x", strings)
    with _err("metric 'x': data 'd' must be indexed by a timestamp series"):
        w.double_over_time("x", plain)
    with _err("metric 'x': data 'ds' must be indexed by a timestamp series"):
        w.double_over_time("x", by_str)
    with _err("metric 'x': data 'dt' must be indexed by a string series"):
        w.bar_chart("x", by_ts)
    with _err("metric 'x': data 's' must be indexed by a timestamp series"):
        w.states_over_time("x", strings)
    with _err("metric 'x': data 'd' holds double values, string needed"):
        w.states_over_time("x", plain)
    with _err("metric 'x': data 's' holds string values, double needed"):
        w.histogram("x", strings, buckets=1, lower=0, upper=1)
    with _err("metric 'x': data 's' holds string values, double needed"):
        w.line_plot("x", strings, plain)
    with _err("metric 'x': data 'd' holds double values, external_file needed"):
        w.image("x", plain)
    with _err("metric 'x': data 'd' holds double values, external_file needed"):
        w.image_list("x", [data.external_file("f", "f.png"), plain])
    with _err("metric 'x': index 'a' needs values indexed by timestamps, UUIDs or strings"):
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
    with _err("metric 'x': give as many x series as y series (at least 1)"):
        w.line_plot("x", [a, b], [a])
    with _err("metric 'x': give as many x series as y series (at least 1)"):
        w.line_plot("x", [], [])
    with _err("metric 'x': x series 'a' and y series 'b' differ in shape or index"):
        w.line_plot("x", a, b)
    with _err("metric 'x': x series 'a' and y series 'x3' differ in shape or index"):
        w.line_plot("x", a, x3)
    with _err("metric 'x': give one status series per value series"):
        w.double_over_time("x", [a, b], statuses=[data.status_like(a, MetricStatus.PASSED)])
    with _err("metric 'x': status series 'st' must have the shape and index of 'a'"):
        w.double_over_time("x", a, statuses=[data.statuses("st", [MetricStatus.PASSED] * 2)])
    with _err("metric 'x': status series 'st' must have the shape and index of 'a'"):
        w.double_over_time(
            "x", a, statuses=[data.statuses("st", [MetricStatus.PASSED] * 2, index=t2)]
        )
    with _err("metric 'x': give one failure definition per series"):
        w.double_over_time("x", [a, b], failures=[(1.0, None)])
    with _err("metric 'x': data 'st' holds string values, status needed"):
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
        with _err("metric 'x': give one legend name per series"):
            case(MetricsWriter(JOB))


def test_states_errors() -> None:
    w = MetricsWriter(JOB)
    states = data.strings("s", ["go", "halt", "zz"], index=data.timestamps("t", [1, 2, 3]))
    with _err("metric 'x': states ['halt', 'zz'] are not in the states set"):
        w.states_over_time("x", states, states_set=["go"])
    with _err("metric 'y': failure states must be in the states set"):
        w.states_over_time("y", states, failure_states=["crash"])


@pytest.mark.parametrize(
    ("buckets", "lower", "upper", "message"),
    [
        (4, 1.0, 1.0, "metric 'h': 4 buckets need lower < upper and a count of at least 1"),
        (4, 2.0, 1.0, "metric 'h': 4 buckets need lower < upper and a count of at least 1"),
        (0, 0.0, 1.0, "metric 'h': 0 buckets need lower < upper and a count of at least 1"),
        (4, None, 1.0, "metric 'h': 4 buckets need lower < upper and a count of at least 1"),
        (4, 0.0, None, "metric 'h': 4 buckets need lower < upper and a count of at least 1"),
        ([], None, None, "metric 'h': a histogram needs at least one bucket"),
        ([(1.0, 1.0)], None, None, "metric 'h': bucket 0 has lower 1.0 >= upper 1.0"),
        ([(0.0, 1.0), (2.0, 1.5)], None, None, "metric 'h': bucket 1 has lower 2.0 >= upper 1.5"),
        ([(0.0, math.nan)], None, None, "metric 'h': bucket 0 has lower 0.0 >= upper nan"),
        (
            [(0.0, 1.0), (1.5, 2.0)],
            None,
            None,
            "metric 'h': bucket 1 starts at 1.5 but bucket 0 ends at 1.0",
        ),
        ([(0.0, 1.0)], -1.0, None, "metric 'h': lower/upper must match the first and last bucket"),
        ([(0.0, 1.0)], None, 2.0, "metric 'h': lower/upper must match the first and last bucket"),
    ],
)
def test_bucket_errors(
    buckets: object, lower: float | None, upper: float | None, message: str
) -> None:
    w = MetricsWriter(JOB)
    with _err(message):
        w.histogram("h", data.doubles("v", [1.0]), buckets=buckets, lower=lower, upper=upper)  # type: ignore[arg-type]


def test_batchwise_errors() -> None:
    batches = data.uuids("b", [uuid.UUID(int=1)])
    other = data.uuids("b2", [uuid.UUID(int=1)])
    times = data.timestamps("t", [1], index=batches)
    values = data.doubles("v", [1.0], index=batches)
    w = MetricsWriter(JOB)
    with _err("metric 'x': give one times and one values series per category"):
        w.batchwise_bar_chart(
            "x", project_id=PROJECT, times=times, values=values, categories=["a", "b"]
        )
    with _err("metric 'x': 't' and 'v2' need one index"):
        w.batchwise_bar_chart(
            "x",
            project_id=PROJECT,
            times=times,
            values=data.doubles("v2", [1.0], index=other),
            categories=["a"],
        )
    with _err("metric 'x': data 'v' holds double values, timestamp needed"):
        w.batchwise_bar_chart(
            "x", project_id=PROJECT, times=values, values=values, categories=["a"]
        )
    with _err("metric 'x': data 'plain' must be indexed by a uuid series"):
        w.batchwise_bar_chart(
            "x",
            project_id=PROJECT,
            times=times,
            values=data.doubles("plain", [1.0]),
            categories=["a"],
        )
    for colour in ["red", "#12345", "#1234567", "#GGGGGG", "", "2e7d32", "#aabbcc\n"]:
        with _err(f"metric 'x': colour {colour!r} is not #RRGGBB or #RRGGBBAA"):
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
    with _err("metric 't': text cannot be empty"):
        w.text("t", "")
    with pytest.raises(WriterError, match=r"^metric 'p': plotly figure is not JSON \("):
        w.plotly("p", "{not json")
    with pytest.raises(WriterError, match=r"^metric 'p': plotly figure is not JSON \("):
        w.plotly("p", 42)  # type: ignore[arg-type]
    with _err("metric 'i': an image list needs at least one image"):
        w.image_list("i", [])
    assert w.metrics == []


def test_plotly_refuses_json_that_is_not_an_object_with_writer_error() -> None:
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError, match="plotly"):
        w.plotly("p", "[1, 2]")


def test_event_errors() -> None:
    w = MetricsWriter(JOB)
    plain = w.scalar("plain", 1.0)
    m1 = w.scalar("m", 1.0, event=True)
    m2 = w.scalar("m", 2.0, event=True)
    with _err("event names must be non-empty and unique: ''"):
        w.event("", timestamp=1)
    w.event("e", timestamp=1)
    with _err("event names must be non-empty and unique: 'e'"):
        w.event("e", timestamp=2)
    with _err("event 'r': all events must be all absolute or all relative"):
        w.event("r", timestamp=2, relative=True)
    with _err("event 'f': metric 'plain' was not written with event=True"):
        w.event("f", timestamp=2, metrics=[plain])
    with _err("event 'f': its metrics need unique names"):
        w.event("f", timestamp=2, metrics=[m1, m2])
    with _err("timestamp 2026-01-01T00:00:00 has no time zone; use an aware one"):
        w.event("f", timestamp=datetime(2026, 1, 1))
    assert [e.name for e in written(w).events] == ["e"]
    r = MetricsWriter(JOB)
    r.event("r", timestamp=1, relative=True)
    with _err("event 'a': all events must be all absolute or all relative"):
        r.event("a", timestamp=2)


def test_double_over_time_refuses_a_naive_start_time() -> None:
    w = MetricsWriter(JOB)
    values = data.doubles("v", [1.0], index=data.timestamps("t", [1]))
    with _err("timestamp 2026-01-01T00:00:00 has no time zone; use an aware one"):
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


def test_empty_series_are_refused_when_written() -> None:
    # Building one is harmless (an aggregation may fill it later); writing one is not.
    empty = data.doubles("x", [])
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError, match="metrics data 'x' is empty"):
        w.add_data(empty)
    with pytest.raises(WriterError, match="metrics data 'x' is empty"):
        w.histogram("h", empty, buckets=2, lower=0, upper=1)
    with pytest.raises(WriterError, match="metrics data 'pc' is empty"):
        w.add_data(data.per_category("pc", SeriesKind.DOUBLE, {"a": [1.0], "b": []}))
    assert w.to_proto().metrics_data == []
    assert not w.has_metric("h")


def test_event_timestamp_before_the_epoch_is_refused() -> None:
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError):
        w.event("e", timestamp=-5)


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
