"""MetricsWriter: build one JobMetrics output (test, batch or report metrics) fluently.

Each metric method checks its arguments, builds its proto at once and returns a
`MetricHandle` whose setters chain::

    w = MetricsWriter(job_id, deterministic=True)
    w.scalar("Max speed", 31.2, unit="m/s").describe("Peak speed").importance(HIGH)
    w.histogram("Speed distribution", data.doubles("speeds", v), buckets=20, lower=0, upper=40)
    w.write("/tmp/resim/outputs/metrics.binproto")

This module owns the one method per metric type: which data kinds it takes and which
fields of the metric's values it fills. What every type shares -- metrics data and
their index chains, IDs, events, the overall status, the protobuf encoding, writing the
file -- is `OutputBuilder`'s (in `_output`).

The argument checks below (`require_kind`, `matching_statuses`, `check_color`, ...)
each raise a `WriterError` that names the metric before anything is written, so that a
mistake shows where it is made rather than as a platform refusal of the finished
output: they check what the SDK's types cannot (data kinds and indexes, matching shapes
and counts, UUID and colour spellings). `histogram_buckets` is the one place that turns
"N buckets between lower and upper" or a list of explicit pairs into checked,
contiguous buckets: the ``histogram`` method calls it, and so do the aggregations
(`MergedHistogram` bins its values on the edges the histogram metric will carry,
`ScalarDefaults` asks it which bucket counts floating point can tell apart).
"""

from __future__ import annotations

import itertools
import json
import math
import uuid
from collections.abc import Mapping, Sequence
from typing import Any, Unpack

from google.protobuf import struct_pb2

from stook.proto import metrics_pb2 as pb
from stook.sdk import _data
from stook.sdk._data import MetricsData, TimestampLike, UuidLike
from stook.sdk._enums import MetricStatus, MetricType, SeriesKind
from stook.sdk._errors import WriterError
from stook.sdk._output import (
    FailureDefinition,
    MetricHandle,
    MetricOptions,
    OutputBuilder,
    all_or_nothing,
    failure_proto,
    status_of,
    timestamp_proto,
)

Bucket = tuple[float, float]


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


def require_kind(
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


def matching_statuses(
    metric: str,
    series: list[MetricsData],
    statuses: Sequence[MetricsData] | None,
    status: MetricStatus,
    make: Any,
) -> list[MetricsData]:
    """The status series of each value series: the given ones, checked, or made by `make`."""
    if statuses is None:
        return [make(s, None, status) for s in series]
    if len(statuses) != len(series):
        raise WriterError(f"metric {metric!r}: give one status series per value series")
    for s, st in zip(series, statuses, strict=True):
        require_kind(metric, st, SeriesKind.STATUS)
        if st.shape() != s.shape() or st.index is not s.index:
            raise WriterError(
                f"metric {metric!r}: status series {st.name!r} must have the shape and index "
                f"of {s.name!r}"
            )
    return list(statuses)


def legend_names(metric: str, names: Sequence[str] | None, series: list[MetricsData]) -> list[str]:
    if names is None:
        return [s.name for s in series]
    if len(names) != len(series):
        raise WriterError(f"metric {metric!r}: give one legend name per series")
    return list(names)


def flat_strings(data: MetricsData) -> list[str]:
    if isinstance(data.values, dict):
        return [str(v) for vs in data.values.values() for v in vs]
    return [str(v) for v in data.values or []]


def canonical_uuid(metric: str, value: object) -> str:
    try:
        return str(value if isinstance(value, uuid.UUID) else uuid.UUID(str(value)))
    except ValueError:
        raise WriterError(f"metric {metric!r}: {value!r} is not a UUID") from None


def check_color(metric: str, color: str) -> None:
    body = color[1:] if color.startswith("#") else ""
    if len(body) not in (6, 8) or any(c not in "0123456789abcdefABCDEF" for c in body):
        raise WriterError(f"metric {metric!r}: colour {color!r} is not #RRGGBB or #RRGGBBAA")


class MetricsWriter(OutputBuilder):
    """Collects metrics and metrics data for one job (or batch, or report) output."""

    # ---- status series: given ones are checked, missing ones generated ----

    def _status_ref(
        self,
        metric: str,
        values: MetricsData,
        statuses: MetricsData | None,
        options: MetricOptions,
    ) -> pb.MetricsDataId:
        """The reference to the status series of a single value series."""
        if statuses is not None:
            matching_statuses(metric, [values], [statuses], status_of(options), self._statuses_for)
        return self._ref(self._statuses_for(values, statuses, status_of(options)))

    def _status_series(
        self,
        metric: str,
        series: list[MetricsData],
        statuses: Sequence[MetricsData] | None,
        options: MetricOptions,
    ) -> list[MetricsData]:
        """The status series of each value series, in order."""
        return matching_statuses(metric, series, statuses, status_of(options), self._statuses_for)

    # ---- metrics: one method per type ----

    @all_or_nothing
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
            values.failure_definition.CopyFrom(failure_proto(fails_above, fails_below))
        return handle

    @all_or_nothing
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
        require_kind(name, values, SeriesKind.DOUBLE)
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
            mv.timestamp_index.CopyFrom(timestamp_proto(_data.timestamp_ns(index)))  # type: ignore[arg-type]
        elif kind is SeriesKind.UUID:
            mv.uuid_index.data = canonical_uuid(name, index)
        elif kind is SeriesKind.STRING:
            mv.string_index = str(index)
        else:
            raise WriterError(
                f"metric {name!r}: index {index!r} needs values indexed by timestamps, UUIDs "
                "or strings"
            )
        if failure is not None:
            mv.failure_definition.CopyFrom(failure_proto(*failure))
        return handle

    @all_or_nothing
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
            require_kind(name, s, SeriesKind.DOUBLE, index=SeriesKind.TIMESTAMP)
        status_series = self._status_series(name, series, statuses, options)
        fails = list(failures) if failures is not None else [(None, None)] * len(series)
        if len(fails) != len(series):
            raise WriterError(f"metric {name!r}: give one failure definition per series")
        proto, handle = self._new_metric(name, MetricType.DOUBLE_OVER_TIME, options)
        mv = proto.metric_values.double_over_time_metric_values
        for s, st, f in zip(series, status_series, fails, strict=True):
            mv.doubles_over_time_data_id.append(self._ref(s))
            mv.statuses_over_time_data_id.append(self._ref(st))
            mv.failure_definition.append(failure_proto(*f))
        if start_time is not None:
            mv.start_time.CopyFrom(timestamp_proto(_data.timestamp_ns(start_time)))
        if end_time is not None:
            mv.end_time.CopyFrom(timestamp_proto(_data.timestamp_ns(end_time)))
        if y_axis_name is not None:
            mv.y_axis_name = y_axis_name
        mv.legend_series_names.extend(legend_names(name, legend, series))
        return handle

    @all_or_nothing
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
            require_kind(name, xi, SeriesKind.DOUBLE)
            require_kind(name, yi, SeriesKind.DOUBLE)
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
        status_series = self._status_series(name, xs, statuses, options)
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
        mv.legend_series_names.extend(legend_names(name, legend, ys))
        return handle

    @all_or_nothing
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
            require_kind(name, s, SeriesKind.DOUBLE, index=SeriesKind.STRING)
        status_series = self._status_series(name, series, statuses, options)
        proto, handle = self._new_metric(name, MetricType.BAR_CHART, options)
        mv = proto.metric_values.bar_chart_metric_values
        for s, st in zip(series, status_series, strict=True):
            mv.values_data_id.append(self._ref(s))
            mv.statuses_data_id.append(self._ref(st))
        mv.legend_series_names.extend(legend_names(name, legend, series))
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

    @all_or_nothing
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
            require_kind(name, s, SeriesKind.STRING, index=SeriesKind.TIMESTAMP)
            seen.update(flat_strings(s))
        allowed = list(states_set) if states_set is not None else sorted(seen)
        if not seen.issubset(allowed):
            raise WriterError(
                f"metric {name!r}: states {sorted(seen - set(allowed))} are not in the states set"
            )
        if not set(failure_states).issubset(allowed):
            raise WriterError(f"metric {name!r}: failure states must be in the states set")
        status_series = self._status_series(name, series, statuses, options)
        proto, handle = self._new_metric(name, MetricType.STATES_OVER_TIME, options)
        mv = proto.metric_values.states_over_time_metric_values
        for s, st in zip(series, status_series, strict=True):
            mv.states_over_time_data_id.append(self._ref(s))
            mv.statuses_over_time_data_id.append(self._ref(st))
        mv.states_set.extend(allowed)
        mv.failure_states.extend(failure_states)
        mv.legend_series_names.extend(legend_names(name, legend, series))
        return handle

    @all_or_nothing
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
        require_kind(name, values, SeriesKind.DOUBLE)
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

    @all_or_nothing
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
            require_kind(name, t, SeriesKind.TIMESTAMP, index=SeriesKind.UUID)
            require_kind(name, v, SeriesKind.DOUBLE, index=SeriesKind.UUID)
            if t.index is not v.index:
                raise WriterError(f"metric {name!r}: {t.name!r} and {v.name!r} need one index")
        for color in colors:
            check_color(name, color)
        status_series = self._status_series(name, vs, statuses, options)
        proto, handle = self._new_metric(name, MetricType.BATCHWISE_BAR_CHART, options)
        mv = proto.metric_values.batchwise_bar_chart_metric_values
        for t, v, st in zip(ts, vs, status_series, strict=True):
            mv.times_data_id.append(self._ref(t))
            mv.values_data_id.append(self._ref(v))
            mv.statuses_data_id.append(self._ref(st))
        mv.categories.extend(categories)
        mv.colors.extend(colors)
        mv.project_id.data = canonical_uuid(name, project_id)
        if x_axis_name is not None:
            mv.x_axis_name = x_axis_name
        if y_axis_name is not None:
            mv.y_axis_name = y_axis_name
        if stack_bars is not None:
            mv.stack_bars = stack_bars
        return handle

    @all_or_nothing
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

    @all_or_nothing
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

    @all_or_nothing
    def image(
        self,
        name: str,
        image: MetricsData,
        **options: Unpack[MetricOptions],
    ) -> MetricHandle:
        """An image file written beside metrics.binproto (see `data.external_file`)."""
        require_kind(name, image, SeriesKind.EXTERNAL_FILE)
        proto, handle = self._new_metric(name, MetricType.IMAGE, options)
        proto.metric_values.image_metric_values.image_data_id.CopyFrom(self._ref(image))
        return handle

    @all_or_nothing
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
            require_kind(name, image, SeriesKind.EXTERNAL_FILE)
        proto, handle = self._new_metric(name, MetricType.IMAGE_LIST, options)
        for image in images:
            proto.metric_values.image_list_metric_values.image_data_ids.append(self._ref(image))
        return handle
