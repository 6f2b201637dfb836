"""Series to polars: each kind's dtype, doubles bit for bit on both paths, bad values."""

from __future__ import annotations

import math
import struct
import uuid
from datetime import UTC, datetime

import polars as pl
import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    JobMetricsView,
    ReadError,
    SeriesKind,
    parse_metrics_data,
    read_metrics_data,
)
from stook.sdk._series import doubles_array
from stook.sdk.dtypes import STATUS_DTYPE
from tests.sdk.support import bare_data

# ---------------------------------------------------------------- a ReSim-written output


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


# ---------------------------------------------------------------- hand-made messages


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
    for d in (bare_data(data_type), bare_data(data_type, is_per_category=True)):
        if not d.is_per_category:
            d.series.SetInParent()
        view = parse_metrics_data(d)
        if not view.per_category:
            assert view.series().dtype == dtype
            assert len(view.series()) == 0
        frame = view.frame()
        assert frame.is_empty()
        assert frame["value"].dtype == dtype


@pytest.mark.parametrize("copies", [1, 100])  # below and above the packed-bytes path
def test_special_doubles_keep_their_bits_on_both_paths(copies: int) -> None:
    values = [0.0, -0.0, math.inf, -math.inf, 5e-324, 1.7976931348623157e308, math.nan] * copies
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(values)
    got = read_metrics_data(d.SerializeToString()).series()
    assert got.dtype == pl.Float64
    assert got.name == d.name
    assert [struct.pack("<d", v) for v in got] == [struct.pack("<d", v) for v in values]


@pytest.mark.parametrize("length", [1, 63, 64, 65, 300, 4096, 70_000])
def test_double_series_of_any_length_match_the_proto(length: int) -> None:
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(float(i) * 0.1 - 7.0 for i in range(length))
    got = read_metrics_data(d.SerializeToString()).series()
    assert got.equals(pl.Series(d.name, list(d.series.doubles.series), dtype=pl.Float64))


def test_unknown_fields_in_a_long_series_fall_back_to_copying() -> None:
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(float(i) for i in range(1000))
    d.series.doubles.MergeFromString(b"\x10\x07")
    assert read_metrics_data(d.SerializeToString()).series().to_list() == [
        float(i) for i in range(1000)
    ]


def test_large_double_series_matches_the_proto() -> None:
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(float(i) * 0.1 for i in range(200_000))
    got = read_metrics_data(d.SerializeToString()).series()
    assert got.equals(pl.Series("d", list(d.series.doubles.series), dtype=pl.Float64))


def test_unknown_fields_inside_a_series_do_not_break_doubles() -> None:
    # Nested unknown fields are kept; the fast path then falls back to copying.
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend([1.0, 2.0])
    d.series.doubles.MergeFromString(b"\x10\x07")  # field 2, varint 7: not in DoubleSeries
    view = read_metrics_data(d.SerializeToString())
    assert view.series().to_list() == [1.0, 2.0]
    assert view.raw.SerializeToString(deterministic=True) == d.SerializeToString(deterministic=True)


def test_status_zero_is_null() -> None:
    d = bare_data(pb.METRIC_STATUS_SERIES_DATA_TYPE)
    d.series.statuses.series.extend(pb.MetricStatus.ValueType(v) for v in (0, 5, 3, 4))
    assert parse_metrics_data(d).series().to_list() == [None, "FAIL_BLOCK", "NOT_APPLICABLE", "RAW"]


def test_uuids_are_canonicalised() -> None:
    d = bare_data(pb.UUID_SERIES_DATA_TYPE)
    u = uuid.UUID(int=0xABCDEF)
    for text in (str(u).upper(), u.hex, "{" + str(u) + "}", u.urn):
        d.series.uuids.series.add().data = text
    assert set(parse_metrics_data(d).series().to_list()) == {str(u)}


def test_bad_uuid_in_a_series_is_a_read_error_on_conversion() -> None:
    d = bare_data(pb.UUID_SERIES_DATA_TYPE)
    d.series.uuids.series.add().data = "nope"
    view = read_metrics_data(d.SerializeToString(), source="ids.bin")
    with pytest.raises(ReadError, match=r"could not read MetricsData from 'ids.bin'.*'nope'"):
        view.series()


def test_timestamp_out_of_range_is_a_read_error_on_conversion() -> None:
    d = bare_data(pb.TIMESTAMP_SERIES_DATA_TYPE)
    d.series.timestamps.series.add().seconds = 2**62
    with pytest.raises(ReadError, match="too far"):
        parse_metrics_data(d).frame()


@pytest.mark.parametrize("length", [1, 63, 64, 65, 300, 70_000])
def test_doubles_array_matches_the_series_bit_for_bit(length: int) -> None:
    special = [0.0, -0.0, math.inf, -math.inf, 5e-324, math.nan]
    values = [special[i % len(special)] if i % 7 == 0 else i * 0.1 - 7.0 for i in range(length)]
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.extend(values)
    view = read_metrics_data(d.SerializeToString())
    got = doubles_array(view.raw.series.doubles)
    assert got.dtype == "float64"
    assert got.tobytes() == struct.pack(f"<{length}d", *values)
    assert got.tobytes() == view.series().to_numpy().tobytes()
