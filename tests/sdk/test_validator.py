"""stook's validator: each rule, its message, and ReSim's quirks.

Every case also runs ReSim's validator, so that a message here can never claim
a decision ReSim would not make.
"""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable
from typing import cast

import pytest
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.proto import metrics_pb2 as pb
from stook.proto import uuid_pb2
from stook.sdk import InvalidMetricsError, find_problems, validate_job_metrics

_NS = uuid.UUID("00000000-0000-4000-8000-000000000000")
JOB = str(uuid.uuid5(_NS, "job"))


def uid(name: str) -> str:
    return str(uuid.uuid5(_NS, name))


class Job:
    """A valid output with one metric of each type, built by name."""

    def __init__(self) -> None:
        self.msg = pb.JobMetrics()
        self.msg.job_id.id.data = JOB
        self.msg.metrics_status = pb.PASSED_METRIC_STATUS
        self.msg.job_level_metrics.metrics_status = pb.PASSED_METRIC_STATUS
        self._build()

    def data(self, name: str) -> pb.MetricsData:
        return next(d for d in self.msg.metrics_data if d.name == name)

    def metric(self, name: str) -> pb.Metric:
        return next(m for m in self.msg.job_level_metrics.metrics if m.name == name)

    def add_data(
        self, name: str, data_type: int, values: list[object], index: str | None = None
    ) -> pb.MetricsData:
        d = self.msg.metrics_data.add(name=name, data_type=data_type)
        d.metrics_data_id.id.data = uid(name)
        if index is not None:
            d.is_indexed = True
            d.index_data_id.id.data = uid(index)
            d.index_data_type = self.data(index).data_type
        self.fill(d.series, values)
        return d

    @staticmethod
    def fill(series: pb.Series, values: list[object]) -> None:
        first = values[0]
        if isinstance(first, float):
            series.doubles.series.extend(values)  # type: ignore[arg-type]
        elif isinstance(first, tuple):
            for pair in values:
                seconds, nanos = cast(tuple[int, int], pair)
                t = series.timestamps.series.add()
                t.seconds, t.nanos = seconds, nanos
        elif isinstance(first, uuid.UUID):
            for u in values:
                series.uuids.series.add().data = str(u)
        elif isinstance(first, str):
            series.strings.series.extend(values)  # type: ignore[arg-type]
        else:
            series.statuses.series.extend(values)  # type: ignore[arg-type]

    def add_metric(self, name: str, metric_type: int) -> pb.Metric:
        m = self.msg.job_level_metrics.metrics.add(name=name, type=metric_type)
        m.metric_id.id.data = uid(name)
        m.status = pb.PASSED_METRIC_STATUS
        m.importance = pb.HIGH_IMPORTANCE
        m.job_id.id.data = JOB
        return m

    def _build(self) -> None:
        ok = pb.PASSED_METRIC_STATUS
        self.add_data("times", pb.TIMESTAMP_SERIES_DATA_TYPE, [(0, 0), (1, 0), (2, 0)])
        self.add_data("speeds", pb.INDEXED_DOUBLE_SERIES_DATA_TYPE, [1.0, 2.0, 3.0], "times")
        self.add_data(
            "speed statuses", pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, [ok] * 3, "times"
        )
        self.add_data("values", pb.DOUBLE_SERIES_DATA_TYPE, [0.5, 1.5])
        self.add_data("value statuses", pb.METRIC_STATUS_SERIES_DATA_TYPE, [ok, ok])
        self.add_data("names", pb.STRING_SERIES_DATA_TYPE, ["a", "b"])
        self.add_data("bar values", pb.INDEXED_DOUBLE_SERIES_DATA_TYPE, [1.0, 2.0], "names")
        self.add_data("bar statuses", pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, [ok] * 2, "names")
        self.add_data("batch ids", pb.UUID_SERIES_DATA_TYPE, [uuid.UUID(int=1)])
        self.add_data("batch values", pb.INDEXED_DOUBLE_SERIES_DATA_TYPE, [1.0], "batch ids")
        self.add_data("batch times", pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE, [(5, 0)], "batch ids")
        self.add_data(
            "batch statuses", pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, [ok], "batch ids"
        )
        self.add_data("states", pb.INDEXED_STRING_SERIES_DATA_TYPE, ["idle", "go", "idle"], "times")
        self.add_data(
            "state statuses", pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, [ok] * 3, "times"
        )
        for name, data_type, values in (
            ("grouped", pb.DOUBLE_SERIES_DATA_TYPE, {"car": [1.0], "bike": [2.0, 3.0]}),
            (
                "grouped statuses",
                pb.METRIC_STATUS_SERIES_DATA_TYPE,
                {"car": [ok], "bike": [ok, ok]},
            ),
        ):
            d = self.msg.metrics_data.add(name=name, data_type=data_type, is_per_category=True)
            d.metrics_data_id.id.data = uid(name)
            d.category_names.extend(values)
            for cat, vals in values.items():
                self.fill(d.series_per_category.category_to_series[cat], list(vals))
        picture = self.msg.metrics_data.add(name="picture", data_type=pb.EXTERNAL_FILE_DATA_TYPE)
        picture.metrics_data_id.id.data = uid("picture")
        picture.external_file.path = "a.png"

        self.add_metric(
            "Max speed", pb.SCALAR_METRIC_TYPE
        ).metric_values.scalar_metric_values.value = 3.0
        h = self.add_metric("Speed histogram", pb.HISTOGRAM_METRIC_TYPE)
        hv = h.metric_values.histogram_metric_values
        hv.values_data_id.id.data, hv.statuses_data_id.id.data = (
            uid("values"),
            uid("value statuses"),
        )
        for lower, upper in ((0.0, 1.0), (1.0, 2.5), (2.5, 4.0)):
            hv.buckets.add(lower=lower, upper=upper)
        hv.lower_bound, hv.upper_bound = 0.0, 4.0
        dot = self.add_metric("Speed", pb.DOUBLE_OVER_TIME_METRIC_TYPE)
        dv = dot.metric_values.double_over_time_metric_values
        dv.doubles_over_time_data_id.add().id.data = uid("speeds")
        dv.statuses_over_time_data_id.add().id.data = uid("speed statuses")
        dv.failure_definition.add(fails_above=10.0)
        lp = self.add_metric("Path", pb.LINE_PLOT_METRIC_TYPE).metric_values.line_plot_metric_values
        lp.x_doubles_data_id.add().id.data = uid("values")
        lp.y_doubles_data_id.add().id.data = uid("values")
        lp.statuses_data_id.add().id.data = uid("value statuses")
        bc = self.add_metric("Bars", pb.BAR_CHART_METRIC_TYPE).metric_values.bar_chart_metric_values
        bc.values_data_id.add().id.data = uid("bar values")
        bc.statuses_data_id.add().id.data = uid("bar statuses")
        bw = self.add_metric("Batches", pb.BATCHWISE_BAR_CHART_METRIC_TYPE)
        bwv = bw.metric_values.batchwise_bar_chart_metric_values
        bwv.values_data_id.add().id.data = uid("batch values")
        bwv.times_data_id.add().id.data = uid("batch times")
        bwv.statuses_data_id.add().id.data = uid("batch statuses")
        bwv.categories.append("batch")
        bwv.colors.extend(["#1f77b4", "#1F77B4AA"])
        bwv.project_id.data = uid("project")
        so = self.add_metric("States", pb.STATES_OVER_TIME_METRIC_TYPE)
        sov = so.metric_values.states_over_time_metric_values
        sov.states_over_time_data_id.add().id.data = uid("states")
        sov.statuses_over_time_data_id.add().id.data = uid("state statuses")
        sov.states_set.extend(["idle", "go"])
        sov.failure_states.append("go")
        ds = self.add_metric("Summary", pb.DOUBLE_SUMMARY_METRIC_TYPE)
        dsv = ds.metric_values.double_metric_values
        dsv.value_data_id.id.data, dsv.status_data_id.id.data = (
            uid("grouped"),
            uid("grouped statuses"),
        )
        image = self.add_metric("Image", pb.IMAGE_METRIC_TYPE).metric_values.image_metric_values
        image.image_data_id.id.data = uid("picture")
        images = self.add_metric("Images", pb.IMAGE_LIST_METRIC_TYPE)
        images.metric_values.image_list_metric_values.image_data_ids.add().id.data = uid("picture")
        self.add_metric("Text", pb.TEXT_METRIC_TYPE).metric_values.text_metric_values.text = "hi"
        plot = self.add_metric("Plot", pb.PLOTLY_METRIC_TYPE)
        plot.metric_values.plotly_metric_values.json.update({"data": []})
        stop_speed = self.add_metric("Stop speed", pb.SCALAR_METRIC_TYPE)
        stop_speed.metric_values.scalar_metric_values.value = 0.0
        stop_speed.event_metric = True

        e = self.msg.events.add(name="Stop", status=pb.PASSED_METRIC_STATUS)
        e.event_id.id.data = uid("Stop")
        e.importance = pb.LOW_IMPORTANCE
        e.timestamp_type = pb.ABSOLUTE_TIMESTAMP
        e.timestamp.seconds = 10
        e.metrics.add().id.data = uid("Stop speed")


def resim_accepts(msg: pb.JobMetrics) -> bool:
    try:
        resim_validate(resim_pb.JobMetrics.FromString(msg.SerializeToString()))
    except Exception:  # any failure of ReSim's validator is a refusal
        return False
    return True


def test_base_output_is_valid() -> None:
    job = Job()
    assert resim_accepts(job.msg)
    assert find_problems(job.msg) == []
    validate_job_metrics(job.msg)


Mutation = Callable[[Job], object]


def _set(obj: object, **fields: object) -> None:
    for name, value in fields.items():
        setattr(obj, name, value)


def _drop_data(name: str) -> Mutation:
    def drop(job: Job) -> None:
        data = job.msg.metrics_data
        del data[[d.name for d in data].index(name)]

    return drop


def _respell_job_id(job: Job) -> None:
    job.metric("Text").job_id.id.data = JOB.upper()


def _hist(job: Job) -> pb.HistogramMetricValues:
    return job.metric("Speed histogram").metric_values.histogram_metric_values


def _batch(job: Job) -> pb.BatchwiseBarChartMetricValues:
    return job.metric("Batches").metric_values.batchwise_bar_chart_metric_values


def _states(job: Job) -> pb.StatesOverTimeMetricValues:
    return job.metric("States").metric_values.states_over_time_metric_values


HIST = f"metric 'Speed histogram' (id {uid('Speed histogram')})"
SPEEDS = f"data 'speeds' (id {uid('speeds')})"

REFUSED: list[tuple[str, Mutation, str]] = [
    (
        "bucket gap",
        lambda j: _set(_hist(j).buckets[2], lower=3.0),
        f"{HIST}: histogram buckets must be contiguous (bucket 2 starts at 3.0, "
        "previous ended at 2.5)",
    ),
    (
        "no buckets",
        lambda j: _hist(j).ClearField("buckets"),
        f"{HIST}: a histogram needs at least one bucket",
    ),
    (
        "first bucket",
        lambda j: _set(_hist(j), lower_bound=-1.0),
        f"{HIST}: histogram bucket 0 starts at 0.0, but lower_bound is -1.0",
    ),
    (
        "last bucket",
        lambda j: _set(_hist(j), upper_bound=5.0),
        f"{HIST}: the last histogram bucket ends at 4.0, but upper_bound is 5.0",
    ),
    (
        "empty bucket",
        lambda j: _set(_hist(j).buckets[0], upper=0.0),
        f"{HIST}: histogram bucket 0 must end after it starts (0.0 to 0.0)",
    ),
    (
        "missing data",
        _drop_data("value statuses"),
        f"{HIST}: values status data {uid('value statuses')} is not in the output",
    ),
    (
        "wrong value type",
        lambda j: _set(j.data("values"), data_type=pb.STRING_SERIES_DATA_TYPE),
        f"{HIST}: values data 'values' is STRING_SERIES_DATA_TYPE, "
        "but must be DOUBLE_SERIES_DATA_TYPE or INDEXED_DOUBLE_SERIES_DATA_TYPE",
    ),
    (
        "wrong status type",
        lambda j: _set(j.data("speed statuses"), data_type=pb.METRIC_STATUS_SERIES_DATA_TYPE),
        "doubles status data 'speed statuses' is METRIC_STATUS_SERIES_DATA_TYPE, "
        "but must be INDEXED_METRIC_STATUS_SERIES_DATA_TYPE",
    ),
    (
        "different index",
        lambda j: _set(j.data("speed statuses").index_data_id.id, data=uid("names")),
        "status data 'speed statuses' must have the same index as doubles data 'speeds'",
    ),
    (
        "index type not allowed",
        lambda j: _set(j.data("bar values"), index_data_type=pb.UUID_SERIES_DATA_TYPE),
        "the index of 'bar values' is UUID_SERIES_DATA_TYPE, but must be "
        "INDEXED_STRING_SERIES_DATA_TYPE or STRING_SERIES_DATA_TYPE",
    ),
    (
        "index type disagrees",
        lambda j: _set(j.data("states"), index_data_type=pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE),
        "index_data_type is INDEXED_TIMESTAMP_SERIES_DATA_TYPE, but the index data 'times' "
        "is TIMESTAMP_SERIES_DATA_TYPE",
    ),
    (
        "missing index",
        _drop_data("names"),
        f"data 'bar values' (id {uid('bar values')}): index data {uid('names')} "
        "is not in the output",
    ),
    (
        "length mismatch",
        lambda j: j.data("speeds").series.doubles.series.append(4.0),
        f"{SPEEDS}: 'speeds' and its index 'times' must have the same length (4 and 3)",
    ),
    (
        "unset metric status",
        lambda j: _set(j.metric("Max speed"), status=pb.NO_METRIC_STATUS),
        f"metric 'Max speed' (id {uid('Max speed')}): the metric status is unset",
    ),
    (
        "unset metric type",
        lambda j: _set(j.metric("Text"), type=pb.NO_METRIC_TYPE),
        "the metric type is unset",
    ),
    (
        "unset importance",
        lambda j: _set(j.metric("Text"), importance=pb.NO_SPECIFIED_IMPORTANCE),
        "the metric importance is unset",
    ),
    (
        "unset data type",
        lambda j: _set(j.data("grouped"), data_type=pb.NO_DATA_TYPE),
        "the data type is unset",
    ),
    (
        "unset overall status",
        lambda j: _set(j.msg, metrics_status=pb.NO_METRIC_STATUS),
        "output: the output has no overall status",
    ),
    (
        "unset collection status",
        lambda j: _set(j.msg.job_level_metrics, metrics_status=pb.NO_METRIC_STATUS),
        "output: the job-level metric collection has no status",
    ),
    (
        "bad metric id",
        lambda j: _set(j.metric("Max speed").metric_id.id, data="nope"),
        "metric 'Max speed' (id nope): id 'nope' is not a valid UUID",
    ),
    (
        "missing job id",
        lambda j: j.msg.ClearField("job_id"),
        "output: job id is missing",
    ),
    (
        "bad project id",
        lambda j: _batch(j).ClearField("project_id"),
        "project id is missing",
    ),
    (
        "bad colour",
        lambda j: _batch(j).colors.append("red"),
        "colour 2 ('red') is not a hex colour like '#1f77b4'",
    ),
    (
        "colour with two newlines",
        lambda j: _batch(j).colors.append("#aabbcc\n\n"),
        "is not a hex colour",
    ),
    (
        "batch lengths",
        lambda j: _batch(j).categories.append("extra"),
        "the lists of data must have the same length (got 1 values, 1 times, 1 statuses, "
        "2 categories)",
    ),
    (
        "negative timestamp",
        lambda j: _set(j.msg.events[0].timestamp, seconds=-1),
        f"event 'Stop' (id {uid('Stop')}): the event timestamp has negative seconds (-1)",
    ),
    (
        "nanos too big",
        lambda j: _set(j.msg.events[0].timestamp, nanos=1_000_000_000),
        "the event timestamp nanos must be in [0, 1e9) (got 1000000000)",
    ),
    (
        "duplicate metric names",
        lambda j: _set(j.metric("Text"), name="Plot"),
        "another metric (not an event metric) has the same name",
    ),
    (
        "duplicate data names",
        lambda j: _set(j.data("names"), name="values"),
        "another metrics data has the same name",
    ),
    (
        "duplicate data ids",
        lambda j: _set(j.data("names").metrics_data_id.id, data=uid("values")),
        "another metrics data has the same id",
    ),
    (
        "duplicate event names",
        lambda j: j.msg.events.add().CopyFrom(j.msg.events[0]),
        "another event has the same name",
    ),
    (
        "NaN scalar",
        lambda j: _set(j.metric("Max speed").metric_values.scalar_metric_values, value=math.nan),
        "a scalar metric value cannot be NaN",
    ),
    (
        "scalar without value",
        lambda j: j.metric("Max speed").metric_values.scalar_metric_values.ClearField("value"),
        "a scalar metric needs a value",
    ),
    (
        "job id differs",
        lambda j: _set(j.metric("Text").job_id.id, data=uid("other job")),
        f"the metric's job id '{uid('other job')}' differs from the output's '{JOB}'",
    ),
    (
        "job id spelt differently",
        _respell_job_id,
        "differs from the output's",
    ),
    (
        "reference spelt differently",
        lambda j: _set(
            j.metric("Image").metric_values.image_metric_values.image_data_id.id,
            data=uid("picture").upper(),
        ),
        f"image data {uid('picture').upper()} is not in the output",
    ),
    (
        "undeclared category",
        lambda j: j.data("grouped").category_names.append("truck"),
        "the category names must be exactly the categories with series "
        "(declared only: ['truck'], series only: [])",
    ),
    (
        "category of the status data differs",
        lambda j: (
            j.data("grouped statuses")
            .series_per_category.category_to_series["car"]
            .statuses.series.append(pb.PASSED_METRIC_STATUS)
        ),
        "'grouped' and its status data 'grouped statuses' must have the same length "
        "in category 'car' (1 and 2)",
    ),
    (
        "state outside the set",
        lambda j: j.data("states").series.strings.series.__setitem__(0, "flying"),
        "states ['flying'] of 'states' are not in the states set",
    ),
    (
        "failure state outside the set",
        lambda j: _states(j).failure_states.append("crashed"),
        "failure states ['crashed'] are not in the states set",
    ),
    (
        "external file without path",
        lambda j: _set(j.data("picture").external_file, path=""),
        "the external file has an empty path",
    ),
    (
        "image of a series",
        lambda j: _set(
            j.metric("Image").metric_values.image_metric_values.image_data_id.id,
            data=uid("values"),
        ),
        "image data 'values' must be EXTERNAL_FILE_DATA_TYPE, not DOUBLE_SERIES_DATA_TYPE",
    ),
    (
        "empty image list",
        lambda j: j.metric("Images").metric_values.image_list_metric_values.ClearField(
            "image_data_ids"
        ),
        "an image list metric needs at least one image",
    ),
    (
        "empty text",
        lambda j: _set(j.metric("Text").metric_values.text_metric_values, text=""),
        "a text metric needs non-empty text",
    ),
    (
        "plotly without JSON",
        lambda j: j.metric("Plot").metric_values.plotly_metric_values.ClearField("json"),
        "a plotly metric needs its JSON",
    ),
    (
        "tag without value",
        lambda j: j.metric("Text").tags.add(key="team"),
        "tag 0 ('team': '') needs a key and a value",
    ),
    (
        "type and values disagree",
        lambda j: _set(j.metric("Text"), type=pb.SCALAR_METRIC_TYPE),
        "a metric of type SCALAR_METRIC_TYPE needs scalar_metric_values, "
        "but it has text_metric_values",
    ),
    (
        "no values",
        lambda j: j.metric("Text").ClearField("metric_values"),
        "the metric has no values",
    ),
    (
        "no job id on metric",
        lambda j: j.metric("Text").ClearField("job_id"),
        "the metric has no job id",
    ),
    (
        "event lists a missing metric",
        lambda j: _set(j.msg.events[0].metrics[0].id, data=uid("gone")),
        f"metric {uid('gone')} is not in the output",
    ),
    (
        "event lists a metric twice",
        lambda j: j.msg.events[0].metrics.add().id.CopyFrom(j.msg.events[0].metrics[0].id),
        "the event lists two metrics named 'Stop speed'",
    ),
    (
        "event timestamp types differ",
        lambda j: j.msg.events.add().CopyFrom(
            pb.Event(
                name="Go",
                status=pb.PASSED_METRIC_STATUS,
                importance=pb.LOW_IMPORTANCE,
                timestamp_type=pb.RELATIVE_TIMESTAMP,
                event_id=pb.EventId(id=uuid_pb2.UUID(data=uid("Go"))),
            )
        ),
        "all events of an output must have the same timestamp type",
    ),
    (
        "empty series",
        lambda j: j.data("values").series.doubles.ClearField("series"),
        "the series is empty",
    ),
    (
        "series of the wrong element type",
        lambda j: j.data("names").series.doubles.series.append(1.0),
        "the series holds doubles, but data type STRING_SERIES_DATA_TYPE needs strings",
    ),
    (
        "double-over-time lists differ",
        lambda j: j.metric(
            "Speed"
        ).metric_values.double_over_time_metric_values.failure_definition.add(),
        "the lists of data must have the same length (got 1 doubles, 1 statuses, "
        "2 failure definitions)",
    ),
    (
        "summary index needs indexed data",
        lambda j: _set(j.metric("Summary").metric_values.double_metric_values, string_index="car"),
        "value data 'grouped' is DOUBLE_SERIES_DATA_TYPE, but must be "
        "INDEXED_DOUBLE_SERIES_DATA_TYPE",
    ),
]


@pytest.mark.parametrize(
    ("mutate", "expected"), [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED]
)
def test_rule(mutate: Mutation, expected: str) -> None:
    job = Job()
    mutate(job)
    assert not resim_accepts(job.msg), "the case must be one ReSim refuses"
    problems = [str(p) for p in find_problems(job.msg)]
    assert any(expected in p for p in problems), "\n".join(problems)
    with pytest.raises(InvalidMetricsError) as info:
        validate_job_metrics(job.msg)
    assert info.value.problems
    assert str(info.value).startswith(problems[0])


def _external_indexed_by_external(job: Job) -> None:
    other = job.msg.metrics_data.add(name="other", data_type=pb.EXTERNAL_FILE_DATA_TYPE)
    other.metrics_data_id.id.data = uid("other")
    other.external_file.path = "b.png"
    picture = job.data("picture")
    picture.is_indexed = True
    picture.index_data_id.id.data = uid("other")
    picture.index_data_type = pb.EXTERNAL_FILE_DATA_TYPE


def _respell_everything(job: Job) -> None:
    for spell in (lambda u: "{" + u + "}", lambda u: uuid.UUID(u).urn):
        m = job.add_metric("Respelt", pb.TEXT_METRIC_TYPE)
        m.metric_values.text_metric_values.text = "x"
        m.metric_id.id.data = spell(uid(f"respelt {spell}"))
        m.name = f"Respelt {len(job.msg.job_level_metrics.metrics)}"


ACCEPTED: list[tuple[str, Mutation]] = [
    # ReSim treats every type it does not list as IMAGE, and only refuses unset enums.
    (
        "unknown metric type with image values",
        lambda j: _set(j.metric("Image"), type=99),
    ),
    ("unknown status and importance", lambda j: _set(j.metric("Text"), status=42, importance=9)),
    ("unknown data type holding statuses", lambda j: _odd_data(j)),
    # `$` in ReSim's colour pattern also matches before one final newline.
    ("colour with a trailing newline", lambda j: _batch(j).colors.append("#aabbcc\n")),
    ("ids spelt with braces or as URNs", _respell_everything),
    ("duplicate event ids", lambda j: _dup_event(j)),
    ("event metric used by no event", lambda j: j.msg.events[0].ClearField("metrics")),
    ("external file indexed by an external file", _external_indexed_by_external),
    (
        "metric names repeat among event metrics",
        lambda j: _set(j.metric("Stop speed"), name="Text"),
    ),
    ("nothing but an id", lambda j: _only_ids(j)),
]


def _odd_data(job: Job) -> None:
    odd = job.msg.metrics_data.add(name="odd", data_type=99)
    odd.metrics_data_id.id.data = uid("odd")
    odd.series.statuses.series.append(pb.PASSED_METRIC_STATUS)


def _dup_event(job: Job) -> None:
    last = job.msg.events.add()
    last.CopyFrom(job.msg.events[0])
    last.name = "Stop again"
    last.ClearField("metrics")


def _only_ids(job: Job) -> None:
    job.msg.ClearField("job_level_metrics")
    job.msg.ClearField("metrics_data")
    job.msg.ClearField("events")
    job.msg.job_level_metrics.metrics_status = pb.FAIL_WARN_METRIC_STATUS


@pytest.mark.parametrize("mutate", [c[1] for c in ACCEPTED], ids=[c[0] for c in ACCEPTED])
def test_resim_quirk_accepted(mutate: Mutation) -> None:
    job = Job()
    mutate(job)
    assert resim_accepts(job.msg)
    assert find_problems(job.msg) == []


def test_all_problems_are_collected() -> None:
    job = Job()
    job.metric("Max speed").status = pb.NO_METRIC_STATUS
    job.data("picture").external_file.path = ""
    job.msg.events[0].timestamp.seconds = -5
    problems = find_problems(job.msg)
    assert [p.where.split(" (")[0] for p in problems] == [
        "metric 'Max speed'",
        "data 'picture'",
        "event 'Stop'",
    ]
    error = InvalidMetricsError(problems)
    assert str(error).endswith("(and 2 more)")


def test_unnamed_things_are_still_located() -> None:
    job = Job()
    job.metric("Text").name = ""
    (problem,) = find_problems(job.msg)
    assert str(problem) == f"unnamed metric (id {uid('Text')}): a metric must have a name"
