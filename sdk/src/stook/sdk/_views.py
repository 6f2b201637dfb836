"""The reader's views: frozen, typed records of an output, its metrics, data and events.

A view holds what the reader decoded (IDs as ``uuid.UUID``, enums as members, unset
fields as None) and keeps the message it was read from as ``raw``. Series values are
converted on demand, by `series`, `frame` and the frames of `JobMetricsView`, so that
reading an output converts no data nobody looks at. Building views from
messages, and deciding what is readable, is `_reader`'s job.

The typed views of one metric: `JobMetricsView.metric(name)` builds one per call, for
the metric's `MetricType`: a `HistogramMetric` has its buckets, bounds and values data,
a `BarChartMetric` its values data per series with their legend, and so on. Every
``*_data_id(s)`` field of the schema becomes a ``*_data`` field holding the
`MetricsDataView` (or a tuple of them, in field order) that the same `JobMetricsView`
holds under that ID; an unset singular reference is None. A reference to an ID the
output does not hold raises `MissingDataError`. Optional fields that are unset are None;
timestamps are integer UTC nanoseconds, as in `EventView`.

A metric whose type this schema does not know (a newer ReSim's), or that has no type,
reads as an `UnknownMetric` holding every metrics data it references: the reader reads
such metrics rather than refusing them (see `_reader`), and so do the typed views. A
metric whose values message is not the one its type calls for (a HISTOGRAM holding bar
chart values) cannot be read as its type and raises `ReadError`.

`MetricsDataView.values` gives a few values without polars: doubles are floats, strings
str, timestamps integer UTC nanoseconds (as `EventView` counts them), UUIDs
``uuid.UUID`` and statuses `MetricStatus` members (None for an unset status, the number
for one this schema does not know).
"""

from __future__ import annotations

import dataclasses
import difflib
import uuid
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, TypeVar, overload

from google.protobuf.message import Message

from stook.proto import metrics_pb2 as pb
from stook.sdk._enums import (
    NANOS_PER_SECOND,
    MetricImportance,
    MetricStatus,
    MetricType,
    SeriesKind,
)
from stook.sdk._errors import (
    MalformedError,
    MetricNotFoundError,
    MissingDataError,
    ReadError,
    read_error,
)

if TYPE_CHECKING:
    import polars as pl


# polars (and numpy, through `_series`) is imported when a series or frame is first asked
# for, not with the views: `stook show` and `stook validate` read files without it.

_T = TypeVar("_T", bound="TypedMetric")


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
    index: MetricsDataView | None = field(default=None, repr=False, compare=False)
    """The index data itself, when this data was read as part of a `JobMetricsView`
    that holds it; None otherwise (and for data without an index)."""

    @property
    def is_external(self) -> bool:
        return self.kind is SeriesKind.EXTERNAL_FILE

    def with_index(self, index: MetricsDataView) -> MetricsDataView:
        """This data holding `index` as its index view (for data read on their own, e.g.
        with `read_metrics_data`); ValueError when `index` is not the data its
        ``index_id`` names."""
        if index.id != self.index_id:
            raise ValueError(
                f"metrics data {index.name!r} ({index.id}) is not the index of {self.name!r} "
                f"({self.index_id})"
            )
        return dataclasses.replace(self, index=index)

    def values(self) -> tuple[Any, ...]:
        """The values of a plain (not per-category) series as Python values.

        Doubles are floats, strings str, timestamps integer UTC nanoseconds, UUIDs
        ``uuid.UUID``, statuses `MetricStatus` (None unset, an int if unknown). For a
        few values without polars; `series` is the fast way for many.
        """
        self._check_has_series()
        if self.per_category:
            raise ValueError(
                f"metrics data {self.name!r} is per category; use by_category() or frame()"
            )
        return self._plain(self.raw.series)

    def labelled(self) -> tuple[tuple[Any, Any], ...]:
        """(index value, value) pairs of an indexed plain series, in order.

        For a bar chart's values (doubles indexed by strings) these are the (label,
        value) pairs, labels kept as written (repeats included). Values and index values
        are Python values as in `values`. Needs the index: read the data as part of the
        `JobMetricsView` that holds it (``job.data_by_name[...]`` or a typed metric's
        data); ValueError when the data has no index or it was read without it.
        """
        if self.index_id is None:
            raise ValueError(f"metrics data {self.name!r} has no index")
        if self.index is None:
            raise ValueError(
                f"the index of metrics data {self.name!r} ({self.index_id}) is not at hand; "
                "read the data with the JobMetricsView that holds its index"
            )
        values, labels = self.values(), self.index.values()
        if len(values) != len(labels):
            raise read_error(
                pb.MetricsData,
                self.source,
                f"data {self.name!r} has {len(values)} values but its index "
                f"{self.index.name!r} has {len(labels)}",
            )
        return tuple(zip(labels, values, strict=True))

    def by_label(self) -> dict[str, Any]:
        """`labelled` as a dict, label -> value, for data indexed by strings (a bar chart's
        values). ValueError if a label repeats (use `labelled` to keep repeats)."""
        pairs = self.labelled()
        assert self.index is not None  # labelled() checked
        if self.index.kind is not SeriesKind.STRING:
            raise ValueError(f"metrics data {self.name!r} is not indexed by strings")
        result: dict[str, Any] = {}
        for label, value in pairs:
            if label in result:
                raise ValueError(f"metrics data {self.name!r} repeats the label {label!r}")
            result[label] = value
        return result

    def by_category(self) -> dict[str, pl.Series]:
        """Per-category data as category -> series (named after its category), in
        declared order, then any undeclared categories, sorted. ValueError when the data
        is not per category."""
        self._check_has_series()
        if not self.per_category:
            raise ValueError(f"metrics data {self.name!r} is not per category; use series()")
        by_category = self.raw.series_per_category.category_to_series
        extra = sorted(set(by_category) - set(self.categories))
        return {
            category: self._convert(by_category[category], category)
            for category in (*self.categories, *extra)
            if category in by_category
        }

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
        import polars as pl

        from stook.sdk._series import VALUE_DTYPES, long_frame

        kind = self._check_has_series()
        if not self.per_category:
            return long_frame(None, self.series())
        by_category = self.raw.series_per_category.category_to_series
        extra = sorted(set(by_category) - set(self.categories))
        parts = [
            long_frame(category, self._convert(by_category[category], "value"))
            for category in (*self.categories, *extra)
            if category in by_category
        ]
        if not parts:
            return long_frame(None, pl.Series("value", [], dtype=VALUE_DTYPES[kind]))
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

    def _plain(self, series: pb.Series) -> tuple[Any, ...]:
        try:
            return plain_values(series, self._check_has_series())
        except MalformedError as exc:
            raise read_error(pb.MetricsData, self.source, f"data {self.name!r}: {exc}") from None

    def _convert(self, series: pb.Series, name: str) -> pl.Series:
        from stook.sdk._series import to_polars

        try:
            return to_polars(series, self._check_has_series(), name)
        except MalformedError as exc:
            raise read_error(pb.MetricsData, self.source, f"data {self.name!r}: {exc}") from None


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

    def metric_names(self) -> tuple[str, ...]:
        """The names of the metrics, in the order written, without repeats."""
        return tuple(dict.fromkeys(m.name for m in self.metrics))

    def find_metric(self, name: str) -> MetricView | None:
        """The metric named `name` (the first, if names repeat), or None."""
        return next((m for m in self.metrics if m.name == name), None)

    @overload
    def metric(self, name: str) -> TypedMetric: ...
    @overload
    def metric(self, name: str, kind: type[_T]) -> _T: ...
    def metric(self, name: str, kind: type[TypedMetric] | None = None) -> TypedMetric:
        """The typed view of the metric `name`, its data resolved from this output.

        One class per `MetricType` (`HistogramMetric`, `BarChartMetric`, ...;
        `UnknownMetric` for a type this schema does not know). With `kind`, the view
        must be of that class (TypeError otherwise), which also types the result.
        KeyError (naming close names) when there is no such metric; `MissingDataError`
        when it references data this output does not hold.
        """
        found = self.find_metric(name)
        if found is None:
            raise not_found(name, self.metric_names())
        typed = typed_metric(found, self)
        if kind is not None and not isinstance(typed, kind):
            shown = found.type.name if isinstance(found.type, MetricType) else found.type
            raise TypeError(f"metric {name!r} is a {shown} metric, not a {kind.__name__}")
        return typed

    def scalars_frame(self) -> pl.DataFrame:
        """One row per SCALAR metric: metric_id, name, value (Float64), unit, status."""
        import polars as pl

        from stook.sdk._series import STATUS_DTYPE

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
        import polars as pl

        from stook.sdk._series import KIND_DTYPE

        schema = _series_frame_schema()
        parts = [schema.clear()]
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
        return pl.concat(parts, how="diagonal").select(schema.columns)


def _series_frame_schema() -> pl.DataFrame:
    import polars as pl

    from stook.sdk._series import KIND_DTYPE, SERIES_KINDS, VALUE_DTYPES

    return pl.DataFrame(
        schema={
            "data_id": pl.String,
            "data_name": pl.String,
            "kind": KIND_DTYPE,
            "category": pl.String,
            "position": pl.UInt32,
            **{f"value_{k.value}": VALUE_DTYPES[k] for k in SERIES_KINDS},
        }
    )


class Bucket(NamedTuple):
    """One histogram bucket, ``[lower, upper)``. A bound that is unset reads as 0.0, as the
    platform's validator reads it (a tuple, so ``writer.histogram(buckets=...)`` takes it)."""

    lower: float
    upper: float


class FailureLimits(NamedTuple):
    """A failure definition: the value fails above `fails_above` or below `fails_below`."""

    fails_above: float | None
    fails_below: float | None


@dataclass(frozen=True, slots=True)
class TypedMetric:
    """The base of the typed metric views: `view` is the metric as `MetricView` reads it."""

    view: MetricView

    @property
    def name(self) -> str:
        return self.view.name

    @property
    def id(self) -> uuid.UUID:
        return self.view.id

    @property
    def type(self) -> MetricType | int | None:
        return self.view.type

    @property
    def status(self) -> MetricStatus | int | None:
        return self.view.status


@dataclass(frozen=True, slots=True)
class ScalarMetric(TypedMetric):
    value: float | None
    unit: str | None
    fails_above: float | None
    fails_below: float | None


@dataclass(frozen=True, slots=True)
class DoubleSummaryMetric(TypedMetric):
    """One element of `value_data`, picked by position (`series_index`) or by one of the
    index values (at most one of the four index fields is set)."""

    value_data: MetricsDataView | None
    status_data: MetricsDataView | None
    series_index: int | None
    timestamp_index_ns: int | None
    uuid_index: uuid.UUID | None
    string_index: str | None
    fails_above: float | None
    fails_below: float | None


@dataclass(frozen=True, slots=True)
class DoubleOverTimeMetric(TypedMetric):
    doubles_over_time_data: tuple[MetricsDataView, ...]
    statuses_over_time_data: tuple[MetricsDataView, ...]
    failure_definitions: tuple[FailureLimits, ...]
    start_time_ns: int | None
    end_time_ns: int | None
    y_axis_name: str | None
    legend: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class LinePlotMetric(TypedMetric):
    x_doubles_data: tuple[MetricsDataView, ...]
    y_doubles_data: tuple[MetricsDataView, ...]
    statuses_data: tuple[MetricsDataView, ...]
    x_axis_name: str | None
    y_axis_name: str | None
    legend: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class BarChartMetric(TypedMetric):
    """Bars: each of `values_data` is doubles indexed by string labels
    (``values_data[i].labelled()`` gives (label, value) pairs)."""

    values_data: tuple[MetricsDataView, ...]
    statuses_data: tuple[MetricsDataView, ...]
    legend: tuple[str, ...]
    x_axis_name: str | None
    y_axis_name: str | None
    stack_bars: bool | None


@dataclass(frozen=True, slots=True)
class BatchwiseBarChartMetric(TypedMetric):
    times_data: tuple[MetricsDataView, ...]
    values_data: tuple[MetricsDataView, ...]
    statuses_data: tuple[MetricsDataView, ...]
    categories: tuple[str, ...]
    colors: tuple[str, ...]
    x_axis_name: str | None
    y_axis_name: str | None
    stack_bars: bool | None
    project_id: uuid.UUID | None


@dataclass(frozen=True, slots=True)
class StatesOverTimeMetric(TypedMetric):
    states_over_time_data: tuple[MetricsDataView, ...]
    statuses_over_time_data: tuple[MetricsDataView, ...]
    states_set: tuple[str, ...]
    failure_states: tuple[str, ...]
    legend: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class HistogramMetric(TypedMetric):
    values_data: MetricsDataView | None
    statuses_data: MetricsDataView | None
    buckets: tuple[Bucket, ...]
    lower_bound: float | None
    upper_bound: float | None
    x_axis_name: str | None


@dataclass(frozen=True, slots=True)
class TextMetric(TypedMetric):
    text: str


@dataclass(frozen=True, slots=True)
class PlotlyMetric(TypedMetric):
    """`json` is the figure as JSON data (a fresh dict per `metric` call; numbers are
    floats, as a protobuf Struct holds them)."""

    json: dict[str, Any]


@dataclass(frozen=True, slots=True)
class ImageMetric(TypedMetric):
    """`image_data` is an external file: its path is ``image_data.external_path``."""

    image_data: MetricsDataView | None


@dataclass(frozen=True, slots=True)
class ImageListMetric(TypedMetric):
    image_data: tuple[MetricsDataView, ...]


@dataclass(frozen=True, slots=True)
class UnknownMetric(TypedMetric):
    """A metric of a type this schema does not know, or of no type: `data` holds every
    metrics data it references, in field order (``view.raw`` has the rest)."""

    data: tuple[MetricsDataView, ...]


def not_found(name: str, names: Iterable[str]) -> MetricNotFoundError:
    close = difflib.get_close_matches(name, list(names), n=3)
    hint = f"; close names: {', '.join(map(repr, close))}" if close else ""
    return MetricNotFoundError(f"the output has no metric named {name!r}{hint}")


# ---------------------------------------------------------------- building


class _Resolver:
    """Looks a metric's data references up in the output it came from."""

    def __init__(self, metric: MetricView, job: JobMetricsView) -> None:
        self._metric = metric
        self._data = job.data_by_id

    def one(self, owner: Message, field: str) -> MetricsDataView | None:
        ref: pb.MetricsDataId = getattr(owner, field)
        if not owner.HasField(field) or not ref.id.data:
            return None
        return self._find(ref)

    def many(self, refs: Iterable[pb.MetricsDataId]) -> tuple[MetricsDataView, ...]:
        return tuple(self._find(ref) for ref in refs)

    def _find(self, ref: pb.MetricsDataId) -> MetricsDataView:
        # The reader parsed every non-empty referenced ID when it built the MetricView.
        data_id = uuid.UUID(hex=ref.id.data) if ref.id.data else None
        found = self._data.get(data_id) if data_id is not None else None
        if found is None:
            raise MissingDataError(self._metric.name, data_id)
        return found


def _optional(msg: Message, field: str) -> Any:
    return getattr(msg, field) if msg.HasField(field) else None


def _ns(ts: Any) -> int:
    return int(ts.seconds) * NANOS_PER_SECOND + int(ts.nanos)


def _limits(failure: pb.DoubleFailureDefinition | None) -> FailureLimits:
    if failure is None:
        return FailureLimits(None, None)
    return FailureLimits(_optional(failure, "fails_above"), _optional(failure, "fails_below"))


def _scalar(m: MetricView, v: pb.ScalarMetricValues, r: _Resolver) -> ScalarMetric:
    limits = _limits(_optional(v, "failure_definition"))
    return ScalarMetric(
        m, _optional(v, "value"), _optional(v, "unit"), limits.fails_above, limits.fails_below
    )


def _double_summary(
    m: MetricView, v: pb.DoubleSummaryMetricValues, r: _Resolver
) -> DoubleSummaryMetric:
    index = v.WhichOneof("index")
    limits = _limits(_optional(v, "failure_definition"))
    return DoubleSummaryMetric(
        m,
        value_data=r.one(v, "value_data_id"),
        status_data=r.one(v, "status_data_id"),
        series_index=v.series_index if index == "series_index" else None,
        timestamp_index_ns=_ns(v.timestamp_index) if index == "timestamp_index" else None,
        uuid_index=_parse_uuid(m, v.uuid_index.data) if index == "uuid_index" else None,
        string_index=v.string_index if index == "string_index" else None,
        fails_above=limits.fails_above,
        fails_below=limits.fails_below,
    )


def _double_over_time(
    m: MetricView, v: pb.DoubleOverTimeMetricValues, r: _Resolver
) -> DoubleOverTimeMetric:
    return DoubleOverTimeMetric(
        m,
        doubles_over_time_data=r.many(v.doubles_over_time_data_id),
        statuses_over_time_data=r.many(v.statuses_over_time_data_id),
        failure_definitions=tuple(_limits(f) for f in v.failure_definition),
        start_time_ns=_ns(v.start_time) if v.HasField("start_time") else None,
        end_time_ns=_ns(v.end_time) if v.HasField("end_time") else None,
        y_axis_name=_optional(v, "y_axis_name"),
        legend=tuple(v.legend_series_names),
    )


def _line_plot(m: MetricView, v: pb.LinePlotMetricValues, r: _Resolver) -> LinePlotMetric:
    return LinePlotMetric(
        m,
        x_doubles_data=r.many(v.x_doubles_data_id),
        y_doubles_data=r.many(v.y_doubles_data_id),
        statuses_data=r.many(v.statuses_data_id),
        x_axis_name=_optional(v, "x_axis_name"),
        y_axis_name=_optional(v, "y_axis_name"),
        legend=tuple(v.legend_series_names),
    )


def _bar_chart(m: MetricView, v: pb.BarChartMetricValues, r: _Resolver) -> BarChartMetric:
    return BarChartMetric(
        m,
        values_data=r.many(v.values_data_id),
        statuses_data=r.many(v.statuses_data_id),
        legend=tuple(v.legend_series_names),
        x_axis_name=_optional(v, "x_axis_name"),
        y_axis_name=_optional(v, "y_axis_name"),
        stack_bars=_optional(v, "stack_bars"),
    )


def _batchwise_bar_chart(
    m: MetricView, v: pb.BatchwiseBarChartMetricValues, r: _Resolver
) -> BatchwiseBarChartMetric:
    return BatchwiseBarChartMetric(
        m,
        times_data=r.many(v.times_data_id),
        values_data=r.many(v.values_data_id),
        statuses_data=r.many(v.statuses_data_id),
        categories=tuple(v.categories),
        colors=tuple(v.colors),
        x_axis_name=_optional(v, "x_axis_name"),
        y_axis_name=_optional(v, "y_axis_name"),
        stack_bars=_optional(v, "stack_bars"),
        project_id=(
            _parse_uuid(m, v.project_id.data)
            if v.HasField("project_id") and v.project_id.data
            else None
        ),
    )


def _states_over_time(
    m: MetricView, v: pb.StatesOverTimeMetricValues, r: _Resolver
) -> StatesOverTimeMetric:
    return StatesOverTimeMetric(
        m,
        states_over_time_data=r.many(v.states_over_time_data_id),
        statuses_over_time_data=r.many(v.statuses_over_time_data_id),
        states_set=tuple(v.states_set),
        failure_states=tuple(v.failure_states),
        legend=tuple(v.legend_series_names),
    )


def _histogram(m: MetricView, v: pb.HistogramMetricValues, r: _Resolver) -> HistogramMetric:
    return HistogramMetric(
        m,
        values_data=r.one(v, "values_data_id"),
        statuses_data=r.one(v, "statuses_data_id"),
        buckets=tuple(Bucket(b.lower, b.upper) for b in v.buckets),
        lower_bound=_optional(v, "lower_bound"),
        upper_bound=_optional(v, "upper_bound"),
        x_axis_name=_optional(v, "x_axis_name"),
    )


def _text(m: MetricView, v: pb.TextMetricValues, r: _Resolver) -> TextMetric:
    return TextMetric(m, v.text)


def _plotly(m: MetricView, v: pb.PlotlyMetricValues, r: _Resolver) -> PlotlyMetric:
    from google.protobuf import json_format

    return PlotlyMetric(m, json_format.MessageToDict(v.json))


def _image(m: MetricView, v: pb.ImageMetricValues, r: _Resolver) -> ImageMetric:
    return ImageMetric(m, r.one(v, "image_data_id"))


def _image_list(m: MetricView, v: pb.ImageListMetricValues, r: _Resolver) -> ImageListMetric:
    return ImageListMetric(m, r.many(v.image_data_ids))


def _parse_uuid(m: MetricView, text: str) -> uuid.UUID:
    try:
        return uuid.UUID(hex=text)
    except ValueError:
        raise ReadError(f"metric {m.name!r}: {text!r} is not a UUID") from None


_Build = Callable[[Any, Any, _Resolver], TypedMetric]

# MetricType -> (the field of the MetricValues oneof it uses, the builder)
_BUILDERS: Mapping[MetricType, tuple[str, _Build]] = {
    MetricType.SCALAR: ("scalar_metric_values", _scalar),
    MetricType.DOUBLE_SUMMARY: ("double_metric_values", _double_summary),
    MetricType.DOUBLE_OVER_TIME: ("double_over_time_metric_values", _double_over_time),
    MetricType.LINE_PLOT: ("line_plot_metric_values", _line_plot),
    MetricType.BAR_CHART: ("bar_chart_metric_values", _bar_chart),
    MetricType.BATCHWISE_BAR_CHART: ("batchwise_bar_chart_metric_values", _batchwise_bar_chart),
    MetricType.STATES_OVER_TIME: ("states_over_time_metric_values", _states_over_time),
    MetricType.HISTOGRAM: ("histogram_metric_values", _histogram),
    MetricType.TEXT: ("text_metric_values", _text),
    MetricType.PLOTLY: ("plotly_metric_values", _plotly),
    MetricType.IMAGE: ("image_metric_values", _image),
    MetricType.IMAGE_LIST: ("image_list_metric_values", _image_list),
}

#: the typed view class of each metric type
TYPED_CLASSES: Mapping[MetricType, type[TypedMetric]] = {
    MetricType.SCALAR: ScalarMetric,
    MetricType.DOUBLE_SUMMARY: DoubleSummaryMetric,
    MetricType.DOUBLE_OVER_TIME: DoubleOverTimeMetric,
    MetricType.LINE_PLOT: LinePlotMetric,
    MetricType.BAR_CHART: BarChartMetric,
    MetricType.BATCHWISE_BAR_CHART: BatchwiseBarChartMetric,
    MetricType.STATES_OVER_TIME: StatesOverTimeMetric,
    MetricType.HISTOGRAM: HistogramMetric,
    MetricType.TEXT: TextMetric,
    MetricType.PLOTLY: PlotlyMetric,
    MetricType.IMAGE: ImageMetric,
    MetricType.IMAGE_LIST: ImageListMetric,
}


def typed_metric(metric: MetricView, job: JobMetricsView) -> TypedMetric:
    """The typed view of `metric`, its data looked up in `job` (which holds it)."""
    resolver = _Resolver(metric, job)
    spec = _BUILDERS.get(metric.type) if isinstance(metric.type, MetricType) else None
    if spec is None:
        return UnknownMetric(
            metric, tuple(job.data_by_id.get(i) or _missing(metric, i) for i in metric.data_ids)
        )
    field, build = spec
    values = metric.raw.metric_values
    holds = values.WhichOneof("metric_values")
    if holds not in (None, field):
        assert isinstance(metric.type, MetricType)
        raise ReadError(
            f"metric {metric.name!r} is a {metric.type.name} metric but holds {holds}, not {field}"
        )
    return build(metric, getattr(values, field), resolver)


def _missing(metric: MetricView, data_id: uuid.UUID) -> MetricsDataView:
    raise MissingDataError(metric.name, data_id)


def plain_values(series: pb.Series, kind: SeriesKind) -> tuple[Any, ...]:
    """The elements of `series`, which holds elements of `kind` (not an external file)."""
    return _CONVERTERS[kind](series)


def _uuid(text: str) -> uuid.UUID:
    try:
        return uuid.UUID(hex=text)
    except ValueError:
        raise MalformedError(f"series element {text!r} is not a UUID") from None


def _status(value: int) -> MetricStatus | int | None:
    if value == 0:
        return None
    try:
        return MetricStatus(value)
    except ValueError:
        return value


_CONVERTERS: dict[SeriesKind, Callable[[pb.Series], tuple[Any, ...]]] = {
    SeriesKind.DOUBLE: lambda s: tuple(s.doubles.series),
    SeriesKind.STRING: lambda s: tuple(s.strings.series),
    SeriesKind.TIMESTAMP: lambda s: tuple(
        t.seconds * NANOS_PER_SECOND + t.nanos for t in s.timestamps.series
    ),
    SeriesKind.UUID: lambda s: tuple(_uuid(u.data) for u in s.uuids.series),
    SeriesKind.STATUS: lambda s: tuple(_status(v) for v in s.statuses.series),
}
