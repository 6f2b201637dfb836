"""Protobuf encoding of the writer's values: IDs, timestamps, failure definitions, series.

It owns how SDK values become schema messages, and nothing about which metric needs
which message: `data_to_proto` turns one `MetricsData` into its ``MetricsData``
message, with IDs as the writer assigned them, and the small helpers below build the
submessages the metric methods fill in. Everything here is deterministic, so that
equal inputs give equal bytes.
"""

from __future__ import annotations

import uuid
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
    target = getattr(series, SERIES_FIELD[kind])
    target.SetInParent()
    match kind:
        case SeriesKind.TIMESTAMP:
            target.series.extend(timestamp_proto(v) for v in values)
        case SeriesKind.UUID:
            target.series.extend(uuid_pb2.UUID(data=v) for v in values)
        case _:
            target.series.extend(values)
