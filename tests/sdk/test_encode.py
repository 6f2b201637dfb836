"""Metrics data through the encoder: every kind, index and layout, read back exactly."""

from __future__ import annotations

import math
import struct
import uuid
from array import array
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import polars as pl
import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricStatus, MetricsWriter, SeriesKind, data, read_job_metrics
from stook.sdk.dtypes import STATUS_DTYPE
from tests.sdk.support import JOB, T0, T0_NS, float_bits, resim_accepts, statuses_of, written

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


# ---------------------------------------------------------------- status series' fast path


@pytest.mark.parametrize(
    "values",
    [
        [MetricStatus.PASSED] * 300,  # what the writer makes beside a value series
        [MetricStatus.PASSED, MetricStatus.FAIL_BLOCK, MetricStatus.RAW, MetricStatus.FAIL_WARN],
        [],
        [200, 3, 1],  # a two-byte varint: the element path
        (MetricStatus.PASSED, MetricStatus.NOT_APPLICABLE),
        # A buffer's bytes are its memory, not its values: the element path.
        array("q", [MetricStatus.PASSED, MetricStatus.FAIL_BLOCK]),
        np.array([MetricStatus.PASSED, MetricStatus.FAIL_WARN], dtype=np.int64),
    ],
)
def test_a_status_series_is_encoded_as_extend_would(values: Sequence[int]) -> None:
    from stook.sdk._output import _fill_series

    fast = pb.Series()
    _fill_series(fast, SeriesKind.STATUS, values)
    slow = pb.Series()
    slow.statuses.SetInParent()
    slow.statuses.series.extend(values)  # type: ignore[arg-type]
    assert list(fast.statuses.series) == list(values)
    assert fast.SerializeToString(deterministic=True) == slow.SerializeToString(deterministic=True)


def test_statuses_that_are_no_numbers_still_reach_extend_and_its_error() -> None:
    from stook.sdk._output import _fill_series

    with pytest.raises(ValueError, match="unknown enum label"):
        _fill_series(pb.Series(), SeriesKind.STATUS, ["not a status"])
