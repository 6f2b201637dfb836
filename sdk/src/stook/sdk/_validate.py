"""stook's own validator of a JobMetrics message.

It accepts and refuses exactly the messages that ReSim's platform validator
(``resim.metrics.proto.validate_metrics_proto.validate_job_metrics``, version
1.6.0) accepts and refuses, so an output that passes here will be ingested. Unlike
ReSim's, it collects every problem and names the metric, data or event and the
rule broken. The conformance tests check the agreement on generated messages.

This module owns the entry points and the rules of the output as a whole (IDs,
names, the fields every metric has, metrics data and indexes, events) with the data
lookups all rules share; the rules of each metric type's values are in
`_validate_values`.

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

import uuid
from dataclasses import dataclass, field

from google.protobuf.timestamp_pb2 import Timestamp

from stook.proto import metrics_pb2 as pb
from stook.proto import uuid_pb2
from stook.sdk._data_types import DOUBLES, STRINGS, TIMESTAMPS, UUIDS, type_name
from stook.sdk._errors import InvalidMetricsError, Problem
from stook.sdk._validate_values import ValuesChecker

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
