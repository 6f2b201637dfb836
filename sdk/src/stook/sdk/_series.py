"""Schema series to polars: the dtypes of frames and the conversion of one series.

It owns how the elements of a ``Series`` message become a typed polars Series
(doubles bit for bit, timestamps as UTC nanoseconds, UUIDs in canonical text,
statuses as `STATUS_DTYPE`) and the long (category, position, value) frame the views
build on. A value that cannot be converted raises `MalformedError`; the views turn it
into a `ReadError` that names the data.
"""

from __future__ import annotations

import uuid
from typing import Any

import numpy as np
import polars as pl

from stook.proto import metrics_pb2 as pb
from stook.sdk._enums import NANOS_PER_SECOND, MetricStatus, SeriesKind
from stook.sdk._errors import MalformedError

STATUS_DTYPE = pl.Enum([s.name for s in MetricStatus])
"""dtype of status values in frames; ``NO_METRIC_STATUS`` (unset) and a status this
schema does not know read as null."""

SERIES_KINDS = tuple(k for k in SeriesKind if k is not SeriesKind.EXTERNAL_FILE)
KIND_DTYPE = pl.Enum([k.value for k in SERIES_KINDS])
"""dtype of the ``kind`` column of `JobMetricsView.series_frame`."""

VALUE_DTYPES: dict[SeriesKind, pl.DataType] = {
    SeriesKind.DOUBLE: pl.Float64(),
    SeriesKind.TIMESTAMP: pl.Datetime("ns", "UTC"),
    SeriesKind.UUID: pl.String(),
    SeriesKind.STRING: pl.String(),
    SeriesKind.STATUS: STATUS_DTYPE,
}

_STATUS_NAMES: dict[int, str] = {s.value: s.name for s in MetricStatus}


def long_frame(category: str | None, values: pl.Series) -> pl.DataFrame:
    n = len(values)
    return pl.DataFrame(
        {
            "category": pl.Series([category], dtype=pl.String).extend_constant(category, n - 1)
            if n
            else pl.Series([], dtype=pl.String),
            "position": pl.int_range(0, n, dtype=pl.UInt32, eager=True),
            "value": values.rename("value"),
        }
    )


def to_polars(series: pb.Series, kind: SeriesKind, name: str) -> pl.Series:
    if kind is SeriesKind.DOUBLE:
        return _doubles(series.doubles, name)
    if kind is SeriesKind.TIMESTAMP:
        return _timestamps(series.timestamps, name)
    if kind is SeriesKind.UUID:
        return pl.Series(name, [_canonical_uuid(u.data) for u in series.uuids.series], pl.String)
    if kind is SeriesKind.STRING:
        return pl.Series(name, series.strings.series, dtype=pl.String)
    statuses = pl.Series(name, series.statuses.series, dtype=pl.Int32)
    return statuses.replace_strict(_STATUS_NAMES, default=None, return_dtype=STATUS_DTYPE)


def _doubles(doubles: pb.DoubleSeries, name: str) -> pl.Series:
    return pl.Series(name, doubles_array(doubles))


def doubles_array(doubles: pb.DoubleSeries) -> np.ndarray[Any, np.dtype[np.float64]]:
    """The doubles as a read-only float64 array, bit for bit, without building polars
    objects (for aggregations that reduce the values with numpy)."""
    values = np.array(doubles.series, dtype=np.float64)
    values.flags.writeable = False
    return values


def _timestamps(timestamps: pb.TimestampSeries, name: str) -> pl.Series:
    nanos = [t.seconds * NANOS_PER_SECOND + t.nanos for t in timestamps.series]
    try:
        ints = pl.Series(name, nanos, dtype=pl.Int64)
    except (OverflowError, TypeError, pl.exceptions.PolarsError) as exc:
        raise MalformedError("a timestamp is too far from 1970 to hold in nanoseconds") from exc
    return ints.cast(pl.Datetime("ns", "UTC"))


def _canonical_uuid(text: str) -> str:
    try:
        return str(uuid.UUID(hex=text))
    except ValueError:
        raise MalformedError(f"series element {text!r} is not a UUID") from None
