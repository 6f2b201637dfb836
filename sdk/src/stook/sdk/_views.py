"""The reader's views: frozen, typed records of an output, its metrics, data and events.

A view holds what the reader decoded (IDs as ``uuid.UUID``, enums as members, unset
fields as None) and keeps the message it was read from as ``raw``. Series values are
converted on demand, by `series`, `frame` and the frames of `JobMetricsView`, so that
reading an output converts no data nobody looks at. Building views from
messages, and deciding what is readable, is `_reader`'s job.
"""

from __future__ import annotations

import dataclasses
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import TYPE_CHECKING, Any, Literal, TypeVar, overload

from stook.proto import metrics_pb2 as pb
from stook.sdk._elements import plain_values
from stook.sdk._enums import MetricImportance, MetricStatus, MetricType, SeriesKind
from stook.sdk._errors import MalformedError, read_error
from stook.sdk._metric_views import not_found, typed_metric

if TYPE_CHECKING:
    import polars as pl

    from stook.sdk._metric_views import TypedMetric

# polars (and numpy, through `_series`) is imported when a series or frame is first asked
# for, not with the views: `stook show` and `stook validate` read files without it. The
# typed metric views (`_metric_views`: fourteen dataclasses, about a quarter of `stook
# validate`'s instructions) are imported by `metric`, the one method that builds them.

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
        try:
            return _to_polars()(series, self._check_has_series(), name)
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


@cache
def _to_polars() -> Callable[[pb.Series, SeriesKind, str], pl.Series]:
    """`stook.sdk._series.to_polars` (and with it polars), imported on first use. Not an
    import statement per call: ``from stook.sdk._series import ...`` costs a few µs each
    time, a good part of converting a job's 300 doubles."""
    from stook.sdk._series import to_polars

    return to_polars


@cache
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
