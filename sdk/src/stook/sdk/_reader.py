"""Read metrics.binproto bytes into typed, immutable views and polars frames.

This module owns the entry points and the decoding: parsing the bytes, deciding what
is readable, and building the views (`_views`) from the messages; converting series
to polars is `_series`'s.

What counts as readable:

* The bytes must parse as the claimed message (protobuf consumes all of them or
  fails), and must not be empty: protobuf reads ``b""`` as a default message, but
  no writer emits an empty output, so empty bytes mean a failed or truncated write.
* The top level of the message must hold no fields the schema does not know.
  Bytes of another message type almost always do (a field number the claimed type
  lacks, or a wire type that does not fit), so they are refused. Unknown fields
  deeper down are kept (``raw`` re-serializes them) because a newer ReSim schema
  may add fields to nested messages.
* Every ID the views expose as a ``uuid.UUID`` must parse (as ``uuid.UUID(hex=...)``,
  the platform's rule).
* A series must hold the element type its data type declares.

Enum values this schema does not know (ones a newer ReSim schema adds) are read, not
refused, as ReSim's validator accepts them: a view keeps such a status, type or
importance as its number (an ``int`` where the enum member would be), metrics data of
an unknown data type has ``kind`` None and no series, and an unknown status in a
status series reads as null in frames. ``raw`` keeps every value as it was.

Anything else is left to the validator (`stook.sdk._validate`): the reader reads
what is there, including outputs the platform would refuse.

Views keep the message they were read from as ``raw``; do not mutate it.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable, Iterable, Mapping
from types import MappingProxyType
from typing import Final, Literal, TypeVar

from google.protobuf.message import Error as ProtobufError
from google.protobuf.message import Message
from google.protobuf.unknown_fields import UnknownFieldSet

from stook.proto import metrics_pb2 as pb
from stook.sdk._enums import (
    NANOS_PER_SECOND,
    MetricImportance,
    MetricStatus,
    MetricType,
    SeriesKind,
    kind_of,
)
from stook.sdk._errors import MalformedError, read_error
from stook.sdk._views import EventView, JobMetricsView, MetricsDataView, MetricView

# The views are listed with the entry points that hand them out, so that
# code importing them from here keeps working; the public home is `stook.sdk`.
__all__ = [
    "EventView",
    "JobMetricsView",
    "MetricView",
    "MetricsDataView",
    "parse_job_metrics",
    "parse_metric",
    "parse_metrics_data",
    "read_job_metrics",
    "read_metric",
    "read_metrics_data",
]

_Msg = TypeVar("_Msg", bound=Message)
_METRICS_DATA: Final = pb.MetricsData
_E = TypeVar("_E", MetricStatus, MetricImportance, MetricType)
_V = TypeVar("_V")


# ---------------------------------------------------------------- entry points


def read_job_metrics(data: bytes, *, source: str = "<bytes>") -> JobMetricsView:
    """Read a whole output (the bytes of a metrics.binproto file)."""
    return _view(pb.JobMetrics, _parse(pb.JobMetrics, data, source), source, _job_view)


def read_metric(data: bytes, *, source: str = "<bytes>") -> MetricView:
    """Read the bytes of one ``Metric`` message."""
    return _view(pb.Metric, _parse(pb.Metric, data, source), source, _metric_view)


def read_metrics_data(data: bytes, *, source: str = "<bytes>") -> MetricsDataView:
    """Read the bytes of one ``MetricsData`` message."""
    # `_view` written out: every downloaded series is read here.
    msg = _parse(_METRICS_DATA, data, source)
    try:
        return _data_view(msg, source)
    except MalformedError as exc:
        raise read_error(_METRICS_DATA, source, str(exc)) from None


def parse_job_metrics(msg: pb.JobMetrics, *, source: str = "<message>") -> JobMetricsView:
    """View an already-parsed JobMetrics; the view keeps its own copy of ``msg``."""
    return _view(pb.JobMetrics, _copy(msg), source, _job_view)


def parse_metric(msg: pb.Metric, *, source: str = "<message>") -> MetricView:
    """View an already-parsed Metric; the view keeps its own copy of ``msg``."""
    return _view(pb.Metric, _copy(msg), source, _metric_view)


def parse_metrics_data(msg: pb.MetricsData, *, source: str = "<message>") -> MetricsDataView:
    """View an already-parsed MetricsData; the view keeps its own copy of ``msg``."""
    return _view(pb.MetricsData, _copy(msg), source, _data_view)


def _copy(msg: _Msg) -> _Msg:
    # A copy, so that later changes to the caller's message cannot show through
    # the frozen view.
    new = type(msg)()
    new.CopyFrom(msg)
    return new


def _parse(cls: type[_Msg], data: bytes, source: str) -> _Msg:
    if len(data) == 0:
        raise read_error(cls, source, "no bytes (an empty file is a failed or truncated write)")
    try:
        msg = cls.FromString(data)
    except ProtobufError as exc:
        detail = str(exc).rpartition(": ")[2].lower() or "parse failed"
        raise read_error(cls, source, f"not a valid protobuf message ({detail})") from exc
    fields = UnknownFieldSet(msg)
    if len(fields):  # almost never: checked first, as every downloaded blob passes here
        unknown = sorted({fields[i].field_number for i in range(len(fields))})
        numbers = ", ".join(map(str, unknown))
        raise read_error(
            cls,
            source,
            f"field number(s) {numbers} do not fit {cls.DESCRIPTOR.name}; "
            "these bytes are probably a different message",
        )
    return msg


def _view(cls: type[_Msg], msg: _Msg, source: str, build: Callable[[_Msg, str], _V]) -> _V:
    try:
        return build(msg, source)
    except MalformedError as exc:
        raise read_error(cls, source, str(exc)) from None


# ---------------------------------------------------------------- building views


def _uuid(text: str, what: str) -> uuid.UUID:
    if not text:
        raise MalformedError(f"{what} is missing")
    try:
        return uuid.UUID(text)
    except ValueError:
        raise MalformedError(f"{what} {text!r} is not a UUID") from None


def _optional_uuid(text: str, what: str) -> uuid.UUID | None:
    return _uuid(text, what) if text else None


def _enum(cls: type[_E], value: int) -> _E | int | None:
    """The member for `value`; None when unset, the number itself when unknown."""
    if value == 0:
        return None
    try:
        return cls(value)
    except ValueError:
        return value


def _kind(data_type: int) -> SeriesKind | None:
    """The series kind of a data type; None for one this schema does not know (or unset,
    which the caller checks first where it is an error)."""
    try:
        return kind_of(data_type)[0]
    except ValueError:
        return None


def _label(kind: str, name: str) -> str:
    return f"{kind} {name!r}" if name else f"{kind} (unnamed)"


def _data_label(msg: pb.MetricsData) -> str:
    # Made only for an error: every downloaded series is read here.
    return _label("data", msg.name)


def _data_uuid(msg: pb.MetricsData, text: str, what: str) -> uuid.UUID:
    """`_uuid` of one of `msg`'s IDs, its label made only when it is no UUID."""
    try:
        return uuid.UUID(text)
    except ValueError:
        return _uuid(text, f"{_data_label(msg)}: {what}")


def _data_view(msg: pb.MetricsData, source: str) -> MetricsDataView:
    data_type = msg.data_type
    if data_type == _NO_DATA_TYPE:
        raise MalformedError(f"{_data_label(msg)}: data type is unset")
    kind, elements = _KNOWN_TYPES.get(data_type) or _type_of(data_type)
    holds = msg.WhichOneof("data")
    per_category = msg.is_per_category
    if kind is _EXTERNAL_FILE:
        if holds not in (None, "external_file"):
            raise MalformedError(
                f"{_data_label(msg)} is declared an external file but holds a {holds}"
            )
    elif kind is not None:  # of an unknown data type, nothing says what its series hold
        expected = "series_per_category" if per_category else "series"
        if holds not in (None, expected):
            declared = f"is_per_category is {per_category}"
            raise MalformedError(f"{_data_label(msg)}: {declared} but it holds {holds}")
        # `series` and `series_per_category` are one oneof: only the one set holds series.
        if holds == "series":
            # `_check_series` of the common case, its call made only to word the error.
            within = msg.series.WhichOneof("series")
            if within is not None and within != elements:
                _check_series(msg.series, elements, kind, msg)
        elif holds == "series_per_category":
            for series in msg.series_per_category.category_to_series.values():
                _check_series(series, elements, kind, msg)
    # Asked first: most data has no index, and reading an absent ID's text makes two
    # message objects.
    index_text = msg.index_data_id.id.data if msg.HasField("index_data_id") else ""
    index_type = msg.index_data_type
    names = msg.category_names
    return MetricsDataView(
        id=_data_uuid(msg, msg.metrics_data_id.id.data, "id"),
        name=msg.name,
        unit=msg.unit,
        kind=kind,
        indexed=msg.is_indexed,
        index_id=_data_uuid(msg, index_text, "index id") if index_text else None,
        index_kind=_kind(index_type) if index_type != _NO_DATA_TYPE else None,
        per_category=per_category,
        categories=tuple(names) if names else (),
        external_path=msg.external_file.path if holds == "external_file" else None,
        raw=msg,
        source=source,
    )


_ELEMENT_FIELDS: dict[SeriesKind, str] = {
    SeriesKind.DOUBLE: "doubles",
    SeriesKind.TIMESTAMP: "timestamps",
    SeriesKind.UUID: "uuids",
    SeriesKind.STRING: "strings",
    SeriesKind.STATUS: "statuses",
}


# Per known data type: its kind and the element field its series hold, found by one lookup
# of the type's number (an enum member hashes in Python; a series is read for every job).
_KNOWN_TYPES: dict[int, tuple[SeriesKind, str | None]] = {}
_NO_DATA_TYPE: Final = pb.NO_DATA_TYPE
_EXTERNAL_FILE: Final = SeriesKind.EXTERNAL_FILE


def _type_of(data_type: int) -> tuple[SeriesKind | None, str | None]:
    """`_KNOWN_TYPES` of `data_type`, kept once known; (None, None) for an unknown type."""
    kind = _kind(data_type)
    if kind is None:
        return None, None
    known = _KNOWN_TYPES[data_type] = (kind, _ELEMENT_FIELDS.get(kind))
    return known


def _check_series(
    series: pb.Series, elements: str | None, kind: SeriesKind, msg: pb.MetricsData
) -> None:
    """`elements`: the element field `kind`'s series hold."""
    holds = series.WhichOneof("series")
    if holds is not None and holds != elements:
        raise MalformedError(
            f"{_data_label(msg)} is declared {kind.value} but its series holds {holds}"
        )


def _referenced_ids(values: pb.MetricValues) -> list[pb.MetricsDataId]:
    which = values.WhichOneof("metric_values")
    if which is None:
        return []
    sub = getattr(values, which)
    ids: list[pb.MetricsDataId] = []
    # Walk the descriptor, so that every MetricsDataId field counts, whatever
    # the metric type, including ones a future type might add.
    for fd in sub.DESCRIPTOR.fields:
        if fd.message_type is not pb.MetricsDataId.DESCRIPTOR:
            continue
        value = getattr(sub, fd.name)
        if fd.is_repeated:
            ids.extend(value)
        elif sub.HasField(fd.name):
            ids.append(value)
    return ids


def _metric_view(msg: pb.Metric, source: str) -> MetricView:
    del source
    label = _label("metric", msg.name)
    data_ids: dict[uuid.UUID, None] = {}
    for ref in _referenced_ids(msg.metric_values):
        if ref.id.data:
            data_ids[_uuid(ref.id.data, f"{label}: referenced data id")] = None
    values = msg.metric_values
    scalar = values.scalar_metric_values if values.HasField("scalar_metric_values") else None
    return MetricView(
        id=_uuid(msg.metric_id.id.data, f"{label}: id"),
        name=msg.name,
        type=_enum(MetricType, msg.type),
        status=_enum(MetricStatus, msg.status),
        description=msg.description,
        blocking=msg.blocking if msg.HasField("blocking") else None,
        should_display=msg.should_display if msg.HasField("should_display") else None,
        importance=_enum(MetricImportance, msg.importance),
        order=msg.order if msg.HasField("order") else None,
        tags=tuple((t.key, t.value) for t in msg.tags),
        job_id=_optional_uuid(msg.job_id.id.data, f"{label}: job id"),
        event_metric=msg.event_metric,
        value=scalar.value if scalar is not None and scalar.HasField("value") else None,
        unit=scalar.unit if scalar is not None and scalar.HasField("unit") else None,
        data_ids=tuple(data_ids),
        raw=msg,
    )


_TIMESTAMP_TYPES: dict[int, Literal["absolute", "relative"]] = {
    pb.ABSOLUTE_TIMESTAMP: "absolute",
    pb.RELATIVE_TIMESTAMP: "relative",
}


def _event_view(msg: pb.Event) -> EventView:
    label = _label("event", msg.name)
    ts = msg.timestamp
    return EventView(
        id=_uuid(msg.event_id.id.data, f"{label}: id"),
        name=msg.name,
        description=msg.description,
        tags=tuple(msg.tags),
        metric_ids=tuple(_uuid(m.id.data, f"{label}: metric id") for m in msg.metrics),
        status=_enum(MetricStatus, msg.status),
        importance=_enum(MetricImportance, msg.importance),
        timestamp_ns=(
            ts.seconds * NANOS_PER_SECOND + ts.nanos if msg.HasField("timestamp") else None
        ),
        timestamp_type=(
            None
            if msg.timestamp_type == pb.NO_TYPE
            else _TIMESTAMP_TYPES.get(msg.timestamp_type, msg.timestamp_type)
        ),
        raw=msg,
    )


def _job_view(msg: pb.JobMetrics, source: str) -> JobMetricsView:
    metrics = tuple(_metric_view(m, source) for m in msg.job_level_metrics.metrics)
    data = _with_indexes(tuple(_data_view(d, source) for d in msg.metrics_data))
    return JobMetricsView(
        job_id=_optional_uuid(msg.job_id.id.data, "job id"),
        status=_enum(MetricStatus, msg.metrics_status),
        metrics=metrics,
        data=data,
        events=tuple(_event_view(e) for e in msg.events),
        metrics_by_id=_first_wins((m.id, m) for m in metrics),
        data_by_id=_first_wins((d.id, d) for d in data),
        data_by_name=_first_wins((d.name, d) for d in data),
        raw=msg,
    )


def _with_indexes(data: tuple[MetricsDataView, ...]) -> tuple[MetricsDataView, ...]:
    """The data, each indexed one holding its index view (when the output holds it), so
    that `MetricsDataView.labelled` needs nothing else."""
    by_id = _first_wins((d.id, d) for d in data)
    return tuple(
        d.with_index(by_id[d.index_id]) if d.index_id is not None and d.index_id in by_id else d
        for d in data
    )


_K = TypeVar("_K")


def _first_wins(pairs: Iterable[tuple[_K, _V]]) -> Mapping[_K, _V]:
    result: dict[_K, _V] = {}
    for key, value in pairs:
        result.setdefault(key, value)
    return MappingProxyType(result)
