"""stook's validator: the rules of the output as a whole, their messages, ReSim's quirks.

Every case also runs ReSim's validator, so that a message here can never claim
a decision ReSim would not make. The rules of each metric type's values are in
`test_validate_values.py`.
"""

from __future__ import annotations

import uuid

import pytest

from stook.proto import metrics_pb2 as pb
from stook.proto import uuid_pb2
from stook.sdk import InvalidMetricsError, find_problems, validate_job_metrics
from tests.sdk.valid_output import (
    JOB,
    Job,
    Mutation,
    batch_values,
    drop_data,
    resim_accepts,
    set_fields,
    uid,
)


def test_base_output_is_valid() -> None:
    job = Job()
    assert resim_accepts(job.msg)
    assert find_problems(job.msg) == []
    validate_job_metrics(job.msg)


def _respell_job_id(job: Job) -> None:
    job.metric("Text").job_id.id.data = JOB.upper()


SPEEDS = f"data 'speeds' (id {uid('speeds')})"


REFUSED: list[tuple[str, Mutation, str]] = [
    (
        "index type disagrees",
        lambda j: set_fields(
            j.data("states"), index_data_type=pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE
        ),
        "index_data_type is INDEXED_TIMESTAMP_SERIES_DATA_TYPE, but the index data 'times' "
        "is TIMESTAMP_SERIES_DATA_TYPE",
    ),
    (
        "missing index",
        drop_data("names"),
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
        lambda j: set_fields(j.metric("Max speed"), status=pb.NO_METRIC_STATUS),
        f"metric 'Max speed' (id {uid('Max speed')}): the metric status is unset",
    ),
    (
        "unset metric type",
        lambda j: set_fields(j.metric("Text"), type=pb.NO_METRIC_TYPE),
        "the metric type is unset",
    ),
    (
        "unset importance",
        lambda j: set_fields(j.metric("Text"), importance=pb.NO_SPECIFIED_IMPORTANCE),
        "the metric importance is unset",
    ),
    (
        "unset data type",
        lambda j: set_fields(j.data("grouped"), data_type=pb.NO_DATA_TYPE),
        "the data type is unset",
    ),
    (
        "unset overall status",
        lambda j: set_fields(j.msg, metrics_status=pb.NO_METRIC_STATUS),
        "output: the output has no overall status",
    ),
    (
        "unset collection status",
        lambda j: set_fields(j.msg.job_level_metrics, metrics_status=pb.NO_METRIC_STATUS),
        "output: the job-level metric collection has no status",
    ),
    (
        "bad metric id",
        lambda j: set_fields(j.metric("Max speed").metric_id.id, data="nope"),
        "metric 'Max speed' (id nope): id 'nope' is not a valid UUID",
    ),
    (
        "missing job id",
        lambda j: j.msg.ClearField("job_id"),
        "output: job id is missing",
    ),
    (
        "negative timestamp",
        lambda j: set_fields(j.msg.events[0].timestamp, seconds=-1),
        f"event 'Stop' (id {uid('Stop')}): the event timestamp has negative seconds (-1)",
    ),
    (
        "nanos too big",
        lambda j: set_fields(j.msg.events[0].timestamp, nanos=1_000_000_000),
        "the event timestamp nanos must be in [0, 1e9) (got 1000000000)",
    ),
    (
        "duplicate metric names",
        lambda j: set_fields(j.metric("Text"), name="Plot"),
        "another metric (not an event metric) has the same name",
    ),
    (
        "duplicate data names",
        lambda j: set_fields(j.data("names"), name="values"),
        "another metrics data has the same name",
    ),
    (
        "duplicate data ids",
        lambda j: set_fields(j.data("names").metrics_data_id.id, data=uid("values")),
        "another metrics data has the same id",
    ),
    (
        "duplicate event names",
        lambda j: j.msg.events.add().CopyFrom(j.msg.events[0]),
        "another event has the same name",
    ),
    (
        "job id differs",
        lambda j: set_fields(j.metric("Text").job_id.id, data=uid("other job")),
        f"the metric's job id '{uid('other job')}' differs from the output's '{JOB}'",
    ),
    (
        "job id spelt differently",
        _respell_job_id,
        "differs from the output's",
    ),
    (
        "undeclared category",
        lambda j: j.data("grouped").category_names.append("truck"),
        "the category names must be exactly the categories with series "
        "(declared only: ['truck'], series only: [])",
    ),
    (
        "external file without path",
        lambda j: set_fields(j.data("picture").external_file, path=""),
        "the external file has an empty path",
    ),
    (
        "tag without value",
        lambda j: j.metric("Text").tags.add(key="team"),
        "tag 0 ('team': '') needs a key and a value",
    ),
    (
        "type and values disagree",
        lambda j: set_fields(j.metric("Text"), type=pb.SCALAR_METRIC_TYPE),
        "a metric of type SCALAR_METRIC_TYPE needs scalar_metric_values, "
        "but it has text_metric_values",
    ),
    (
        "no job id on metric",
        lambda j: j.metric("Text").ClearField("job_id"),
        "the metric has no job id",
    ),
    (
        "event lists a missing metric",
        lambda j: set_fields(j.msg.events[0].metrics[0].id, data=uid("gone")),
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
        lambda j: set_fields(j.metric("Image"), type=99),
    ),
    (
        "unknown status and importance",
        lambda j: set_fields(j.metric("Text"), status=42, importance=9),
    ),
    ("unknown data type holding statuses", lambda j: _odd_data(j)),
    # `$` in ReSim's colour pattern also matches before one final newline.
    ("colour with a trailing newline", lambda j: batch_values(j).colors.append("#aabbcc\n")),
    ("ids spelt with braces or as URNs", _respell_everything),
    ("duplicate event ids", lambda j: _dup_event(j)),
    ("event metric used by no event", lambda j: j.msg.events[0].ClearField("metrics")),
    ("external file indexed by an external file", _external_indexed_by_external),
    (
        "metric names repeat among event metrics",
        lambda j: set_fields(j.metric("Stop speed"), name="Text"),
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
