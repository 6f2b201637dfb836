"""Hypothesis strategies for stook.v1 JobMetrics messages.

`valid_job_metrics()` builds outputs that ReSim's validator accepts: every metric
type, every data kind, indexed and per-category data, events. `mutated_job_metrics()`
then breaks them in the ways real writers do (a missing reference, a wrong type,
an unset enum, a bad UUID, ...), so that roughly half of `job_metrics_cases()` are
valid and half are not.
"""

from __future__ import annotations

import itertools
import math
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from google.protobuf.struct_pb2 import Struct
from hypothesis import strategies as st

from stook.proto import metrics_pb2 as pb

Draw = Callable[[st.SearchStrategy[Any]], Any]

# A shape is the length of a plain series, or a length per category.
Shape = int | dict[str, int]

# Spellings uuid.UUID(hex=...) accepts besides the canonical one.
_SPELLINGS: list[Callable[[uuid.UUID], str]] = [
    str,
    str,
    str,
    lambda u: str(u).upper(),
    lambda u: u.hex,
    lambda u: "{" + str(u) + "}",
    lambda u: u.urn,
]

BAD_UUIDS = ["", "not-a-uuid", "1234", "g" * 32, "0123456789abcdef0123456789abcde", " " * 32]

_WORDS = st.sampled_from(["a", "b", "c", "idle", "drive", "stop", "x y", "ü"])
_FINITE = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)
_STATUS_VALUES = st.sampled_from(
    [
        pb.PASSED_METRIC_STATUS,
        pb.FAIL_WARN_METRIC_STATUS,
        pb.FAIL_BLOCK_METRIC_STATUS,
        pb.NOT_APPLICABLE_METRIC_STATUS,
        pb.RAW_METRIC_STATUS,
    ]
)
_IMPORTANCES = st.sampled_from(
    [
        pb.ZERO_IMPORTANCE,
        pb.LOW_IMPORTANCE,
        pb.MEDIUM_IMPORTANCE,
        pb.HIGH_IMPORTANCE,
        pb.CRITICAL_IMPORTANCE,
    ]
)

_PLAIN = {
    "doubles": pb.DOUBLE_SERIES_DATA_TYPE,
    "timestamps": pb.TIMESTAMP_SERIES_DATA_TYPE,
    "uuids": pb.UUID_SERIES_DATA_TYPE,
    "strings": pb.STRING_SERIES_DATA_TYPE,
    "statuses": pb.METRIC_STATUS_SERIES_DATA_TYPE,
}
_INDEXED = {
    "doubles": pb.INDEXED_DOUBLE_SERIES_DATA_TYPE,
    "timestamps": pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE,
    "uuids": pb.INDEXED_UUID_SERIES_DATA_TYPE,
    "strings": pb.INDEXED_STRING_SERIES_DATA_TYPE,
    "statuses": pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE,
}


@dataclass
class _Builder:
    """Adds data and metrics to one JobMetrics while a strategy draws."""

    draw: Draw
    job: pb.JobMetrics
    job_id: str
    counter: int = 0
    names: set[str] = field(default_factory=set)

    def new_id(self) -> str:
        self.counter += 1
        spell = self.draw(st.sampled_from(_SPELLINGS))
        return str(spell(uuid.UUID(int=(0xABC << 100) + self.counter)))

    def name(self, prefix: str) -> str:
        self.counter += 1
        return f"{prefix} {self.counter}"

    def shape(self, *, allow_categories: bool = True) -> Shape:
        if allow_categories and self.draw(st.booleans()):
            cats = self.draw(st.lists(_WORDS, min_size=1, max_size=3, unique=True))
            return {c: self.draw(st.integers(1, 3)) for c in cats}
        return int(self.draw(st.integers(1, 4)))

    def elements(self, element: str, n: int, pb_series: pb.Series, **opts: Any) -> None:
        if element == "doubles":
            pb_series.doubles.series.extend(self.draw(st.lists(_FINITE, min_size=n, max_size=n)))
        elif element == "timestamps":
            for _ in range(n):
                ts = pb_series.timestamps.series.add()
                ts.seconds = self.draw(st.integers(0, 2_000_000_000))
                ts.nanos = self.draw(st.integers(0, 999_999_999))
        elif element == "uuids":
            for _ in range(n):
                pb_series.uuids.series.add().data = self.new_id()
        elif element == "strings":
            words = opts.get("words", _WORDS)
            pb_series.strings.series.extend(self.draw(st.lists(words, min_size=n, max_size=n)))
        else:
            pb_series.statuses.series.extend(
                self.draw(st.lists(_STATUS_VALUES, min_size=n, max_size=n))
            )

    def data(
        self,
        element: str,
        shape: Shape,
        *,
        index: pb.MetricsData | None = None,
        **opts: Any,
    ) -> pb.MetricsData:
        d = self.job.metrics_data.add()
        d.metrics_data_id.id.data = self.new_id()
        d.name = self.name(f"{element} data")
        if self.draw(st.booleans()):
            d.unit = self.draw(st.sampled_from(["m", "s", "m/s"]))
        d.data_type = (_INDEXED if index is not None else _PLAIN)[element]
        if index is not None:
            d.is_indexed = True
            d.index_data_id.id.data = index.metrics_data_id.id.data
            d.index_data_type = index.data_type
        if isinstance(shape, dict):
            d.is_per_category = True
            d.category_names.extend(shape)
            for cat, n in shape.items():
                self.elements(element, n, d.series_per_category.category_to_series[cat], **opts)
        else:
            self.elements(element, shape, d.series, **opts)
        return d

    def external(self) -> pb.MetricsData:
        d = self.job.metrics_data.add()
        d.metrics_data_id.id.data = self.new_id()
        d.name = self.name("image")
        d.data_type = pb.EXTERNAL_FILE_DATA_TYPE
        d.external_file.path = f"images/{self.counter}.png"
        return d

    def metric(self, metric_type: pb.MetricType.ValueType) -> pb.Metric:
        m = self.job.job_level_metrics.metrics.add()
        m.metric_id.id.data = self.new_id()
        m.name = self.name(pb.MetricType.Name(metric_type).lower())
        m.type = metric_type
        m.status = self.draw(_STATUS_VALUES)
        m.importance = self.draw(_IMPORTANCES)
        m.job_id.id.data = self.job_id
        if self.draw(st.booleans()):
            m.description = "a description"
            m.should_display = self.draw(st.booleans())
            m.blocking = self.draw(st.booleans())
            m.order = float(self.counter)
        for _ in range(self.draw(st.integers(0, 2))):
            tag = m.tags.add()
            tag.key, tag.value = self.draw(_WORDS), self.draw(_WORDS)
        m.event_metric = self.draw(st.booleans()) and self.draw(st.booleans())
        return m

    @staticmethod
    def ref(target: pb.MetricsDataId, data: pb.MetricsData) -> None:
        target.id.data = data.metrics_data_id.id.data

    def values_with_statuses(
        self, element: str, index_element: str | None, shape: Shape
    ) -> tuple[pb.MetricsData, pb.MetricsData]:
        """A value data and its status data, indexed by a new index data or not."""
        index = self.data(index_element, shape) if index_element is not None else None
        values = self.data(element, shape, index=index)
        statuses = self.data("statuses", shape, index=index)
        return values, statuses


# ---------------------------------------------------------------- one metric per type


def _double_summary(b: _Builder) -> None:
    m = b.metric(pb.DOUBLE_SUMMARY_METRIC_TYPE)
    v = m.metric_values.double_metric_values
    index_kind = b.draw(st.sampled_from(["none", "series", "timestamps", "uuids", "strings"]))
    shape = b.shape()
    if index_kind in ("none", "series"):
        index_element = b.draw(st.sampled_from([None, "doubles", "timestamps", "strings", "uuids"]))
    else:
        index_element = index_kind
    values, statuses = b.values_with_statuses("doubles", index_element, shape)
    b.ref(v.value_data_id, values)
    b.ref(v.status_data_id, statuses)
    if index_kind == "series":
        v.series_index = b.draw(st.integers(0, 3))
    elif index_kind == "timestamps":
        v.timestamp_index.seconds = 5
    elif index_kind == "uuids":
        v.uuid_index.data = str(uuid.UUID(int=1))
    elif index_kind == "strings":
        v.string_index = "a"
    if b.draw(st.booleans()):
        v.failure_definition.fails_above = 1.0


def _double_over_time(b: _Builder) -> None:
    m = b.metric(pb.DOUBLE_OVER_TIME_METRIC_TYPE)
    v = m.metric_values.double_over_time_metric_values
    v.SetInParent()  # a metric with no series still has (empty) values
    for _ in range(b.draw(st.integers(0, 2))):
        values, statuses = b.values_with_statuses("doubles", "timestamps", b.shape())
        b.ref(v.doubles_over_time_data_id.add(), values)
        b.ref(v.statuses_over_time_data_id.add(), statuses)
        v.failure_definition.add().fails_below = -1.0
        v.legend_series_names.append(values.name)
    if b.draw(st.booleans()):
        v.start_time.seconds = 1
        v.y_axis_name = "speed"


def _line_plot(b: _Builder) -> None:
    m = b.metric(pb.LINE_PLOT_METRIC_TYPE)
    v = m.metric_values.line_plot_metric_values
    v.SetInParent()  # a metric with no series still has (empty) values
    for _ in range(b.draw(st.integers(0, 2))):
        shape = b.shape()
        index = b.data("timestamps", shape) if b.draw(st.booleans()) else None
        x = b.data("doubles", shape, index=index)
        y = b.data("doubles", shape, index=index)
        statuses = b.data("statuses", shape, index=index)
        b.ref(v.x_doubles_data_id.add(), x)
        b.ref(v.y_doubles_data_id.add(), y)
        b.ref(v.statuses_data_id.add(), statuses)
    v.x_axis_name = "x"


def _bar_chart(b: _Builder) -> None:
    m = b.metric(pb.BAR_CHART_METRIC_TYPE)
    v = m.metric_values.bar_chart_metric_values
    v.SetInParent()  # a metric with no series still has (empty) values
    for _ in range(b.draw(st.integers(0, 2))):
        values, statuses = b.values_with_statuses("doubles", "strings", b.shape())
        b.ref(v.values_data_id.add(), values)
        b.ref(v.statuses_data_id.add(), statuses)
    v.stack_bars = b.draw(st.booleans())


def _batchwise_bar_chart(b: _Builder) -> None:
    m = b.metric(pb.BATCHWISE_BAR_CHART_METRIC_TYPE)
    v = m.metric_values.batchwise_bar_chart_metric_values
    v.SetInParent()  # a metric with no series still has (empty) values
    for _ in range(b.draw(st.integers(0, 2))):
        shape = b.shape()
        index = b.data("uuids", shape)
        b.ref(v.values_data_id.add(), b.data("doubles", shape, index=index))
        b.ref(v.times_data_id.add(), b.data("timestamps", shape, index=index))
        b.ref(v.statuses_data_id.add(), b.data("statuses", shape, index=index))
        v.categories.append(b.draw(_WORDS))
    v.colors.extend(
        b.draw(st.lists(st.sampled_from(["#1f77b4", "#FFAA00", "#12345678", "#abcdef\n"])))
    )
    v.project_id.data = b.new_id()


def _states_over_time(b: _Builder) -> None:
    m = b.metric(pb.STATES_OVER_TIME_METRIC_TYPE)
    v = m.metric_values.states_over_time_metric_values
    v.SetInParent()  # a metric with no series still has (empty) values
    states = b.draw(st.lists(_WORDS, min_size=1, max_size=4, unique=True))
    v.states_set.extend(states)
    v.failure_states.extend(b.draw(st.lists(st.sampled_from(states), unique=True)))
    for _ in range(b.draw(st.integers(0, 2))):
        shape = b.shape()
        index = b.data("timestamps", shape)
        values = b.data("strings", shape, index=index, words=st.sampled_from(states))
        b.ref(v.states_over_time_data_id.add(), values)
        b.ref(v.statuses_over_time_data_id.add(), b.data("statuses", shape, index=index))


def _histogram(b: _Builder) -> None:
    m = b.metric(pb.HISTOGRAM_METRIC_TYPE)
    v = m.metric_values.histogram_metric_values
    shape = b.shape()
    index_element = b.draw(st.sampled_from([None, "timestamps", "strings"]))
    values, statuses = b.values_with_statuses("doubles", index_element, shape)
    b.ref(v.values_data_id, values)
    b.ref(v.statuses_data_id, statuses)
    edges = [b.draw(_FINITE)]
    for width in b.draw(st.lists(st.floats(0.5, 100.0), min_size=1, max_size=4)):
        edges.append(edges[-1] + width)
    for lower, upper in itertools.pairwise(edges):
        bucket = v.buckets.add()
        bucket.lower, bucket.upper = lower, upper
    v.lower_bound, v.upper_bound = edges[0], edges[-1]


def _scalar(b: _Builder) -> None:
    m = b.metric(pb.SCALAR_METRIC_TYPE)
    v = m.metric_values.scalar_metric_values
    v.value = b.draw(st.floats(allow_nan=False))
    if b.draw(st.booleans()):
        v.unit = "m"
        v.failure_definition.fails_above = 2.0


def _plotly(b: _Builder) -> None:
    m = b.metric(pb.PLOTLY_METRIC_TYPE)
    s = Struct()
    s.update({"data": [{"x": [1, 2], "type": "scatter"}]})
    m.metric_values.plotly_metric_values.json.CopyFrom(s)


def _text(b: _Builder) -> None:
    m = b.metric(pb.TEXT_METRIC_TYPE)
    m.metric_values.text_metric_values.text = b.draw(st.text(min_size=1, max_size=10))


def _image(b: _Builder) -> None:
    m = b.metric(pb.IMAGE_METRIC_TYPE)
    b.ref(m.metric_values.image_metric_values.image_data_id, b.external())


def _image_list(b: _Builder) -> None:
    m = b.metric(pb.IMAGE_LIST_METRIC_TYPE)
    for _ in range(b.draw(st.integers(1, 3))):
        b.ref(m.metric_values.image_list_metric_values.image_data_ids.add(), b.external())


METRIC_BUILDERS: list[Callable[[_Builder], None]] = [
    _double_summary,
    _double_over_time,
    _line_plot,
    _bar_chart,
    _batchwise_bar_chart,
    _states_over_time,
    _histogram,
    _scalar,
    _plotly,
    _text,
    _image,
    _image_list,
]


def _events(b: _Builder) -> None:
    metrics = list(b.job.job_level_metrics.metrics)
    timestamp_type = b.draw(st.sampled_from([pb.ABSOLUTE_TIMESTAMP, pb.RELATIVE_TIMESTAMP]))
    for _ in range(b.draw(st.integers(0, 2))):
        e = b.job.events.add()
        e.event_id.id.data = b.new_id()
        e.name = b.name("event")
        e.status = b.draw(_STATUS_VALUES)
        e.importance = b.draw(_IMPORTANCES)
        e.timestamp_type = timestamp_type
        e.timestamp.seconds = b.draw(st.integers(0, 10**9))
        e.timestamp.nanos = b.draw(st.integers(0, 999_999_999))
        e.tags.extend(b.draw(st.lists(_WORDS, max_size=2)))
        if metrics:
            # Metric names are unique, so any subset has unique names.
            chosen = b.draw(st.lists(st.sampled_from(metrics), max_size=3, unique_by=id))
            for metric in chosen:
                e.metrics.add().id.data = metric.metric_id.id.data


@st.composite
def valid_job_metrics(draw: Draw, *, max_metrics: int = 4) -> pb.JobMetrics:
    """A JobMetrics that ReSim's validator accepts."""
    job = pb.JobMetrics()
    spell = draw(st.sampled_from(_SPELLINGS))
    job_id = str(spell(uuid.UUID(int=0xDEF << 100)))
    job.job_id.id.data = job_id
    b = _Builder(draw, job, job_id)
    for builder in draw(st.lists(st.sampled_from(METRIC_BUILDERS), max_size=max_metrics)):
        builder(b)
    if draw(st.booleans()):
        b.data(draw(st.sampled_from(list(_PLAIN))), b.shape())  # data no metric uses
    _events(b)
    status = draw(_STATUS_VALUES)
    job.metrics_status = status
    job.job_level_metrics.metrics_status = status
    return job


# ---------------------------------------------------------------- mutations


def _all_ids(job: pb.JobMetrics) -> list[Any]:
    """Every UUID message in the output: own IDs and references."""
    found: list[Any] = []

    def walk(msg: Any) -> None:
        for fd, value in msg.ListFields():
            if fd.message_type is None:
                continue
            items = value if fd.is_repeated else [value]
            if fd.message_type.full_name == "stook.v1.UUID":
                found.extend(items)
            elif fd.message_type.GetOptions().map_entry:
                for item in value.values():
                    walk(item)
            else:
                for item in items:
                    walk(item)

    walk(job)
    return found


def _all_series(job: pb.JobMetrics) -> list[pb.Series]:
    out: list[pb.Series] = []
    for d in job.metrics_data:
        if d.HasField("series"):
            out.append(d.series)
        out.extend(d.series_per_category.category_to_series.values())
    return out


def _values_of(job: pb.JobMetrics, field_name: str) -> list[Any]:
    return [
        getattr(m.metric_values, field_name)
        for m in job.job_level_metrics.metrics
        if m.metric_values.WhichOneof("metric_values") == field_name
    ]


def _pick(draw: Draw, items: list[Any]) -> Any | None:
    return draw(st.sampled_from(items)) if items else None


def _drop_data(draw: Draw, job: pb.JobMetrics) -> None:
    if job.metrics_data:
        del job.metrics_data[draw(st.integers(0, len(job.metrics_data) - 1))]


def _wrong_data_type(draw: Draw, job: pb.JobMetrics) -> None:
    d = _pick(draw, list(job.metrics_data))
    if d is not None:
        d.data_type = draw(st.integers(0, 12))
        if draw(st.booleans()):
            d.index_data_type = draw(st.integers(0, 12))


def _unset_enum(draw: Draw, job: pb.JobMetrics) -> None:
    targets: list[tuple[Any, str]] = [
        (job, "metrics_status"),
        (job.job_level_metrics, "metrics_status"),
    ]
    for m in job.job_level_metrics.metrics:
        targets += [(m, "type"), (m, "status"), (m, "importance")]
    for e in job.events:
        targets += [(e, "status"), (e, "importance"), (e, "timestamp_type")]
    owner, name = draw(st.sampled_from(targets))
    setattr(
        owner, name, draw(st.sampled_from([0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 99]))
    )


def _bad_uuid(draw: Draw, job: pb.JobMetrics) -> None:
    ident = _pick(draw, _all_ids(job))
    if ident is not None:
        try:
            respelt = [s(uuid.UUID(hex=ident.data)) for s in _SPELLINGS]
        except ValueError:
            respelt = []
        ident.data = draw(st.sampled_from(BAD_UUIDS + respelt))


def _length_mismatch(draw: Draw, job: pb.JobMetrics) -> None:
    s = _pick(draw, _all_series(job))
    if s is None:
        return
    which = s.WhichOneof("series")
    if which == "doubles":
        s.doubles.series.append(1.0)
    elif which == "strings":
        s.strings.series.append("a")
    elif which == "statuses":
        s.statuses.series.append(pb.PASSED_METRIC_STATUS)
    elif which == "timestamps":
        s.timestamps.series.add()
    elif which == "uuids":
        s.uuids.series.add().data = str(uuid.UUID(int=7))


def _empty_series(draw: Draw, job: pb.JobMetrics) -> None:
    s = _pick(draw, _all_series(job))
    if s is None:
        return
    which = s.WhichOneof("series")
    if draw(st.booleans()) or which is None:
        s.Clear()
    else:
        getattr(s, which).ClearField("series")


def _wrong_series_kind(draw: Draw, job: pb.JobMetrics) -> None:
    s = _pick(draw, _all_series(job))
    if s is not None:
        s.strings.series.append("oops")


def _bad_colour(draw: Draw, job: pb.JobMetrics) -> None:
    v = _pick(draw, _values_of(job, "batchwise_bar_chart_metric_values"))
    if v is not None:
        v.colors.append(
            draw(st.sampled_from(["red", "#12345", "#1234567", "#GGGGGG", "", "#aabbcc\n\n"]))
        )


def _bad_timestamp(draw: Draw, job: pb.JobMetrics) -> None:
    e = _pick(draw, list(job.events))
    if e is not None:
        if draw(st.booleans()):
            e.timestamp.seconds = draw(st.integers(-10, -1))
        else:
            e.timestamp.nanos = draw(st.sampled_from([-1, 1_000_000_000, 2_000_000_000]))


def _duplicate_name(draw: Draw, job: pb.JobMetrics) -> None:
    pools: list[list[Any]] = [
        list(job.job_level_metrics.metrics),
        list(job.metrics_data),
        list(job.events),
    ]
    pool = draw(st.sampled_from(pools))
    if len(pool) >= 2:
        a, b = draw(st.lists(st.sampled_from(pool), min_size=2, max_size=2, unique_by=id))
        a.name = b.name
    elif pool:
        pool[0].name = ""


def _nan_scalar(draw: Draw, job: pb.JobMetrics) -> None:
    v = _pick(draw, _values_of(job, "scalar_metric_values"))
    if v is not None:
        if draw(st.booleans()):
            v.value = math.nan
        else:
            v.ClearField("value")


def _bucket_gap(draw: Draw, job: pb.JobMetrics) -> None:
    v = _pick(draw, _values_of(job, "histogram_metric_values"))
    if v is None:
        return
    choice = draw(st.integers(0, 4))
    if choice == 0:
        del v.buckets[:]
    elif choice == 1:
        v.buckets[-1].lower += 0.5
    elif choice == 2:
        v.upper_bound += 1.0
    elif choice == 3:
        v.ClearField("lower_bound")
    else:
        v.buckets[0].upper = v.buckets[0].lower


def _category_mismatch(draw: Draw, job: pb.JobMetrics) -> None:
    d = _pick(draw, [d for d in job.metrics_data if d.is_per_category])
    if d is None:
        return
    if draw(st.booleans()):
        d.category_names.append("extra")
    else:
        d.series_per_category.category_to_series["extra"].doubles.series.append(1.0)


def _flip_flags(draw: Draw, job: pb.JobMetrics) -> None:
    d = _pick(draw, list(job.metrics_data))
    if d is not None:
        if draw(st.booleans()):
            d.is_indexed = not d.is_indexed
        else:
            d.is_per_category = not d.is_per_category


def _break_metric(draw: Draw, job: pb.JobMetrics) -> None:
    m = _pick(draw, list(job.job_level_metrics.metrics))
    if m is None:
        return
    choice = draw(st.integers(0, 5))
    if choice == 0:
        m.ClearField("job_id")
    elif choice == 1:
        m.job_id.id.data = str(uuid.UUID(int=99))
    elif choice == 2:
        m.metric_values.Clear()
    elif choice == 3:
        tag = m.tags.add()
        tag.key = draw(st.sampled_from(["", "k"]))
    elif choice == 4:
        m.metric_values.text_metric_values.text = draw(st.sampled_from(["", "t"]))
    else:
        m.event_metric = not m.event_metric


def _break_values(draw: Draw, job: pb.JobMetrics) -> None:
    """Shorten a repeated reference list, or change a states set / an external file."""
    m = _pick(draw, list(job.job_level_metrics.metrics))
    if m is None:
        return
    which = m.metric_values.WhichOneof("metric_values")
    if which is None:
        return
    values = getattr(m.metric_values, which)
    repeated = [
        fd.name
        for fd in values.DESCRIPTOR.fields
        if fd.is_repeated and len(getattr(values, fd.name))
    ]
    name = _pick(draw, repeated)
    if name is not None:
        del getattr(values, name)[-1]
    if which == "states_over_time_metric_values" and draw(st.booleans()):
        values.failure_states.append("never")
    if which == "states_over_time_metric_values" and values.states_set and draw(st.booleans()):
        del values.states_set[0]
    ext = _pick(draw, [d for d in job.metrics_data if d.HasField("external_file")])
    if ext is not None and draw(st.booleans()):
        ext.external_file.path = ""


def _break_event(draw: Draw, job: pb.JobMetrics) -> None:
    e = _pick(draw, list(job.events))
    if e is None:
        return
    choice = draw(st.integers(0, 2))
    if choice == 0:
        e.metrics.add().id.data = str(uuid.UUID(int=12345))
    elif choice == 1 and len(e.metrics):
        e.metrics.add().CopyFrom(e.metrics[0])
    else:
        dup = job.events.add()
        dup.CopyFrom(e)
        dup.name = e.name + " again"


MUTATIONS: list[Callable[[Draw, pb.JobMetrics], None]] = [
    _drop_data,
    _wrong_data_type,
    _unset_enum,
    _bad_uuid,
    _length_mismatch,
    _empty_series,
    _wrong_series_kind,
    _bad_colour,
    _bad_timestamp,
    _duplicate_name,
    _nan_scalar,
    _bucket_gap,
    _category_mismatch,
    _flip_flags,
    _break_metric,
    _break_values,
    _break_event,
]


@st.composite
def mutated_job_metrics(draw: Draw) -> pb.JobMetrics:
    """A valid output with one to three mutations applied (some are harmless)."""
    job: pb.JobMetrics = draw(valid_job_metrics())
    for mutate in draw(st.lists(st.sampled_from(MUTATIONS), min_size=1, max_size=3)):
        mutate(draw, job)
    return job


def job_metrics_cases() -> st.SearchStrategy[pb.JobMetrics]:
    """Valid and broken outputs, about half each."""
    return st.one_of(valid_job_metrics(), mutated_job_metrics())
