"""The output a writer builds: data and index chains, events, overall status, rollback."""

from __future__ import annotations

import uuid
from datetime import datetime, timedelta

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    MetricImportance,
    MetricStatus,
    MetricsWriter,
    SeriesKind,
    WriterError,
    data,
    find_problems,
)
from tests.sdk.support import JOB, T0, T0_NS, metric, writer_error, written

# ---------------------------------------------------------------- the job


def test_writer_refuses_a_job_id_that_is_not_a_uuid() -> None:
    with writer_error("job ID 'job-1' is not a UUID"):
        MetricsWriter("job-1")


# ---------------------------------------------------------------- events


def test_events_with_their_metrics_round_trip() -> None:
    w = MetricsWriter(JOB, deterministic=True)
    brake1 = w.scalar("Deceleration", 6.5, unit="m/s^2", event=True)
    brake2 = w.scalar("Deceleration", 7.0, unit="m/s^2", event=True, status=MetricStatus.FAIL_WARN)
    note = w.text("Why", "wet road", event=True)
    w.event(
        "Hard brake",
        timestamp=T0 + timedelta(seconds=21, microseconds=5),
        metrics=[brake1, note],
        status=MetricStatus.FAIL_WARN,
        importance=MetricImportance.HIGH,
        description="decel above 6",
        tags=["braking", "wet"],
    )
    w.event("Second brake", timestamp=T0_NS + 1, metrics=[brake2])
    w.event("Bare", timestamp=T0)
    view = written(w)
    assert [m.name for m in view.metrics] == ["Deceleration", "Deceleration", "Why"]
    assert all(m.event_metric for m in view.metrics)
    assert len({m.id for m in view.metrics}) == 3
    e1, e2, e3 = view.events
    assert e1.name == "Hard brake"
    assert e1.description == "decel above 6"
    assert e1.tags == ("braking", "wet")
    assert e1.metric_ids == (brake1.id, note.id)
    assert e1.status is MetricStatus.FAIL_WARN
    assert e1.importance is MetricImportance.HIGH
    assert e1.timestamp_ns == T0_NS + 21_000_005_000
    assert e1.timestamp_type == "absolute"
    assert e2.metric_ids == (brake2.id,)
    assert e2.status is MetricStatus.PASSED
    assert e2.importance is MetricImportance.MEDIUM
    assert e2.timestamp_ns == T0_NS + 1
    assert e3.metric_ids == ()
    assert e3.description == ""
    assert e3.tags == ()
    assert len({e.id for e in view.events}) == 3
    # Event metrics count towards the overall status.
    assert view.status is MetricStatus.FAIL_WARN


def test_relative_events() -> None:
    w = MetricsWriter(JOB)
    w.event("start", timestamp=0, relative=True)
    w.event("later", timestamp=1_500_000_000, relative=True)
    view = written(w)
    assert [(e.timestamp_type, e.timestamp_ns) for e in view.events] == [
        ("relative", 0),
        ("relative", 1_500_000_000),
    ]
    assert view.events[1].raw.timestamp_type == pb.RELATIVE_TIMESTAMP
    assert (view.events[1].raw.timestamp.seconds, view.events[1].raw.timestamp.nanos) == (
        1,
        500_000_000,
    )


def test_event_metrics_may_share_a_name_with_each_other_and_with_a_normal_metric() -> None:
    w = MetricsWriter(JOB)
    w.scalar("x", 1.0)
    e1 = w.scalar("x", 2.0, event=True)
    e2 = w.scalar("x", 3.0, event=True)
    w.event("e1", timestamp=1, metrics=[e1])
    w.event("e2", timestamp=2, metrics=[e2])
    view = written(w)
    assert [m.value for m in view.metrics] == [1.0, 2.0, 3.0]
    assert w.has_metric("x")
    with pytest.raises(WriterError, match=r"^a metric named 'x' was already written$"):
        w.scalar("x", 4.0)


def test_event_errors() -> None:
    w = MetricsWriter(JOB)
    plain = w.scalar("plain", 1.0)
    m1 = w.scalar("m", 1.0, event=True)
    m2 = w.scalar("m", 2.0, event=True)
    with writer_error("event names must be non-empty and unique: ''"):
        w.event("", timestamp=1)
    w.event("e", timestamp=1)
    with writer_error("event names must be non-empty and unique: 'e'"):
        w.event("e", timestamp=2)
    with writer_error("event 'r': all events must be all absolute or all relative"):
        w.event("r", timestamp=2, relative=True)
    with writer_error("event 'f': metric 'plain' was not written with event=True"):
        w.event("f", timestamp=2, metrics=[plain])
    with writer_error("event 'f': its metrics need unique names"):
        w.event("f", timestamp=2, metrics=[m1, m2])
    with writer_error("timestamp 2026-01-01T00:00:00 has no time zone; use an aware one"):
        w.event("f", timestamp=datetime(2026, 1, 1))
    assert [e.name for e in written(w).events] == ["e"]
    r = MetricsWriter(JOB)
    r.event("r", timestamp=1, relative=True)
    with writer_error("event 'a': all events must be all absolute or all relative"):
        r.event("a", timestamp=2)


def test_event_timestamp_before_the_epoch_is_refused() -> None:
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError):
        w.event("e", timestamp=-5)


# ---------------------------------------------------------------- data written transitively


def test_index_chains_are_written_transitively_once_index_first() -> None:
    root = data.timestamps("root", [1, 2])
    mid = data.uuids("mid", [uuid.UUID(int=1), uuid.UUID(int=2)], index=root)
    leaf = data.strings("leaf", ["a", "b"], index=mid)
    values = data.doubles("values", [1.0, 2.0], index=leaf)
    other = data.doubles("other", [3.0, 4.0], index=mid)
    w = MetricsWriter(JOB)
    w.histogram("h1", values, buckets=1, lower=0, upper=1)
    w.histogram("h2", other, buckets=1, lower=0, upper=1)
    w.double_summary("s", values, index=0)
    view = written(w)
    names = [d.name for d in view.data]
    assert names[:4] == ["root", "mid", "leaf", "values"]
    assert sorted(names) == sorted(
        [
            "root",
            "mid",
            "leaf",
            "values",
            "values (PASSED status)",
            "other",
            "other (PASSED status)",
        ]
    )
    by = view.data_by_name
    assert by["values"].index_id == by["leaf"].id
    assert by["leaf"].index_id == by["mid"].id
    assert by["mid"].index_id == by["root"].id
    assert by["other"].index_id == by["mid"].id
    assert by["values (PASSED status)"].index_id == by["leaf"].id
    assert [d.name for d in w.data] == names


def test_add_data_writes_data_that_no_metric_uses() -> None:
    idx = data.strings("labels", ["a"])
    alone = data.doubles("alone", [1.0], index=idx)
    w = MetricsWriter(JOB)
    w.add_data(alone)
    w.add_data(alone, idx)  # the same objects again: no change
    view = written(w)
    assert view.metrics == ()
    assert [d.name for d in view.data] == ["labels", "alone"]
    assert view.status is MetricStatus.PASSED


def test_two_different_data_with_one_name_are_refused() -> None:
    w = MetricsWriter(JOB)
    w.add_data(data.doubles("x", [1.0]))
    msg = r"^two different metrics data are named 'x'$"
    with pytest.raises(WriterError, match=msg):
        w.add_data(data.doubles("x", [1.0]))  # equal values, still another item
    with pytest.raises(WriterError, match=msg):
        w.add_data(data.doubles("y", [1.0], index=data.strings("x", ["a"])))
    with pytest.raises(WriterError, match=msg):
        w.histogram("h", data.doubles("x", [2.0]), buckets=1, lower=0, upper=1)


def test_empty_series_are_refused_when_written() -> None:
    # Building one is harmless (an aggregation may fill it later); writing one is not.
    empty = data.doubles("x", [])
    w = MetricsWriter(JOB)
    with pytest.raises(WriterError, match="metrics data 'x' is empty"):
        w.add_data(empty)
    with pytest.raises(WriterError, match="metrics data 'x' is empty"):
        w.histogram("h", empty, buckets=2, lower=0, upper=1)
    with pytest.raises(WriterError, match="metrics data 'pc' is empty"):
        w.add_data(data.per_category("pc", SeriesKind.DOUBLE, {"a": [1.0], "b": []}))
    assert w.to_proto().metrics_data == []
    assert not w.has_metric("h")


# ---------------------------------------------------------------- metric names and failed calls


def test_a_failed_metric_call_leaves_the_writer_unchanged() -> None:
    w = MetricsWriter(JOB)
    w.add_data(data.doubles("v", [1.0]))
    with pytest.raises(WriterError):
        w.histogram("h", data.doubles("v", [2.0]), buckets=1, lower=0, upper=1)
    times = data.timestamps("t", [1])
    with pytest.raises(WriterError):
        w.double_over_time("d", data.doubles("dv", [1.0], index=times), legend=["a", "b"])
    assert not w.has_metric("h")
    assert not w.has_metric("d")
    assert w.metrics == []
    assert find_problems(w.to_proto()) == []


def test_duplicate_metric_names_are_refused_across_types() -> None:
    w = MetricsWriter(JOB)
    w.text("n", "t")
    with pytest.raises(WriterError, match=r"^a metric named 'n' was already written$"):
        w.scalar("n", 1.0)
    with pytest.raises(WriterError, match=r"^a metric named 'n' was already written$"):
        w.image("n", data.external_file("f", "f.png"))


# ---------------------------------------------------------------- overall status


@pytest.mark.parametrize(
    ("statuses", "expected"),
    [
        ([], MetricStatus.PASSED),
        ([MetricStatus.PASSED, MetricStatus.NOT_APPLICABLE, MetricStatus.RAW], MetricStatus.PASSED),
        ([MetricStatus.PASSED, MetricStatus.FAIL_WARN], MetricStatus.FAIL_WARN),
        (
            [MetricStatus.FAIL_WARN, MetricStatus.FAIL_BLOCK, MetricStatus.PASSED],
            MetricStatus.FAIL_BLOCK,
        ),
        ([MetricStatus.FAIL_BLOCK], MetricStatus.FAIL_BLOCK),
    ],
)
def test_overall_status_is_computed_from_the_metrics(
    statuses: list[MetricStatus], expected: MetricStatus
) -> None:
    w = MetricsWriter(JOB)
    for i, s in enumerate(statuses):
        w.text(f"m{i}", "x", status=s)
    assert w.status is expected
    view = written(w)
    assert view.status is expected
    assert view.raw.job_level_metrics.metrics_status == int(expected)


def test_status_follows_handle_changes_and_override_can_be_cleared() -> None:
    w = MetricsWriter(JOB)
    h = w.scalar("s", 1.0)
    before = w.status
    h.status(MetricStatus.FAIL_BLOCK)
    assert before is MetricStatus.PASSED
    assert w.status is MetricStatus.FAIL_BLOCK
    w.override_status(MetricStatus.PASSED)
    view = written(w)
    assert view.status is MetricStatus.PASSED
    assert view.raw.job_level_metrics.metrics_status == pb.PASSED_METRIC_STATUS
    assert metric(view, "s").status is MetricStatus.FAIL_BLOCK
    w.override_status(MetricStatus.NOT_APPLICABLE)
    assert written(w).status is MetricStatus.NOT_APPLICABLE
    w.override_status(None)
    assert w.status is MetricStatus.FAIL_BLOCK
    assert written(w).status is MetricStatus.FAIL_BLOCK
