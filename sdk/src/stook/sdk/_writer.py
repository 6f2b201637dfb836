"""MetricsWriter: build one JobMetrics output (test, batch or report metrics) fluently.

Each metric method builds its proto at once and returns a `MetricHandle` whose
setters chain::

    w = MetricsWriter(job_id, deterministic=True)
    w.scalar("Max speed", 31.2, unit="m/s").describe("Peak speed").importance(HIGH)
    w.histogram("Speed distribution", data.doubles("speeds", v), buckets=20, lower=0, upper=40)
    w.write("/tmp/resim/outputs/metrics.binproto")

Metrics data referenced by a metric is written with it, index chains included;
`add_data` writes data alone so that batch metrics can find it later.
"""

from __future__ import annotations

import functools
import itertools
import json
import math
import uuid
from array import array
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Concatenate, ParamSpec, Self, TypedDict, TypeVar, Unpack

from google.protobuf import struct_pb2, timestamp_pb2

from stook.proto import metrics_pb2 as pb
from stook.proto import uuid_pb2
from stook.sdk import _data
from stook.sdk._atomic import write_atomic
from stook.sdk._data import MetricsData, TimestampLike, UuidLike
from stook.sdk._enums import (
    SERIES_FIELD,
    MetricImportance,
    MetricStatus,
    MetricType,
    SeriesKind,
    data_type_of,
)
from stook.sdk._errors import WriterError
from stook.sdk._ids import IdScheme

Bucket = tuple[float, float]


class MetricOptions(TypedDict, total=False):
    """What every metric type takes besides its values."""

    status: MetricStatus  # default PASSED
    description: str
    importance: MetricImportance  # default MEDIUM
    blocking: bool
    event: bool  # written for an event (see MetricsWriter.event); names may repeat


def _status_of(options: MetricOptions) -> MetricStatus:
    return options.get("status", MetricStatus.PASSED)


FailureDefinition = tuple[float | None, float | None]


class MetricHandle:
    """A metric in a writer; its setters change it in place and return it for chaining."""

    def __init__(self, writer: MetricsWriter, proto: pb.Metric) -> None:
        self._writer = writer
        self._proto = proto

    @property
    def name(self) -> str:
        return self._proto.name

    @property
    def type(self) -> MetricType:
        return MetricType(self._proto.type)

    @property
    def id(self) -> uuid.UUID:
        return uuid.UUID(self._proto.metric_id.id.data)

    @property
    def proto(self) -> pb.Metric:
        return self._proto

    def describe(self, description: str) -> Self:
        self._proto.description = description
        return self

    def status(self, status: MetricStatus) -> Self:
        self._proto.status = pb.MetricStatus.ValueType(MetricStatus(status))
        return self

    def blocking(self, blocking: bool = True) -> Self:
        self._proto.blocking = blocking
        return self

    def importance(self, importance: MetricImportance) -> Self:
        self._proto.importance = pb.MetricImportance.ValueType(MetricImportance(importance))
        return self

    def display(self, should_display: bool = True) -> Self:
        self._proto.should_display = should_display
        return self

    def order(self, order: float) -> Self:
        self._proto.order = order
        return self

    def tag(self, key: str, value: str) -> Self:
        if not key or not value:
            raise WriterError(f"metric {self.name!r}: a tag needs a non-empty key and value")
        self._proto.tags.add(key=key, value=value)
        return self


_P = ParamSpec("_P")
_R = TypeVar("_R")


def _all_or_nothing(
    method: Callable[Concatenate[MetricsWriter, _P], _R],
) -> Callable[Concatenate[MetricsWriter, _P], _R]:
    """A metric call that fails leaves the writer as it was: no half-built metric, no
    reserved name, no data written on its behalf."""

    @functools.wraps(method)
    def wrapper(self: MetricsWriter, /, *args: _P.args, **kwargs: _P.kwargs) -> _R:
        metrics, data = len(self._metrics), len(self._data)
        try:
            return method(self, *args, **kwargs)
        except BaseException:
            self._roll_back(metrics, data)
            raise

    return wrapper


class MetricsWriter:
    """Collects metrics and metrics data for one job (or batch, or report) output."""

    def __init__(self, job_id: UuidLike, *, deterministic: bool = False) -> None:
        try:
            self.job_id = job_id if isinstance(job_id, uuid.UUID) else uuid.UUID(str(job_id))
        except ValueError:
            raise WriterError(f"job ID {job_id!r} is not a UUID") from None
        self._ids = IdScheme(self.job_id, deterministic=deterministic)
        self._metrics: list[pb.Metric] = []
        self._metric_names: set[str] = set()
        self._data: dict[str, MetricsData] = {}
        self._data_ids: dict[str, uuid.UUID] = {}
        self._events: list[pb.Event] = []
        self._status_override: MetricStatus | None = None
        self._made_statuses: dict[tuple[str, MetricStatus], MetricsData] = {}

    # ---- data ----

    def add_data(self, *items: MetricsData) -> None:
        """Write data (and its index chain) into the output, referenced or not."""
        for item in items:
            for node in item.dependencies():
                known = self._data.get(node.name)
                if known is node:
                    continue
                if known is not None:
                    raise WriterError(f"two different metrics data are named {node.name!r}")
                _check_not_empty(node)
                self._data[node.name] = node
                self._data_ids[node.name] = self._ids.data_id(node.name, node.id)

    def _roll_back(self, metrics: int, data: int) -> None:
        del self._metrics[metrics:]
        for name in list(self._data)[data:]:
            del self._data[name]
            del self._data_ids[name]
        self._metric_names = {m.name for m in self._metrics if not m.event_metric}
        self._made_statuses = {
            k: v for k, v in self._made_statuses.items() if self._data.get(v.name) is v
        }

    def _ref(self, item: MetricsData) -> pb.MetricsDataId:
        self.add_data(item)
        return pb.MetricsDataId(id=_uuid_proto(self._data_ids[item.name]))

    @property
    def data(self) -> list[MetricsData]:
        return list(self._data.values())

    # ---- metrics: shared plumbing ----

    def _new_metric(
        self, name: str, metric_type: MetricType, options: MetricOptions
    ) -> tuple[pb.Metric, MetricHandle]:
        if not name:
            raise WriterError("a metric needs a non-empty name")
        event = options.get("event", False)
        if not event:
            if name in self._metric_names:
                raise WriterError(f"a metric named {name!r} was already written")
            self._metric_names.add(name)
        proto = pb.Metric(
            metric_id=pb.MetricId(id=_uuid_proto(self._ids.metric_id(name))),
            name=name,
            type=pb.MetricType.ValueType(metric_type),
            description=options.get("description", ""),
            job_id=pb.JobId(id=_uuid_proto(self.job_id)),
        )
        handle = MetricHandle(self, proto)
        handle.status(_status_of(options))
        handle.importance(options.get("importance", MetricImportance.MEDIUM))
        if "blocking" in options:
            handle.blocking(options["blocking"])
        if event:
            proto.event_metric = True
        self._metrics.append(proto)
        return proto, handle

    def _status_ref(
        self,
        metric: str,
        values: MetricsData,
        statuses: MetricsData | None,
        options: MetricOptions,
    ) -> pb.MetricsDataId:
        if statuses is not None:
            _matching(metric, [values], [statuses], _status_of(options), self._statuses_for)
        return self._ref(self._statuses_for(values, statuses, _status_of(options)))

    def _statuses_for(
        self, values: MetricsData, statuses: MetricsData | None, status: MetricStatus
    ) -> MetricsData:
        if statuses is not None:
            return statuses
        # One generated status series per (data, status), so that two metrics over the
        # same data share it instead of colliding on its name.
        key = (values.name, status)
        made = self._made_statuses.get(key)
        if made is None:
            made = _data.status_like(values, status, name=f"{values.name} ({status.name} status)")
            self._made_statuses[key] = made
        return made

    # ---- metrics: one method per type ----

    @_all_or_nothing
    def scalar(
        self,
        name: str,
        value: float,
        *,
        unit: str | None = None,
        fails_above: float | None = None,
        fails_below: float | None = None,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """A single number. With `fails_above`/`fails_below` and no `status`, the status
        is computed: outside the limits is FAIL_WARN, or FAIL_BLOCK when blocking."""
        value = float(value)
        if math.isnan(value):
            raise WriterError(f"metric {name!r}: a scalar value cannot be NaN")
        if "status" not in options:
            failed = (fails_above is not None and value > fails_above) or (
                fails_below is not None and value < fails_below
            )
            if failed:
                blocking = options.get("blocking", False)
                options["status"] = MetricStatus.FAIL_BLOCK if blocking else MetricStatus.FAIL_WARN
        proto, handle = self._new_metric(name, MetricType.SCALAR, options)
        values = proto.metric_values.scalar_metric_values
        values.value = value
        if unit is not None:
            values.unit = unit
        if fails_above is not None or fails_below is not None:
            values.failure_definition.CopyFrom(_failure(fails_above, fails_below))
        return handle

    @_all_or_nothing
    def double_summary(
        self,
        name: str,
        values: MetricsData,
        *,
        index: int | TimestampLike | UuidLike | str | None = None,
        index_kind: SeriesKind | None = None,
        statuses: MetricsData | None = None,
        failure: FailureDefinition | None = None,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """One element of a double series, picked by position (int) or by an index value.

        For a timestamp, UUID or string index value, `values` must be indexed by a
        series of that kind; `index_kind` disambiguates a string that is a UUID.
        """
        _require_kind(name, values, SeriesKind.DOUBLE)
        proto, handle = self._new_metric(name, MetricType.DOUBLE_SUMMARY, options)
        mv = proto.metric_values.double_metric_values
        mv.value_data_id.CopyFrom(self._ref(values))
        mv.status_data_id.CopyFrom(self._status_ref(name, values, statuses, options))
        own_kind = values.index.kind if values.index is not None else None
        if index_kind is not None and index_kind is not own_kind:
            raise WriterError(
                f"metric {name!r}: index_kind {index_kind.value} does not match the index of "
                f"{values.name!r} ({own_kind.value if own_kind else 'none'})"
            )
        kind = own_kind
        if index is None:
            pass
        elif (
            isinstance(index, int)
            and not isinstance(index, bool)
            and kind is not SeriesKind.TIMESTAMP
        ):
            mv.series_index = index
        elif kind is SeriesKind.TIMESTAMP:
            mv.timestamp_index.CopyFrom(_timestamp_proto(_data.timestamp_ns(index)))  # type: ignore[arg-type]
        elif kind is SeriesKind.UUID:
            mv.uuid_index.data = _canonical_uuid(name, index)
        elif kind is SeriesKind.STRING:
            mv.string_index = str(index)
        else:
            raise WriterError(
                f"metric {name!r}: index {index!r} needs values indexed by timestamps, UUIDs "
                "or strings"
            )
        if failure is not None:
            mv.failure_definition.CopyFrom(_failure(*failure))
        return handle

    @_all_or_nothing
    def double_over_time(
        self,
        name: str,
        doubles: MetricsData | Sequence[MetricsData],
        *,
        statuses: Sequence[MetricsData] | None = None,
        failures: Sequence[FailureDefinition] | None = None,
        start_time: TimestampLike | None = None,
        end_time: TimestampLike | None = None,
        y_axis_name: str | None = None,
        legend: Sequence[str] | None = None,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """Double series over time: each series indexed by timestamps."""
        series = _data.sequence_of(doubles)
        for s in series:
            _require_kind(name, s, SeriesKind.DOUBLE, index=SeriesKind.TIMESTAMP)
        status_series = _matching(name, series, statuses, _status_of(options), self._statuses_for)
        fails = list(failures) if failures is not None else [(None, None)] * len(series)
        if len(fails) != len(series):
            raise WriterError(f"metric {name!r}: give one failure definition per series")
        proto, handle = self._new_metric(name, MetricType.DOUBLE_OVER_TIME, options)
        mv = proto.metric_values.double_over_time_metric_values
        for s, st, f in zip(series, status_series, fails, strict=True):
            mv.doubles_over_time_data_id.append(self._ref(s))
            mv.statuses_over_time_data_id.append(self._ref(st))
            mv.failure_definition.append(_failure(*f))
        if start_time is not None:
            mv.start_time.CopyFrom(_timestamp_proto(_data.timestamp_ns(start_time)))
        if end_time is not None:
            mv.end_time.CopyFrom(_timestamp_proto(_data.timestamp_ns(end_time)))
        if y_axis_name is not None:
            mv.y_axis_name = y_axis_name
        mv.legend_series_names.extend(_legend(name, legend, series))
        return handle

    @_all_or_nothing
    def line_plot(
        self,
        name: str,
        x: MetricsData | Sequence[MetricsData],
        y: MetricsData | Sequence[MetricsData],
        *,
        statuses: Sequence[MetricsData] | None = None,
        x_axis_name: str | None = None,
        y_axis_name: str | None = None,
        legend: Sequence[str] | None = None,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """One or more lines, each an x double series against a y double series."""
        xs, ys = _data.sequence_of(x), _data.sequence_of(y)
        if len(xs) != len(ys) or not xs:
            raise WriterError(f"metric {name!r}: give as many x series as y series (at least 1)")
        for xi, yi in zip(xs, ys, strict=True):
            _require_kind(name, xi, SeriesKind.DOUBLE)
            _require_kind(name, yi, SeriesKind.DOUBLE)
            if xi.index is not None and xi.index.kind is not SeriesKind.TIMESTAMP:
                raise WriterError(
                    f"metric {name!r}: line data may be indexed by timestamps only, "
                    f"{xi.name!r} is indexed by {xi.index.kind.value}s"
                )
            if xi.shape() != yi.shape() or xi.index is not yi.index:
                raise WriterError(
                    f"metric {name!r}: x series {xi.name!r} and y series {yi.name!r} differ in "
                    "shape or index"
                )
        status_series = _matching(name, xs, statuses, _status_of(options), self._statuses_for)
        proto, handle = self._new_metric(name, MetricType.LINE_PLOT, options)
        mv = proto.metric_values.line_plot_metric_values
        for xi, yi, st in zip(xs, ys, status_series, strict=True):
            mv.x_doubles_data_id.append(self._ref(xi))
            mv.y_doubles_data_id.append(self._ref(yi))
            mv.statuses_data_id.append(self._ref(st))
        if x_axis_name is not None:
            mv.x_axis_name = x_axis_name
        if y_axis_name is not None:
            mv.y_axis_name = y_axis_name
        mv.legend_series_names.extend(_legend(name, legend, ys))
        return handle

    @_all_or_nothing
    def bar_chart(
        self,
        name: str,
        values: MetricsData | Sequence[MetricsData],
        *,
        statuses: Sequence[MetricsData] | None = None,
        x_axis_name: str | None = None,
        y_axis_name: str | None = None,
        legend: Sequence[str] | None = None,
        stack_bars: bool | None = None,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """Bars: each value series is doubles indexed by string labels."""
        series = _data.sequence_of(values)
        for s in series:
            _require_kind(name, s, SeriesKind.DOUBLE, index=SeriesKind.STRING)
        status_series = _matching(name, series, statuses, _status_of(options), self._statuses_for)
        proto, handle = self._new_metric(name, MetricType.BAR_CHART, options)
        mv = proto.metric_values.bar_chart_metric_values
        for s, st in zip(series, status_series, strict=True):
            mv.values_data_id.append(self._ref(s))
            mv.statuses_data_id.append(self._ref(st))
        mv.legend_series_names.extend(_legend(name, legend, series))
        if x_axis_name is not None:
            mv.x_axis_name = x_axis_name
        if y_axis_name is not None:
            mv.y_axis_name = y_axis_name
        if stack_bars is not None:
            mv.stack_bars = stack_bars
        return handle

    def bar_chart_from(
        self,
        name: str,
        bars: Mapping[str, float],
        *,
        data_name: str | None = None,
        **options: Any,
    ) -> MetricHandle:
        """A one-series bar chart from a label -> value mapping (labels keep their order)."""
        labels = _data.strings(f"{data_name or name} (labels)", list(bars))
        values = _data.doubles(data_name or name, list(bars.values()), index=labels)
        return self.bar_chart(name, values, **options)

    @_all_or_nothing
    def states_over_time(
        self,
        name: str,
        states: MetricsData | Sequence[MetricsData],
        *,
        states_set: Sequence[str] | None = None,
        failure_states: Sequence[str] = (),
        statuses: Sequence[MetricsData] | None = None,
        legend: Sequence[str] | None = None,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """Discrete states over time: string series indexed by timestamps."""
        series = _data.sequence_of(states)
        seen: set[str] = set()
        for s in series:
            _require_kind(name, s, SeriesKind.STRING, index=SeriesKind.TIMESTAMP)
            seen.update(_flat_strings(s))
        allowed = list(states_set) if states_set is not None else sorted(seen)
        if not seen.issubset(allowed):
            raise WriterError(
                f"metric {name!r}: states {sorted(seen - set(allowed))} are not in the states set"
            )
        if not set(failure_states).issubset(allowed):
            raise WriterError(f"metric {name!r}: failure states must be in the states set")
        status_series = _matching(name, series, statuses, _status_of(options), self._statuses_for)
        proto, handle = self._new_metric(name, MetricType.STATES_OVER_TIME, options)
        mv = proto.metric_values.states_over_time_metric_values
        for s, st in zip(series, status_series, strict=True):
            mv.states_over_time_data_id.append(self._ref(s))
            mv.statuses_over_time_data_id.append(self._ref(st))
        mv.states_set.extend(allowed)
        mv.failure_states.extend(failure_states)
        mv.legend_series_names.extend(_legend(name, legend, series))
        return handle

    @_all_or_nothing
    def histogram(
        self,
        name: str,
        values: MetricsData,
        *,
        buckets: int | Sequence[Bucket],
        lower: float | None = None,
        upper: float | None = None,
        statuses: MetricsData | None = None,
        x_axis_name: str | None = None,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """A histogram of a double series. `buckets` is a count of equal-width buckets
        between `lower` and `upper`, or explicit contiguous (lower, upper) pairs."""
        _require_kind(name, values, SeriesKind.DOUBLE)
        edges = histogram_buckets(name, buckets, lower, upper)
        proto, handle = self._new_metric(name, MetricType.HISTOGRAM, options)
        mv = proto.metric_values.histogram_metric_values
        mv.values_data_id.CopyFrom(self._ref(values))
        mv.statuses_data_id.CopyFrom(self._status_ref(name, values, statuses, options))
        for lo, hi in edges:
            mv.buckets.add(lower=lo, upper=hi)
        mv.lower_bound = edges[0][0]
        mv.upper_bound = edges[-1][1]
        if x_axis_name is not None:
            mv.x_axis_name = x_axis_name
        return handle

    @_all_or_nothing
    def batchwise_bar_chart(
        self,
        name: str,
        *,
        project_id: UuidLike,
        times: MetricsData | Sequence[MetricsData],
        values: MetricsData | Sequence[MetricsData],
        categories: Sequence[str],
        statuses: Sequence[MetricsData] | None = None,
        colors: Sequence[str] = (),
        x_axis_name: str | None = None,
        y_axis_name: str | None = None,
        stack_bars: bool | None = None,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """Values per batch over time, one series per category; each series is indexed by
        batch IDs, with a matching series of batch times."""
        ts, vs = _data.sequence_of(times), _data.sequence_of(values)
        if not (len(ts) == len(vs) == len(categories)):
            raise WriterError(f"metric {name!r}: give one times and one values series per category")
        for t, v in zip(ts, vs, strict=True):
            _require_kind(name, t, SeriesKind.TIMESTAMP, index=SeriesKind.UUID)
            _require_kind(name, v, SeriesKind.DOUBLE, index=SeriesKind.UUID)
            if t.index is not v.index:
                raise WriterError(f"metric {name!r}: {t.name!r} and {v.name!r} need one index")
        for color in colors:
            _check_color(name, color)
        status_series = _matching(name, vs, statuses, _status_of(options), self._statuses_for)
        proto, handle = self._new_metric(name, MetricType.BATCHWISE_BAR_CHART, options)
        mv = proto.metric_values.batchwise_bar_chart_metric_values
        for t, v, st in zip(ts, vs, status_series, strict=True):
            mv.times_data_id.append(self._ref(t))
            mv.values_data_id.append(self._ref(v))
            mv.statuses_data_id.append(self._ref(st))
        mv.categories.extend(categories)
        mv.colors.extend(colors)
        mv.project_id.data = _canonical_uuid(name, project_id)
        if x_axis_name is not None:
            mv.x_axis_name = x_axis_name
        if y_axis_name is not None:
            mv.y_axis_name = y_axis_name
        if stack_bars is not None:
            mv.stack_bars = stack_bars
        return handle

    @_all_or_nothing
    def text(
        self,
        name: str,
        text: str,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """Free text (markdown is rendered by the app)."""
        if not text:
            raise WriterError(f"metric {name!r}: text cannot be empty")
        proto, handle = self._new_metric(name, MetricType.TEXT, options)
        proto.metric_values.text_metric_values.text = text
        return handle

    @_all_or_nothing
    def plotly(
        self,
        name: str,
        figure: Mapping[str, Any] | str,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """A plotly figure, given as its JSON dict (``fig.to_dict()``) or JSON text."""
        try:
            doc = json.loads(figure) if isinstance(figure, str) else dict(figure)
        except (TypeError, ValueError) as exc:
            raise WriterError(f"metric {name!r}: plotly figure is not JSON ({exc})") from None
        if not isinstance(doc, dict):
            raise WriterError(f"metric {name!r}: a plotly figure is a JSON object, not {doc!r:.40}")
        proto, handle = self._new_metric(name, MetricType.PLOTLY, options)
        struct = struct_pb2.Struct()
        struct.update(doc)
        proto.metric_values.plotly_metric_values.json.CopyFrom(struct)
        return handle

    @_all_or_nothing
    def image(
        self,
        name: str,
        image: MetricsData,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """An image file written beside metrics.binproto (see `data.external_file`)."""
        _require_kind(name, image, SeriesKind.EXTERNAL_FILE)
        proto, handle = self._new_metric(name, MetricType.IMAGE, options)
        proto.metric_values.image_metric_values.image_data_id.CopyFrom(self._ref(image))
        return handle

    @_all_or_nothing
    def image_list(
        self,
        name: str,
        images: Sequence[MetricsData],
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """Several image files shown together."""
        if not images:
            raise WriterError(f"metric {name!r}: an image list needs at least one image")
        for image in images:
            _require_kind(name, image, SeriesKind.EXTERNAL_FILE)
        proto, handle = self._new_metric(name, MetricType.IMAGE_LIST, options)
        for image in images:
            proto.metric_values.image_list_metric_values.image_data_ids.append(self._ref(image))
        return handle

    # ---- events ----

    def event(
        self,
        name: str,
        *,
        timestamp: TimestampLike,
        relative: bool = False,
        metrics: Sequence[MetricHandle] = (),
        status: MetricStatus = MetricStatus.PASSED,
        importance: MetricImportance = MetricImportance.MEDIUM,
        description: str = "",
        tags: Sequence[str] = (),
    ) -> None:
        """An event at a point in the test, optionally with metrics written with `event=True`.

        All events of one output share one timestamp type (absolute or relative)."""
        if not name or any(e.name == name for e in self._events):
            raise WriterError(f"event names must be non-empty and unique: {name!r}")
        if _data.timestamp_ns(timestamp) < 0:
            raise WriterError(f"event {name!r}: timestamps before 1970 (or negative) are refused")
        kind = pb.RELATIVE_TIMESTAMP if relative else pb.ABSOLUTE_TIMESTAMP
        if self._events and self._events[0].timestamp_type != kind:
            raise WriterError(f"event {name!r}: all events must be all absolute or all relative")
        names = [m.name for m in metrics]
        if len(set(names)) != len(names):
            raise WriterError(f"event {name!r}: its metrics need unique names")
        for m in metrics:
            if not m.proto.event_metric:
                raise WriterError(
                    f"event {name!r}: metric {m.name!r} was not written with event=True"
                )
        self._events.append(
            pb.Event(
                event_id=pb.EventId(id=_uuid_proto(self._ids.event_id(name))),
                name=name,
                description=description,
                tags=list(tags),
                metrics=[pb.MetricId(id=_uuid_proto(m.id)) for m in metrics],
                status=pb.MetricStatus.ValueType(MetricStatus(status)),
                timestamp=_timestamp_proto(_data.timestamp_ns(timestamp)),
                timestamp_type=kind,
                importance=pb.MetricImportance.ValueType(MetricImportance(importance)),
            )
        )

    # ---- status and output ----

    def override_status(self, status: MetricStatus | None) -> None:
        """Set the output's overall status instead of computing it (None: compute again)."""
        self._status_override = None if status is None else MetricStatus(status)

    @property
    def status(self) -> MetricStatus:
        """The overall status: the override, else FAIL_BLOCK if any metric blocks, else
        FAIL_WARN if any warns, else PASSED."""
        if self._status_override is not None:
            return self._status_override
        statuses = {m.status for m in self._metrics}
        if pb.FAIL_BLOCK_METRIC_STATUS in statuses:
            return MetricStatus.FAIL_BLOCK
        if pb.FAIL_WARN_METRIC_STATUS in statuses:
            return MetricStatus.FAIL_WARN
        return MetricStatus.PASSED

    def has_metric(self, name: str) -> bool:
        """Whether a (non-event) metric of this name was written."""
        return name in self._metric_names

    @property
    def metrics(self) -> list[MetricHandle]:
        return [MetricHandle(self, m) for m in self._metrics]

    def to_proto(self) -> pb.JobMetrics:
        """The JobMetrics message as it stands now."""
        status = pb.MetricStatus.ValueType(self.status)
        msg = pb.JobMetrics(
            job_id=pb.JobId(id=_uuid_proto(self.job_id)),
            metrics_status=status,
            events=self._events,
        )
        msg.job_level_metrics.metrics_status = status
        msg.job_level_metrics.metrics.extend(self._metrics)
        msg.metrics_data.extend(data_to_proto(d, self._data_ids) for d in self._data.values())
        return msg

    def serialize(self) -> bytes:
        # Deterministic serialization orders map entries, so equal inputs give equal bytes.
        return self.to_proto().SerializeToString(deterministic=True)

    def write(self, path: str | Path, *, validate: bool = True) -> Path:
        """Validate, then write metrics.binproto atomically; on an invalid output nothing
        is written and InvalidMetricsError says which metric breaks which rule."""
        msg = self.to_proto()
        if validate:
            from stook.sdk._validate import validate_job_metrics

            validate_job_metrics(msg)
        return write_atomic(path, msg.SerializeToString(deterministic=True))


# ---- conversion helpers ----


def _uuid_proto(value: uuid.UUID) -> uuid_pb2.UUID:
    return uuid_pb2.UUID(data=str(value))


def _timestamp_proto(ns: int) -> timestamp_pb2.Timestamp:
    seconds, nanos = divmod(ns, 1_000_000_000)
    return timestamp_pb2.Timestamp(seconds=seconds, nanos=nanos)


def _failure(above: float | None, below: float | None) -> pb.DoubleFailureDefinition:
    f = pb.DoubleFailureDefinition()
    if above is not None:
        f.fails_above = above
    if below is not None:
        f.fails_below = below
    return f


def _fill_series(series: pb.Series, kind: SeriesKind, values: Sequence[Any]) -> None:
    field = SERIES_FIELD[kind]
    target = getattr(series, field)
    target.SetInParent()
    match kind:
        case SeriesKind.DOUBLE if isinstance(values, array):
            # Parsing the packed wire form is a memcpy in C; extend() would box every value.
            raw = values.tobytes()
            target.MergeFromString(b"\x0a" + _varint(len(raw)) + raw)
        case SeriesKind.TIMESTAMP:
            target.series.extend(_timestamp_proto(v) for v in values)
        case SeriesKind.UUID:
            target.series.extend(uuid_pb2.UUID(data=v) for v in values)
        case _:
            target.series.extend(values)


def _varint(n: int) -> bytes:
    out = bytearray()
    while n > 0x7F:
        out.append((n & 0x7F) | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


def data_to_proto(data: MetricsData, ids: Mapping[str, uuid.UUID]) -> pb.MetricsData:
    """The proto of one metrics-data item, with IDs as the writer assigned them."""
    msg = pb.MetricsData(
        metrics_data_id=pb.MetricsDataId(id=_uuid_proto(ids[data.name])),
        data_type=data_type_of(data.kind, indexed=data.indexed),
        name=data.name,
        unit=data.unit,
    )
    if data.kind is SeriesKind.EXTERNAL_FILE:
        msg.external_file.path = data.external_path or ""
        return msg
    if data.index is not None:
        msg.is_indexed = True
        msg.index_data_id.CopyFrom(pb.MetricsDataId(id=_uuid_proto(ids[data.index.name])))
        msg.index_data_type = data_type_of(data.index.kind, indexed=data.index.indexed)
    if isinstance(data.values, dict):
        msg.is_per_category = True
        msg.category_names.extend(data.values)
        for category, values in data.values.items():
            _fill_series(msg.series_per_category.category_to_series[category], data.kind, values)
    else:
        _fill_series(msg.series, data.kind, data.values or [])
    return msg


def histogram_buckets(
    name: str, buckets: int | Sequence[Bucket], lower: float | None, upper: float | None
) -> list[Bucket]:
    """Equal-width buckets from a count and bounds, or explicit ones checked for contiguity."""
    if isinstance(buckets, int):
        if lower is None or upper is None or not lower < upper or buckets < 1:
            raise WriterError(
                f"metric {name!r}: {buckets} buckets need lower < upper and a count of at least 1"
            )
        width = (upper - lower) / buckets
        # The first and last edges are the bounds themselves (0 * inf would be NaN).
        edges = [lower, *(lower + i * width for i in range(1, buckets)), upper]
        if not all(math.isfinite(e) for e in edges) or any(
            a >= b for a, b in itertools.pairwise(edges)
        ):
            raise WriterError(
                f"metric {name!r}: {buckets} buckets between {lower} and {upper} cannot be told "
                "apart in floating point; use fewer buckets or wider bounds"
            )
        return list(itertools.pairwise(edges))
    pairs = [(float(lo), float(hi)) for lo, hi in buckets]
    if not pairs:
        raise WriterError(f"metric {name!r}: a histogram needs at least one bucket")
    for i, (lo, hi) in enumerate(pairs):
        if not lo < hi:
            raise WriterError(f"metric {name!r}: bucket {i} has lower {lo} >= upper {hi}")
        if i and pairs[i - 1][1] != lo:
            raise WriterError(
                f"metric {name!r}: bucket {i} starts at {lo} but bucket {i - 1} ends at "
                f"{pairs[i - 1][1]}"
            )
    if (lower is not None and lower != pairs[0][0]) or (
        upper is not None and upper != pairs[-1][1]
    ):
        raise WriterError(f"metric {name!r}: lower/upper must match the first and last bucket")
    return pairs


def _check_not_empty(data: MetricsData) -> None:
    # The platform refuses a series (or a category) with no elements.
    if data.kind is SeriesKind.EXTERNAL_FILE:
        return
    shape = data.shape()
    lengths = shape.values() if isinstance(shape, dict) else [shape]
    if any(n == 0 for n in lengths):
        raise WriterError(f"metrics data {data.name!r} is empty; the platform refuses empty series")


def _require_kind(
    metric: str, data: MetricsData, kind: SeriesKind, *, index: SeriesKind | None = None
) -> None:
    if data.kind is not kind:
        raise WriterError(
            f"metric {metric!r}: data {data.name!r} holds {data.kind.value} values, "
            f"{kind.value} needed"
        )
    if index is not None and (data.index is None or data.index.kind is not index):
        raise WriterError(
            f"metric {metric!r}: data {data.name!r} must be indexed by a {index.value} series"
        )


def _matching(
    metric: str,
    series: list[MetricsData],
    statuses: Sequence[MetricsData] | None,
    status: MetricStatus,
    make: Any,
) -> list[MetricsData]:
    if statuses is None:
        return [make(s, None, status) for s in series]
    if len(statuses) != len(series):
        raise WriterError(f"metric {metric!r}: give one status series per value series")
    for s, st in zip(series, statuses, strict=True):
        _require_kind(metric, st, SeriesKind.STATUS)
        if st.shape() != s.shape() or st.index is not s.index:
            raise WriterError(
                f"metric {metric!r}: status series {st.name!r} must have the shape and index "
                f"of {s.name!r}"
            )
    return list(statuses)


def _legend(metric: str, legend: Sequence[str] | None, series: list[MetricsData]) -> list[str]:
    if legend is None:
        return [s.name for s in series]
    if len(legend) != len(series):
        raise WriterError(f"metric {metric!r}: give one legend name per series")
    return list(legend)


def _flat_strings(data: MetricsData) -> list[str]:
    if isinstance(data.values, dict):
        return [str(v) for vs in data.values.values() for v in vs]
    return [str(v) for v in data.values or []]


def _canonical_uuid(metric: str, value: object) -> str:
    try:
        return str(value if isinstance(value, uuid.UUID) else uuid.UUID(str(value)))
    except ValueError:
        raise WriterError(f"metric {metric!r}: {value!r} is not a UUID") from None


def _check_color(metric: str, color: str) -> None:
    body = color[1:] if color.startswith("#") else ""
    if len(body) not in (6, 8) or any(c not in "0123456789abcdefABCDEF" for c in body):
        raise WriterError(f"metric {metric!r}: colour {color!r} is not #RRGGBB or #RRGGBBAA")
