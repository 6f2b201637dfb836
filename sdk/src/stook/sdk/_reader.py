"""Read metrics.binproto bytes into typed, immutable views and polars frames.

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
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Literal, TypeVar

import numpy as np
import polars as pl
from google.protobuf.message import Error as ProtobufError
from google.protobuf.message import Message
from google.protobuf.unknown_fields import UnknownFieldSet

from stook.proto import metrics_pb2 as pb
from stook.sdk._enums import MetricImportance, MetricStatus, MetricType, SeriesKind, kind_of
from stook.sdk._errors import ReadError

__all__ = [
    "KIND_DTYPE",
    "STATUS_DTYPE",
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

STATUS_DTYPE = pl.Enum([s.name for s in MetricStatus])
"""dtype of status values in frames; ``NO_METRIC_STATUS`` (unset) and a status this
schema does not know read as null."""

_SERIES_KINDS = tuple(k for k in SeriesKind if k is not SeriesKind.EXTERNAL_FILE)
KIND_DTYPE = pl.Enum([k.value for k in _SERIES_KINDS])
"""dtype of the ``kind`` column of `JobMetricsView.series_frame`."""

_VALUE_DTYPES: dict[SeriesKind, pl.DataType] = {
    SeriesKind.DOUBLE: pl.Float64(),
    SeriesKind.TIMESTAMP: pl.Datetime("ns", "UTC"),
    SeriesKind.UUID: pl.String(),
    SeriesKind.STRING: pl.String(),
    SeriesKind.STATUS: STATUS_DTYPE,
}

_STATUS_NAMES: dict[int, str] = {s.value: s.name for s in MetricStatus}
_NANOS_PER_SECOND = 1_000_000_000

_Msg = TypeVar("_Msg", bound=Message)
_E = TypeVar("_E", MetricStatus, MetricImportance, MetricType)
_V = TypeVar("_V")


class _MalformedError(Exception):
    """Parsed, but not readable as the claimed message; turned into a ReadError."""


# ---------------------------------------------------------------- entry points


def read_job_metrics(data: bytes, *, source: str = "<bytes>") -> JobMetricsView:
    """Read a whole output (the bytes of a metrics.binproto file)."""
    return _view(pb.JobMetrics, _parse(pb.JobMetrics, data, source), source, _job_view)


def read_metric(data: bytes, *, source: str = "<bytes>") -> MetricView:
    """Read the bytes of one ``Metric`` message."""
    return _view(pb.Metric, _parse(pb.Metric, data, source), source, _metric_view)


def read_metrics_data(data: bytes, *, source: str = "<bytes>") -> MetricsDataView:
    """Read the bytes of one ``MetricsData`` message."""
    return _view(pb.MetricsData, _parse(pb.MetricsData, data, source), source, _data_view)


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


def _fail(what: type[Message], source: str, reason: str) -> ReadError:
    return ReadError(f"could not read {what.DESCRIPTOR.name} from {source!r}: {reason}")


def _parse(cls: type[_Msg], data: bytes, source: str) -> _Msg:
    if len(data) == 0:
        raise _fail(cls, source, "no bytes (an empty file is a failed or truncated write)")
    msg = cls()
    try:
        msg.ParseFromString(data)
    except ProtobufError as exc:
        detail = str(exc).rpartition(": ")[2].lower() or "parse failed"
        raise _fail(cls, source, f"not a valid protobuf message ({detail})") from exc
    fields = UnknownFieldSet(msg)
    unknown = sorted({fields[i].field_number for i in range(len(fields))})
    if unknown:
        numbers = ", ".join(map(str, unknown))
        raise _fail(
            cls,
            source,
            f"field number(s) {numbers} do not fit {cls.DESCRIPTOR.name}; "
            "these bytes are probably a different message",
        )
    return msg


def _view(cls: type[_Msg], msg: _Msg, source: str, build: Callable[[_Msg, str], _V]) -> _V:
    try:
        return build(msg, source)
    except _MalformedError as exc:
        raise _fail(cls, source, str(exc)) from None


# ---------------------------------------------------------------- views


@dataclass(frozen=True, slots=True)
class MetricsDataView:
    """One metrics data item: a typed series, per category or not, or an external file.

    ``kind`` is None for a data type this schema does not know (``raw.data_type`` has
    it): such data has no series. ``index_kind`` is None without an index, or for an
    index of a data type this schema does not know.
    """

    id: uuid.UUID
    name: str
    unit: str
    kind: SeriesKind | None
    indexed: bool
    index_id: uuid.UUID | None
    index_kind: SeriesKind | None
    per_category: bool
    categories: tuple[str, ...]
    """The declared category names, in the order written."""
    external_path: str | None
    raw: pb.MetricsData = field(repr=False)
    source: str = field(default="<message>", repr=False, compare=False)

    @property
    def is_external(self) -> bool:
        return self.kind is SeriesKind.EXTERNAL_FILE

    def series(self) -> pl.Series:
        """The values of a plain (not per-category) series, named after the data.

        Doubles are Float64, timestamps Datetime("ns", "UTC"), UUIDs their canonical
        text, strings String, statuses `STATUS_DTYPE`. ValueError for external files
        and per-category data (use `frame` or `category_series`).
        """
        self._check_has_series()
        if self.per_category:
            raise ValueError(
                f"metrics data {self.name!r} is per category; use frame() or category_series()"
            )
        return self._convert(self.raw.series, self.name)

    def category_series(self, category: str) -> pl.Series:
        """The values of one category of per-category data; KeyError if it has none."""
        self._check_has_series()
        if not self.per_category:
            raise ValueError(f"metrics data {self.name!r} is not per category")
        by_category = self.raw.series_per_category.category_to_series
        if category not in by_category:
            raise KeyError(f"metrics data {self.name!r} has no category {category!r}")
        return self._convert(by_category[category], category)

    def frame(self) -> pl.DataFrame:
        """Long format: ``category`` (String, null unless per category), ``position``
        (UInt32, from 0 within each category) and ``value`` (dtype as in `series`).

        Categories come in declared order, then any undeclared ones, sorted.
        ValueError for external files.
        """
        kind = self._check_has_series()
        if not self.per_category:
            return _long_frame(None, self.series())
        by_category = self.raw.series_per_category.category_to_series
        extra = sorted(set(by_category) - set(self.categories))
        parts = [
            _long_frame(category, self._convert(by_category[category], "value"))
            for category in (*self.categories, *extra)
            if category in by_category
        ]
        if not parts:
            return _long_frame(None, pl.Series("value", [], dtype=_VALUE_DTYPES[kind]))
        return pl.concat(parts, how="vertical")

    def _check_has_series(self) -> SeriesKind:
        if self.is_external:
            raise ValueError(f"metrics data {self.name!r} is an external file; it has no series")
        if self.kind is None:
            raise ValueError(
                f"metrics data {self.name!r} has data type {self.raw.data_type}, which this "
                "schema does not know; it has no series"
            )
        return self.kind

    def _convert(self, series: pb.Series, name: str) -> pl.Series:
        try:
            return _to_polars(series, self._check_has_series(), name)
        except _MalformedError as exc:
            raise _fail(pb.MetricsData, self.source, f"data {self.name!r}: {exc}") from None


@dataclass(frozen=True, slots=True)
class MetricView:
    """One metric. ``None`` marks an unset enum or optional field; an ``int`` an enum value
    this schema does not know."""

    id: uuid.UUID
    name: str
    type: MetricType | int | None
    status: MetricStatus | int | None
    description: str
    blocking: bool | None
    should_display: bool | None
    importance: MetricImportance | int | None
    order: float | None
    tags: tuple[tuple[str, str], ...]
    """(key, value) pairs in the order written; keys may repeat."""
    job_id: uuid.UUID | None
    event_metric: bool
    value: float | None
    """The value of a SCALAR metric; None for other types or when unset."""
    unit: str | None
    """The unit of a SCALAR metric; None for other types or when unset."""
    data_ids: tuple[uuid.UUID, ...]
    """Every metrics data this metric references, in field order, without repeats."""
    raw: pb.Metric = field(repr=False)


@dataclass(frozen=True, slots=True)
class EventView:
    id: uuid.UUID
    name: str
    description: str
    tags: tuple[str, ...]
    metric_ids: tuple[uuid.UUID, ...]
    status: MetricStatus | int | None
    importance: MetricImportance | int | None
    timestamp_ns: int | None
    """Nanoseconds since the epoch (absolute) or since the start (relative)."""
    timestamp_type: Literal["absolute", "relative"] | int | None
    raw: pb.Event = field(repr=False)


@dataclass(frozen=True, slots=True)
class JobMetricsView:
    """A whole output: metrics, metrics data and events of one job."""

    job_id: uuid.UUID | None
    status: MetricStatus | int | None
    metrics: tuple[MetricView, ...]
    data: tuple[MetricsDataView, ...]
    events: tuple[EventView, ...]
    metrics_by_id: Mapping[uuid.UUID, MetricView] = field(repr=False)
    data_by_id: Mapping[uuid.UUID, MetricsDataView] = field(repr=False)
    data_by_name: Mapping[str, MetricsDataView] = field(repr=False)
    """If names or IDs repeat (the validator refuses that), the first one wins."""
    raw: pb.JobMetrics = field(repr=False)

    def scalars_frame(self) -> pl.DataFrame:
        """One row per SCALAR metric: metric_id, name, value (Float64), unit, status."""
        scalars = [m for m in self.metrics if m.type is MetricType.SCALAR]
        return pl.DataFrame(
            {
                "metric_id": [str(m.id) for m in scalars],
                "name": [m.name for m in scalars],
                "value": [m.value for m in scalars],
                "unit": [m.unit for m in scalars],
                "status": [
                    m.status.name if isinstance(m.status, MetricStatus) else None for m in scalars
                ],
            },
            schema={
                "metric_id": pl.String,
                "name": pl.String,
                "value": pl.Float64,
                "unit": pl.String,
                "status": STATUS_DTYPE,
            },
        )

    def series_frame(self) -> pl.DataFrame:
        """Every non-external data in long format, one row per element.

        Columns: data_id, data_name (String), kind (`KIND_DTYPE`), category (String,
        null unless per category), position (UInt32), then one typed value column per
        kind -- value_double, value_timestamp, value_uuid, value_string, value_status --
        of which only the row's own kind is filled.
        """
        parts = [_SERIES_FRAME_SCHEMA.clear()]
        for data in self.data:
            if data.is_external or data.kind is None:
                continue
            parts.append(
                data.frame()
                .rename({"value": f"value_{data.kind.value}"})
                .with_columns(
                    data_id=pl.lit(str(data.id), pl.String),
                    data_name=pl.lit(data.name, pl.String),
                    kind=pl.lit(data.kind.value, KIND_DTYPE),
                )
            )
        return pl.concat(parts, how="diagonal").select(_SERIES_FRAME_SCHEMA.columns)


_SERIES_FRAME_SCHEMA = pl.DataFrame(
    schema={
        "data_id": pl.String,
        "data_name": pl.String,
        "kind": KIND_DTYPE,
        "category": pl.String,
        "position": pl.UInt32,
        **{f"value_{k.value}": _VALUE_DTYPES[k] for k in _SERIES_KINDS},
    }
)


# ---------------------------------------------------------------- building views


def _uuid(text: str, what: str) -> uuid.UUID:
    if not text:
        raise _MalformedError(f"{what} is missing")
    try:
        return uuid.UUID(hex=text)
    except ValueError:
        raise _MalformedError(f"{what} {text!r} is not a UUID") from None


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


def _kind(data_type: int, what: str) -> SeriesKind | None:
    """The series kind of a data type; None for one this schema does not know."""
    try:
        return kind_of(data_type)[0]
    except ValueError:
        if data_type == pb.NO_DATA_TYPE:
            raise _MalformedError(f"{what} is unset") from None
        return None


def _label(kind: str, name: str) -> str:
    return f"{kind} {name!r}" if name else f"{kind} (unnamed)"


def _data_view(msg: pb.MetricsData, source: str) -> MetricsDataView:
    label = _label("data", msg.name)
    kind = _kind(msg.data_type, f"{label}: data type")
    holds = msg.WhichOneof("data")
    if kind is SeriesKind.EXTERNAL_FILE:
        if holds not in (None, "external_file"):
            raise _MalformedError(f"{label} is declared an external file but holds a {holds}")
    elif kind is not None:  # of an unknown data type, nothing says what its series hold
        expected = "series_per_category" if msg.is_per_category else "series"
        if holds not in (None, expected):
            raise _MalformedError(
                f"{label}: is_per_category is {msg.is_per_category} but it holds {holds}"
            )
        for series in _all_series(msg):
            _check_series(series, kind, label)
    return MetricsDataView(
        id=_uuid(msg.metrics_data_id.id.data, f"{label}: id"),
        name=msg.name,
        unit=msg.unit,
        kind=kind,
        indexed=msg.is_indexed,
        index_id=_optional_uuid(msg.index_data_id.id.data, f"{label}: index id"),
        index_kind=(
            _kind(msg.index_data_type, f"{label}: index data type")
            if msg.index_data_type != pb.NO_DATA_TYPE
            else None
        ),
        per_category=msg.is_per_category,
        categories=tuple(msg.category_names),
        external_path=msg.external_file.path if holds == "external_file" else None,
        raw=msg,
        source=source,
    )


def _all_series(msg: pb.MetricsData) -> Iterable[pb.Series]:
    if msg.HasField("series"):
        yield msg.series
    yield from msg.series_per_category.category_to_series.values()


_ELEMENT_FIELDS: dict[SeriesKind, str] = {
    SeriesKind.DOUBLE: "doubles",
    SeriesKind.TIMESTAMP: "timestamps",
    SeriesKind.UUID: "uuids",
    SeriesKind.STRING: "strings",
    SeriesKind.STATUS: "statuses",
}


def _check_series(series: pb.Series, kind: SeriesKind, label: str) -> None:
    holds = series.WhichOneof("series")
    if holds is not None and holds != _ELEMENT_FIELDS[kind]:
        raise _MalformedError(f"{label} is declared {kind.value} but its series holds {holds}")


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
            ts.seconds * _NANOS_PER_SECOND + ts.nanos if msg.HasField("timestamp") else None
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
    data = tuple(_data_view(d, source) for d in msg.metrics_data)
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


_K = TypeVar("_K")


def _first_wins(pairs: Iterable[tuple[_K, _V]]) -> Mapping[_K, _V]:
    result: dict[_K, _V] = {}
    for key, value in pairs:
        result.setdefault(key, value)
    return MappingProxyType(result)


# ---------------------------------------------------------------- to polars


def _long_frame(category: str | None, values: pl.Series) -> pl.DataFrame:
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


def _to_polars(series: pb.Series, kind: SeriesKind, name: str) -> pl.Series:
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


_PACKED_PATH_MIN = 400


def _doubles(doubles: pb.DoubleSeries, name: str) -> pl.Series:
    # Handing polars the repeated field element by element costs ~50 ns per double
    # (40 µs for 1,000). The packed wire form already is the little-endian array polars
    # wants: re-serialize it (a memcpy in upb) and view it through numpy, ~20 µs whatever
    # the length. Below a few hundred values the element path is as fast.
    n = len(doubles.series)
    if n < _PACKED_PATH_MIN:
        return pl.Series(name, doubles.series, dtype=pl.Float64)
    wire = doubles.SerializeToString()
    start = _packed_payload_start(wire, n * 8)
    if start is None:
        return pl.Series(name, doubles.series, dtype=pl.Float64)
    return pl.Series(name, np.frombuffer(wire, dtype="<f8", count=n, offset=start))


def _packed_payload_start(wire: bytes, payload_len: int) -> int | None:
    """Offset of the packed payload in a serialized DoubleSeries, if that is all it is.

    Expects the key of field 1 / wire type 2, a varint length equal to
    ``payload_len`` and nothing after the payload (no unknown fields).
    """
    if not wire or wire[0] != 0x0A:
        return None
    length, shift, pos = 0, 0, 1
    while pos < len(wire):
        byte = wire[pos]
        length |= (byte & 0x7F) << shift
        pos += 1
        if not byte & 0x80:
            break
        shift += 7
    if length != payload_len or pos + length != len(wire):
        return None
    return pos


def _timestamps(timestamps: pb.TimestampSeries, name: str) -> pl.Series:
    nanos = [t.seconds * _NANOS_PER_SECOND + t.nanos for t in timestamps.series]
    try:
        ints = pl.Series(name, nanos, dtype=pl.Int64)
    except (OverflowError, TypeError, pl.exceptions.PolarsError) as exc:
        raise _MalformedError("a timestamp is too far from 1970 to hold in nanoseconds") from exc
    return ints.cast(pl.Datetime("ns", "UTC"))


def _canonical_uuid(text: str) -> str:
    try:
        return str(uuid.UUID(hex=text))
    except ValueError:
        raise _MalformedError(f"series element {text!r} is not a UUID") from None
