"""Protobuf encoding of the writer's values: IDs, timestamps, failure definitions, series.

It owns how SDK values become schema messages, and nothing about which metric needs
which message: `data_to_proto` turns one `MetricsData` into its ``MetricsData``
message, with IDs as the writer assigned them, and the small helpers below build the
submessages the metric methods fill in. Everything here is deterministic, so that
equal inputs give equal bytes.
"""

from __future__ import annotations

import uuid
from array import array
from collections.abc import Mapping, Sequence
from typing import Any

from google.protobuf import timestamp_pb2

from stook.proto import metrics_pb2 as pb
from stook.proto import uuid_pb2
from stook.sdk._data import MetricsData
from stook.sdk._enums import SERIES_FIELD, SeriesKind, data_type_of


def uuid_proto(value: uuid.UUID) -> uuid_pb2.UUID:
    return uuid_pb2.UUID(data=str(value))


def timestamp_proto(ns: int) -> timestamp_pb2.Timestamp:
    seconds, nanos = divmod(ns, 1_000_000_000)
    return timestamp_pb2.Timestamp(seconds=seconds, nanos=nanos)


def failure_proto(above: float | None, below: float | None) -> pb.DoubleFailureDefinition:
    f = pb.DoubleFailureDefinition()
    if above is not None:
        f.fails_above = above
    if below is not None:
        f.fails_below = below
    return f


def data_to_proto(data: MetricsData, ids: Mapping[str, uuid.UUID]) -> pb.MetricsData:
    """The proto of one metrics-data item, with IDs as the writer assigned them."""
    msg = pb.MetricsData(
        metrics_data_id=pb.MetricsDataId(id=uuid_proto(ids[data.name])),
        data_type=data_type_of(data.kind, indexed=data.indexed),
        name=data.name,
        unit=data.unit,
    )
    if data.kind is SeriesKind.EXTERNAL_FILE:
        msg.external_file.path = data.external_path or ""
        return msg
    if data.index is not None:
        msg.is_indexed = True
        msg.index_data_id.CopyFrom(pb.MetricsDataId(id=uuid_proto(ids[data.index.name])))
        msg.index_data_type = data_type_of(data.index.kind, indexed=data.index.indexed)
    if isinstance(data.values, dict):
        msg.is_per_category = True
        msg.category_names.extend(data.values)
        for category, values in data.values.items():
            _fill_series(msg.series_per_category.category_to_series[category], data.kind, values)
    else:
        _fill_series(msg.series, data.kind, data.values or [])
    return msg


def _fill_series(series: pb.Series, kind: SeriesKind, values: Sequence[Any]) -> None:
    field = SERIES_FIELD[kind]
    target = getattr(series, field)
    target.SetInParent()
    match kind:
        case SeriesKind.DOUBLE if isinstance(values, array):
            # Parsing the packed wire form is a memcpy in C; extend() would box every value.
            raw = values.tobytes()
            target.MergeFromString(b"\x0a" + _varint(len(raw)) + raw)
        case SeriesKind.STATUS if (packed := _status_bytes(values)) is not None:
            # The same, each status's varint being one byte: extend() converted each
            # value (a status series stands beside every value series the writer makes).
            target.MergeFromString(b"\x0a" + _varint(len(packed)) + packed)
        case SeriesKind.TIMESTAMP:
            target.series.extend(timestamp_proto(v) for v in values)
        case SeriesKind.UUID:
            target.series.extend(uuid_pb2.UUID(data=v) for v in values)
        case _:
            target.series.extend(values)


def _status_bytes(values: Sequence[Any]) -> bytes | None:
    """The packed wire form of statuses that are all below 128 (every `MetricStatus`
    is), whose varints are then their own bytes; None for any other values.

    A list or tuple only (what the SDK's constructors make): `bytes` of anything with a
    buffer (an array, a numpy array) is its memory, not its values."""
    if type(values) is not list and type(values) is not tuple:
        return None
    try:
        raw = bytes(values)
    except (TypeError, ValueError):
        return None
    return raw if raw and raw.isascii() else None


def _varint(n: int) -> bytes:
    out = bytearray()
    while n > 0x7F:
        out.append((n & 0x7F) | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)
