"""stook's own validator of a JobMetrics message.

It accepts and refuses exactly the messages that ReSim's platform validator
(``resim.metrics.proto.validate_metrics_proto.validate_job_metrics``, version
1.6.0) accepts and refuses, so an output that passes here will be ingested. Unlike
ReSim's, it collects every problem and names the metric, data or event and the
rule broken. The conformance tests check the agreement on generated messages.

`OutputChecker` holds the rules of the output as a whole (IDs, names, the fields every
metric has, metrics data and indexes, events) with the data lookups all rules share.
`ValuesChecker` holds the rules of each metric type's values: one method per field of
the ``MetricValues`` oneof, named after it, plus the pairing rules those share (a value
series with its status series, lists of equal length, external files). It reports
through the `OutputChecker`, so that every problem lands in one list in message order.
ReSim's rules speak of "a timestamp series, indexed or not", "an indexed double series"
and so on: the data type sets below (`TIMESTAMPS`, `INDEXED_DOUBLE`, ...) are those
groups, and `type_name` spells a data type in a problem as the schema does.

Deliberate sameness with ReSim, odd as some of it is:

* IDs are checked with ``uuid.UUID(hex=...)``, which also accepts braces,
  ``urn:uuid:``, missing hyphens, upper case, even ``0x`` and ``_`` inside (it ends
  in ``int(text, 16)``). References are matched on the exact text, though, so a
  reference spelt differently from the ID it means is a missing reference.
* Enums are only refused when unset (0); unknown values pass. A metric whose type
  is unknown must carry image values, as ReSim treats every type it does not
  list as IMAGE.
* A histogram with no buckets is always refused (no bucket ends at upper_bound).
* Two data items that both hold an external file "agree" as value and index.
* Event IDs need not be unique, and event metrics need not be used by an event
  (ReSim computes that and ignores the result).
* Where ReSim would crash on a message rather than refuse it, the message is
  refused here; in ReSim 1.6.0 every such path is already guarded by a refusal.
"""

from __future__ import annotations

import math
import re
import uuid
from collections.abc import Set
from dataclasses import dataclass, field

from google.protobuf.timestamp_pb2 import Timestamp

from stook.proto import metrics_pb2 as pb
from stook.proto import uuid_pb2
from stook.sdk._errors import InvalidMetricsError, Problem

TIMESTAMPS = frozenset({pb.TIMESTAMP_SERIES_DATA_TYPE, pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE})
UUIDS = frozenset({pb.UUID_SERIES_DATA_TYPE, pb.INDEXED_UUID_SERIES_DATA_TYPE})
STRINGS = frozenset({pb.STRING_SERIES_DATA_TYPE, pb.INDEXED_STRING_SERIES_DATA_TYPE})
DOUBLES = frozenset({pb.DOUBLE_SERIES_DATA_TYPE, pb.INDEXED_DOUBLE_SERIES_DATA_TYPE})
STATUSES = frozenset({pb.METRIC_STATUS_SERIES_DATA_TYPE, pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE})
INDEXED = frozenset(
    {
        pb.INDEXED_DOUBLE_SERIES_DATA_TYPE,
        pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE,
        pb.INDEXED_UUID_SERIES_DATA_TYPE,
        pb.INDEXED_STRING_SERIES_DATA_TYPE,
        pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE,
    }
)
ANY_SERIES = TIMESTAMPS | UUIDS | STRINGS | DOUBLES | STATUSES
INDEXED_DOUBLE = frozenset({pb.INDEXED_DOUBLE_SERIES_DATA_TYPE})


def type_name(value: int) -> str:
    try:
        return pb.MetricsDataType.Name(pb.MetricsDataType.ValueType(value))
    except ValueError:
        return f"unknown data type {value}"


def type_names(values: Set[int]) -> str:
    return " or ".join(sorted(type_name(v) for v in values))


__all__ = ["find_problems", "validate_job_metrics"]


def validate_job_metrics(msg: pb.JobMetrics) -> None:
    """Raise InvalidMetricsError listing every problem, if there is any."""
    problems = find_problems(msg)
    if problems:
        raise InvalidMetricsError(problems)


def find_problems(msg: pb.JobMetrics) -> list[Problem]:
    """Every rule the output breaks, in message order; empty if it is valid."""
    checker = OutputChecker(msg)
    checker.run()
    return checker.problems


# The Series element field a data type requires. Like ReSim, any type not
# listed (statuses, and unknown values) requires statuses.
_ELEMENT_FIELD: dict[int, str] = {
    **dict.fromkeys(DOUBLES, "doubles"),
    **dict.fromkeys(TIMESTAMPS, "timestamps"),
    **dict.fromkeys(UUIDS, "uuids"),
    **dict.fromkeys(STRINGS, "strings"),
}

# The metric_values field each metric type requires; unknown types need image values.
_VALUES_FIELD: dict[int, str] = {
    pb.DOUBLE_SUMMARY_METRIC_TYPE: "double_metric_values",
    pb.DOUBLE_OVER_TIME_METRIC_TYPE: "double_over_time_metric_values",
    pb.LINE_PLOT_METRIC_TYPE: "line_plot_metric_values",
    pb.BAR_CHART_METRIC_TYPE: "bar_chart_metric_values",
    pb.BATCHWISE_BAR_CHART_METRIC_TYPE: "batchwise_bar_chart_metric_values",
    pb.STATES_OVER_TIME_METRIC_TYPE: "states_over_time_metric_values",
    pb.HISTOGRAM_METRIC_TYPE: "histogram_metric_values",
    pb.SCALAR_METRIC_TYPE: "scalar_metric_values",
    pb.PLOTLY_METRIC_TYPE: "plotly_metric_values",
    pb.TEXT_METRIC_TYPE: "text_metric_values",
    pb.IMAGE_LIST_METRIC_TYPE: "image_list_metric_values",
}


def _is_uuid(text: str) -> bool:
    try:
        uuid.UUID(hex=text)
    except ValueError:
        return False
    return True


def _named(kind: str, name: str, ident: str) -> str:
    shown_id = f"id {ident}" if ident else "no id"
    return f"{kind} {name!r} ({shown_id})" if name else f"unnamed {kind} ({shown_id})"


def _series_length(series: pb.Series) -> int | None:
    """Number of elements, or None if the series holds no element type at all."""
    which = series.WhichOneof("series")
    if which is None:
        return None
    container: pb.DoubleSeries = getattr(series, which)
    return len(container.series)


# ---------------------------------------------------------------- the checker


@dataclass
class OutputChecker:
    """The rules of one output as a whole; collects every problem in message order."""

    msg: pb.JobMetrics
    problems: list[Problem] = field(default_factory=list)
    data_by_id: dict[str, pb.MetricsData] = field(default_factory=dict)
    metrics_by_id: dict[str, pb.Metric] = field(default_factory=dict)

    def add(self, where: str, rule: str) -> None:
        self.problems.append(Problem(where, rule))

    def check_id(self, where: str, what: str, ident: uuid_pb2.UUID) -> bool:
        if _is_uuid(ident.data):
            return True
        shown = f"{ident.data!r} is not a valid UUID" if ident.data else "is missing"
        self.add(where, f"{what} {shown}")
        return False

    def run(self) -> None:
        msg = self.msg
        self.index_ids()
        self.check_id("output", "job id", msg.job_id.id)
        for metric in msg.job_level_metrics.metrics:
            self.check_metric(metric)
        if msg.job_level_metrics.metrics_status == pb.NO_METRIC_STATUS:
            self.add("output", "the job-level metric collection has no status")
        if msg.metrics_status == pb.NO_METRIC_STATUS:
            self.add("output", "the output has no overall status")
        self.check_metric_names_and_jobs()
        seen_data_names: set[str] = set()
        for data in msg.metrics_data:
            if data.name in seen_data_names:
                where = _named("data", data.name, data.metrics_data_id.id.data)
                self.add(where, "another metrics data has the same name")
            seen_data_names.add(data.name)
            self.check_data(data)
        self.check_events()

    def index_ids(self) -> None:
        for data in self.msg.metrics_data:
            key = data.metrics_data_id.id.data
            where = _named("data", data.name, key)
            if self.check_id(where, "id", data.metrics_data_id.id) and key in self.data_by_id:
                self.add(where, "another metrics data has the same id")
            self.data_by_id.setdefault(key, data)
        for metric in self.msg.job_level_metrics.metrics:
            key = metric.metric_id.id.data
            where = _named("metric", metric.name, key)
            if self.check_id(where, "id", metric.metric_id.id) and key in self.metrics_by_id:
                self.add(where, "another metric has the same id")
            self.metrics_by_id.setdefault(key, metric)
        # Event IDs must be UUIDs but, as in ReSim, may repeat.
        for event in self.msg.events:
            self.check_id(
                _named("event", event.name, event.event_id.id.data), "id", event.event_id.id
            )

    # ------------------------------------------------------------ metrics

    def check_metric(self, metric: pb.Metric) -> None:
        where = _named("metric", metric.name, metric.metric_id.id.data)
        if not metric.name:
            self.add(where, "a metric must have a name")
        if metric.type == pb.NO_METRIC_TYPE:
            self.add(where, "the metric type is unset")
        if metric.status == pb.NO_METRIC_STATUS:
            self.add(where, "the metric status is unset")
        ValuesChecker(self, where).check(metric.metric_values)
        if metric.importance == pb.NO_SPECIFIED_IMPORTANCE:
            self.add(where, "the metric importance is unset")
        if not metric.HasField("job_id"):
            self.add(where, "the metric has no job id")
        else:
            self.check_id(where, "job id", metric.job_id.id)
        for n, tag in enumerate(metric.tags):
            if not tag.key or not tag.value:
                self.add(where, f"tag {n} ({tag.key!r}: {tag.value!r}) needs a key and a value")
        wanted = _VALUES_FIELD.get(metric.type, "image_metric_values")
        held = metric.metric_values.WhichOneof("metric_values")
        if metric.type != pb.NO_METRIC_TYPE and held != wanted:
            type_name = (
                pb.MetricType.Name(metric.type)
                if metric.type in pb.MetricType.values()
                else f"unknown type {metric.type}"
            )
            self.add(
                where,
                f"a metric of type {type_name} needs {wanted}, but it has {held or 'no values'}",
            )

    def check_metric_names_and_jobs(self) -> None:
        seen: set[str] = set()
        for metric in self.msg.job_level_metrics.metrics:
            where = _named("metric", metric.name, metric.metric_id.id.data)
            if not metric.event_metric:
                if metric.name in seen:
                    self.add(where, "another metric (not an event metric) has the same name")
                seen.add(metric.name)
            # Message equality, as ReSim compares: the exact ID text must match.
            if metric.job_id != self.msg.job_id:
                self.add(
                    where,
                    f"the metric's job id {metric.job_id.id.data!r} differs from "
                    f"the output's {self.msg.job_id.id.data!r}",
                )

    # ------------------------------------------------------------ data

    def check_data(self, data: pb.MetricsData) -> None:
        where = _named("data", data.name, data.metrics_data_id.id.data)
        if data.data_type == pb.NO_DATA_TYPE:
            self.add(where, "the data type is unset")
        if data.data_type == pb.EXTERNAL_FILE_DATA_TYPE:
            if not data.HasField("external_file"):
                self.add(where, "external file data must hold an external file")
            elif not data.external_file.path:
                self.add(where, "the external file has an empty path")
        elif data.is_per_category:
            self.check_per_category(where, data)
        elif not data.HasField("series"):
            self.add(where, "data that is not per category must hold a series")
        else:
            self.check_series(where, "the series", data.series, data.data_type)
        if data.is_indexed:
            self.check_index(where, data)

    def check_per_category(self, where: str, data: pb.MetricsData) -> None:
        if not data.HasField("series_per_category"):
            self.add(where, "per-category data must hold series per category")
        by_category = data.series_per_category.category_to_series
        for category in sorted(by_category):
            self.check_series(
                where, f"the series of category {category!r}", by_category[category], data.data_type
            )
        if not data.category_names:
            self.add(where, "per-category data must list its category names")
        declared, present = set(data.category_names), set(by_category)
        if declared != present:
            self.add(
                where,
                "the category names must be exactly the categories with series "
                f"(declared only: {sorted(declared - present)}, "
                f"series only: {sorted(present - declared)})",
            )

    def check_series(self, where: str, what: str, series: pb.Series, data_type: int) -> None:
        length = _series_length(series)
        if length is None:
            self.add(where, f"{what} holds no values of any type")
            return
        if length == 0:
            self.add(where, f"{what} is empty")
        wanted = _ELEMENT_FIELD.get(data_type, "statuses")
        held = series.WhichOneof("series")
        if held != wanted:
            self.add(
                where, f"{what} holds {held}, but data type {type_name(data_type)} needs {wanted}"
            )

    def check_index(self, where: str, data: pb.MetricsData) -> None:
        index = self.find_data(where, "index", data.index_data_id)
        if index is None:
            return
        self.check_agree(where, "its index", data, index)
        if data.index_data_type != index.data_type:
            self.add(
                where,
                f"index_data_type is {type_name(data.index_data_type)}, "
                f"but the index data {index.name!r} is {type_name(index.data_type)}",
            )

    def find_data(self, where: str, role: str, ref: pb.MetricsDataId) -> pb.MetricsData | None:
        """The referenced data, or None after adding the problem."""
        if not self.check_id(where, f"{role} data id", ref.id):
            return None
        found = self.data_by_id.get(ref.id.data)
        if found is None:
            self.add(where, f"{role} data {ref.id.data} is not in the output")
        return found

    def check_agree(
        self, where: str, other_role: str, data: pb.MetricsData, other: pb.MetricsData
    ) -> None:
        """ReSim's rule that two data have the same shape: same oneof, same lengths."""
        held, other_held = data.WhichOneof("data"), other.WhichOneof("data")
        prefix = f"{data.name!r} and {other_role} {other.name!r}"
        if held is None:
            self.add(where, f"{data.name!r} holds no data, so it cannot match {other_role}")
            return
        if held != other_held:
            self.add(where, f"{prefix} must both hold {held} (the other holds {other_held})")
            return
        if held == "series":
            a, b = _series_length(data.series), _series_length(other.series)
            if a is None or b is None:
                self.add(where, f"{prefix}: a series holds no values of any type")
            elif a != b:
                self.add(where, f"{prefix} must have the same length ({a} and {b})")
            return
        # Series per category, or (as ReSim treats it) external files: the
        # per-category maps, empty for external files, must match.
        mine = data.series_per_category.category_to_series
        theirs = other.series_per_category.category_to_series
        if set(mine) != set(theirs):
            self.add(
                where,
                f"{prefix} must have the same categories ({sorted(mine)} and {sorted(theirs)})",
            )
            return
        for category in sorted(mine):
            a, b = _series_length(mine[category]), _series_length(theirs[category])
            if a is None or b is None:
                self.add(where, f"{prefix}: category {category!r} holds no values of any type")
            elif a != b:
                self.add(
                    where,
                    f"{prefix} must have the same length in category {category!r} ({a} and {b})",
                )

    # ------------------------------------------------------------ events

    def check_events(self) -> None:
        events = self.msg.events
        if not events:
            return
        first_type = events[0].timestamp_type
        seen: set[str] = set()
        for event in events:
            where = _named("event", event.name, event.event_id.id.data)
            if event.name in seen:
                self.add(where, "another event has the same name")
            seen.add(event.name)
            if event.timestamp_type != first_type:
                self.add(where, "all events of an output must have the same timestamp type")
            self.check_event(where, event)

    def check_event(self, where: str, event: pb.Event) -> None:
        if not event.name:
            self.add(where, "an event must have a name")
        names: set[str] = set()
        for ref in event.metrics:
            if not self.check_id(where, "metric id", ref.id):
                continue
            metric = self.metrics_by_id.get(ref.id.data)
            if metric is None:
                self.add(where, f"metric {ref.id.data} is not in the output")
                continue
            if metric.name in names:
                self.add(where, f"the event lists two metrics named {metric.name!r}")
            names.add(metric.name)
        if event.status == pb.NO_METRIC_STATUS:
            self.add(where, "the event status is unset")
        if event.timestamp_type == pb.NO_TYPE:
            self.add(where, "the event timestamp type is unset")
        self.check_timestamp(where, "the event timestamp", event.timestamp)
        if event.importance == pb.NO_SPECIFIED_IMPORTANCE:
            self.add(where, "the event importance is unset")

    def check_timestamp(self, where: str, what: str, ts: Timestamp) -> None:
        if ts.seconds < 0:
            self.add(where, f"{what} has negative seconds ({ts.seconds})")
        if not 0 <= ts.nanos < 1_000_000_000:
            self.add(where, f"{what} nanos must be in [0, 1e9) (got {ts.nanos})")


# ReSim's pattern is `^#([0-9a-fA-F]{2}){3,4}$` with re.search, and `$` also
# matches before one final newline; \n?\Z keeps that.
_HEX_COLOR = re.compile(r"\A#(?:[0-9a-fA-F]{2}){3,4}\n?\Z")


@dataclass
class ValuesChecker:
    """The rules of each kind of metric values, for one metric."""

    job: OutputChecker
    where: str

    def add(self, rule: str) -> None:
        self.job.add(self.where, rule)

    def check(self, values: pb.MetricValues) -> None:
        which = values.WhichOneof("metric_values")
        if which is None:
            self.add("the metric has no values")
            return
        check = getattr(self, f"check_{which}")
        check(getattr(values, which))

    # Each method is named after the MetricValues oneof field it checks.

    def check_double_metric_values(self, v: pb.DoubleSummaryMetricValues) -> None:
        allowed_values: Set[int]
        index = v.WhichOneof("index")
        if index == "timestamp_index":
            allowed_values, allowed_index = INDEXED_DOUBLE, TIMESTAMPS
        elif index == "uuid_index":
            allowed_values, allowed_index = INDEXED_DOUBLE, UUIDS
        elif index == "string_index":
            allowed_values, allowed_index = INDEXED_DOUBLE, STRINGS
        else:
            allowed_values, allowed_index = DOUBLES, ANY_SERIES
        self.values_and_statuses(
            "value", v.value_data_id, v.status_data_id, allowed_values, allowed_index
        )

    def check_double_over_time_metric_values(self, v: pb.DoubleOverTimeMetricValues) -> None:
        n = len(v.doubles_over_time_data_id)
        self.same_lengths(
            ("doubles", n),
            ("statuses", len(v.statuses_over_time_data_id)),
            ("failure definitions", len(v.failure_definition)),
        )
        for values, statuses in zip(
            v.doubles_over_time_data_id, v.statuses_over_time_data_id, strict=False
        ):
            self.values_and_statuses("doubles", values, statuses, INDEXED_DOUBLE, TIMESTAMPS)

    def check_line_plot_metric_values(self, v: pb.LinePlotMetricValues) -> None:
        self.same_lengths(
            ("x data", len(v.x_doubles_data_id)),
            ("y data", len(v.y_doubles_data_id)),
            ("statuses", len(v.statuses_data_id)),
        )
        for x, y, statuses in zip(
            v.x_doubles_data_id, v.y_doubles_data_id, v.statuses_data_id, strict=False
        ):
            self.values_and_statuses("x", x, statuses, DOUBLES, TIMESTAMPS)
            self.values_and_statuses("y", y, statuses, DOUBLES, TIMESTAMPS)

    def check_bar_chart_metric_values(self, v: pb.BarChartMetricValues) -> None:
        self.same_lengths(("values", len(v.values_data_id)), ("statuses", len(v.statuses_data_id)))
        for values, statuses in zip(v.values_data_id, v.statuses_data_id, strict=False):
            self.values_and_statuses("values", values, statuses, INDEXED_DOUBLE, STRINGS)

    def check_batchwise_bar_chart_metric_values(self, v: pb.BatchwiseBarChartMetricValues) -> None:
        self.same_lengths(
            ("values", len(v.values_data_id)),
            ("times", len(v.times_data_id)),
            ("statuses", len(v.statuses_data_id)),
            ("categories", len(v.categories)),
        )
        for n, color in enumerate(v.colors):
            if not _HEX_COLOR.search(color):
                self.add(f"colour {n} ({color!r}) is not a hex colour like '#1f77b4'")
        self.job.check_id(self.where, "project id", v.project_id)
        for values, times, statuses in zip(
            v.values_data_id, v.times_data_id, v.statuses_data_id, strict=False
        ):
            self.values_and_statuses("values", values, statuses, INDEXED_DOUBLE, UUIDS)
            self.values_and_statuses(
                "times",
                times,
                statuses,
                frozenset({pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE}),
                UUIDS,
            )

    def check_states_over_time_metric_values(self, v: pb.StatesOverTimeMetricValues) -> None:
        self.same_lengths(
            ("states", len(v.states_over_time_data_id)),
            ("statuses", len(v.statuses_over_time_data_id)),
        )
        states_set = set(v.states_set)
        pairs = list(zip(v.states_over_time_data_id, v.statuses_over_time_data_id, strict=False))
        for states, statuses in pairs:
            if not self.values_and_statuses(
                "states",
                states,
                statuses,
                frozenset({pb.INDEXED_STRING_SERIES_DATA_TYPE}),
                TIMESTAMPS,
            ):
                continue
            data = self.job.data_by_id[states.id.data]
            if data.HasField("series"):
                series_list = [data.series]
            else:
                by_category = data.series_per_category.category_to_series
                series_list = [by_category[c] for c in sorted(by_category)]
            for series in series_list:
                if not series.HasField("strings"):
                    self.add(f"the states data {data.name!r} must hold strings")
                    continue
                unknown = sorted(set(series.strings.series) - states_set)
                if unknown:
                    self.add(f"states {unknown} of {data.name!r} are not in the states set")
        # ReSim checks this once per pair: with no pairs it is never checked.
        if pairs and not set(v.failure_states) <= states_set:
            extra = sorted(set(v.failure_states) - states_set)
            self.add(f"failure states {extra} are not in the states set")

    def check_histogram_metric_values(self, v: pb.HistogramMetricValues) -> None:
        self.values_and_statuses(
            "values", v.values_data_id, v.statuses_data_id, DOUBLES, ANY_SERIES
        )
        if not v.buckets:
            self.add("a histogram needs at least one bucket")
            return
        previous_upper: float | None = None
        for n, bucket in enumerate(v.buckets):
            if previous_upper is None:
                # Unset bounds read as 0.0, as in ReSim.
                if bucket.lower != v.lower_bound:
                    self.add(
                        f"histogram bucket 0 starts at {bucket.lower}, "
                        f"but lower_bound is {v.lower_bound}"
                    )
            elif bucket.lower != previous_upper:
                self.add(
                    f"histogram buckets must be contiguous (bucket {n} starts at "
                    f"{bucket.lower}, previous ended at {previous_upper})"
                )
            # Negated, so that NaN bounds are refused, as ReSim's `lower < upper`.
            if not bucket.lower < bucket.upper:
                self.add(
                    f"histogram bucket {n} must end after it starts "
                    f"({bucket.lower} to {bucket.upper})"
                )
            previous_upper = bucket.upper
        if previous_upper != v.upper_bound:
            self.add(
                f"the last histogram bucket ends at {previous_upper}, "
                f"but upper_bound is {v.upper_bound}"
            )

    def check_scalar_metric_values(self, v: pb.ScalarMetricValues) -> None:
        if not v.HasField("value"):
            self.add("a scalar metric needs a value")
        elif math.isnan(v.value):
            self.add("a scalar metric value cannot be NaN")

    def check_plotly_metric_values(self, v: pb.PlotlyMetricValues) -> None:
        if not v.HasField("json"):
            self.add("a plotly metric needs its JSON")

    def check_text_metric_values(self, v: pb.TextMetricValues) -> None:
        if not v.text:
            self.add("a text metric needs non-empty text")

    def check_image_metric_values(self, v: pb.ImageMetricValues) -> None:
        if not v.HasField("image_data_id"):
            self.add("an image metric needs an image data id")
            return
        self.external_file("image", v.image_data_id)

    def check_image_list_metric_values(self, v: pb.ImageListMetricValues) -> None:
        if not v.image_data_ids:
            self.add("an image list metric needs at least one image")
        for n, ref in enumerate(v.image_data_ids):
            self.external_file(f"image {n}", ref)

    # ------------------------------------------------------------ shared rules

    def external_file(self, role: str, ref: pb.MetricsDataId) -> None:
        data = self.job.find_data(self.where, role, ref)
        if data is not None and data.data_type != pb.EXTERNAL_FILE_DATA_TYPE:
            self.add(
                f"{role} data {data.name!r} must be EXTERNAL_FILE_DATA_TYPE, "
                f"not {type_name(data.data_type)}"
            )

    def same_lengths(self, *counts: tuple[str, int]) -> None:
        if len({n for _, n in counts}) > 1:
            listed = ", ".join(f"{n} {what}" for what, n in counts)
            self.add(f"the lists of data must have the same length (got {listed})")

    def values_and_statuses(
        self,
        role: str,
        value_ref: pb.MetricsDataId,
        status_ref: pb.MetricsDataId,
        allowed_values: Set[int],
        allowed_index: Set[int],
    ) -> bool:
        """ReSim's pairing of a value data with its status data; True if all is well."""
        before = len(self.job.problems)
        values = self.job.find_data(self.where, f"{role}", value_ref)
        if values is not None and values.data_type not in allowed_values:
            self.add(
                f"{role} data {values.name!r} is {type_name(values.data_type)}, "
                f"but must be {type_names(allowed_values)}"
            )
        statuses = self.job.find_data(self.where, f"{role} status", status_ref)
        if values is None or statuses is None:
            return False
        if values.data_type not in INDEXED:
            self.require_type(role, statuses, pb.METRIC_STATUS_SERIES_DATA_TYPE)
        else:
            self.require_type(role, statuses, pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE)
            if statuses.index_data_id != values.index_data_id:
                self.add(
                    f"status data {statuses.name!r} must have the same index as "
                    f"{role} data {values.name!r}"
                )
            for data in (statuses, values):
                if data.index_data_type not in allowed_index:
                    self.add(
                        f"the index of {data.name!r} is {type_name(data.index_data_type)}, "
                        f"but must be {type_names(allowed_index)}"
                    )
        self.job.check_agree(self.where, "its status data", values, statuses)
        return len(self.job.problems) == before

    def require_type(self, role: str, statuses: pb.MetricsData, wanted: int) -> None:
        if statuses.data_type != wanted:
            self.add(
                f"{role} status data {statuses.name!r} is {type_name(statuses.data_type)}, "
                f"but must be {type_name(wanted)}"
            )
