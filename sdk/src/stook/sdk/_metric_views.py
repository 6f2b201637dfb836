"""Typed views of one metric: its values message read field by field, its data resolved.

`JobMetricsView.metric(name)` builds one per call, for the metric's `MetricType`: a
`HistogramMetric` has its buckets, bounds and values data, a `BarChartMetric` its
values data per series with their legend, and so on. Every ``*_data_id(s)`` field of
the schema becomes a ``*_data`` field holding the `MetricsDataView` (or a tuple of them,
in field order) that the same `JobMetricsView` holds under that ID; an unset singular
reference is None. A reference to an ID the output does not hold raises
`MissingDataError`. Optional fields that are unset are None; timestamps are integer
UTC nanoseconds, as in `EventView`.

A metric whose type this schema does not know (a newer ReSim's), or that has no type,
reads as an `UnknownMetric` holding every metrics data it references: the reader reads
such metrics rather than refusing them (see `_reader`), and so do the typed views. A
metric whose values message is not the one its type calls for (a HISTOGRAM holding bar
chart values) cannot be read as its type and raises `ReadError`.
"""

from __future__ import annotations

import difflib
import uuid
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

from google.protobuf.message import Message

from stook.proto import metrics_pb2 as pb
from stook.sdk._enums import NANOS_PER_SECOND, MetricStatus, MetricType
from stook.sdk._errors import MissingDataError, ReadError

if TYPE_CHECKING:
    from stook.sdk._views import JobMetricsView, MetricsDataView, MetricView


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


class MetricNotFoundError(KeyError):
    """No metric of that name; a KeyError whose message reads as a sentence."""

    def __str__(self) -> str:
        return str(self.args[0])


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
