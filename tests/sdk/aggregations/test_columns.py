"""A batch's jobs as columns: decoded from a summary they equal those built from the same
jobs' listings; a record built on them reads as one built from per-job fields, and every
report aggregation writes the same bytes from either."""

from __future__ import annotations

import math
import statistics
import struct
import uuid
from collections import Counter
from datetime import UTC, datetime, timedelta

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stook.sdk import MetricsWriter
from stook.sdk.aggregations import (
    BatchRecord,
    BatchSummary,
    JobColumns,
    JobSummary,
    SummaryError,
    SummaryJob,
    encode_summary,
)
from stook.sdk.aggregations._columns import JobSummaries
from stook.sdk.aggregations._summary import decode_summary_columns
from stook.sdk.aggregations.report._experiences import _medians
from tests.hypothesis_profiles import examples
from tests.sdk.aggregations.report.test_merge import FACTORIES

T0 = datetime(2024, 3, 1, 12, 0, tzinfo=UTC)
_names = st.sampled_from(["", "e1", "E2 é", "e3"])
_values = st.one_of(
    st.floats(min_value=-1e6, max_value=1e6),
    st.sampled_from([0.0, -0.0, math.inf, -math.inf, math.nan, 1.0, 1.7976931348623157e308]),
)
_jobs = st.builds(
    SummaryJob,
    st.uuids(),
    _names,
    st.sampled_from(["PASSED", "ERROR", "BLOCKER", "WARNING", "CANCELLED", "NEW_ONE"]),
    st.none() | st.sampled_from([uuid.UUID(int=1), uuid.UUID(int=2)]),
    st.booleans(),
    st.dictionaries(
        st.sampled_from(["s", "t", "u"]), st.tuples(_values, st.sampled_from(["", "m"]))
    ),
)
_summaries = st.builds(
    lambda jobs, statuses: BatchSummary(
        tuple(sorted(jobs, key=lambda j: j.job_id.bytes)), dict(sorted(statuses.items()))
    ),
    st.lists(_jobs, max_size=12, unique_by=lambda j: j.job_id),
    st.dictionaries(st.sampled_from(["PASSED", "FAIL_WARN", "ODD"]), st.integers(1, 5)),
)


def _summaries_of(summary: BatchSummary) -> list[JobSummary]:
    return [
        JobSummary(j.job_id, j.experience_name, j.conflated_status, j.experience_id)
        for j in summary.jobs
    ]


def _bits(job: JobSummary) -> tuple[object, ...]:
    """A job comparable with NaN values in it."""
    scalars = {k: struct.pack("<d", v) for k, v in job.scalars.items()}
    return (job.job_id, job.experience_name, job.conflated_status, job.experience_id, scalars)


def _built(summary: BatchSummary) -> JobColumns:
    """What report mode builds from the jobs' listings."""
    jobs = list(reversed(_summaries_of(summary)))  # listings come in any order
    by_id = {j.job_id: j.scalars for j in summary.jobs}
    return JobColumns.build(jobs, [by_id[j.job_id] for j in jobs], summary.metric_statuses)


@examples(60)
@given(summary=_summaries)
def test_summary_columns_equal_columns_built_from_the_listings(summary: BatchSummary) -> None:
    decoded = decode_summary_columns(encode_summary(summary))
    assert decoded.columns == _built(summary)
    assert decoded.jobs_with_metrics == sum(j.has_metrics for j in summary.jobs)


@examples(60)
@given(summary=_summaries)
def test_a_record_on_columns_reads_as_the_per_job_fields(summary: BatchSummary) -> None:
    record = BatchRecord.with_columns(uuid.UUID(int=1), "b", T0, _built(summary))
    assert len(record.jobs) == len(summary.jobs)
    assert [_bits(j) for j in record.jobs] == [
        _bits(
            JobSummary(
                j.job_id,
                j.experience_name,
                j.conflated_status,
                j.experience_id,
                {n: v for n, (v, _) in j.scalars.items()},
            )
        )
        for j in summary.jobs
    ]
    pooled: dict[str, list[float]] = {}
    units: dict[str, str] = {}
    for job in summary.jobs:
        for name, (value, unit) in job.scalars.items():
            pooled.setdefault(name, []).append(value)
            units.setdefault(name, unit)
    assert {k: [struct.pack("<d", v) for v in vs] for k, vs in record.job_scalars.items()} == {
        k: [struct.pack("<d", v) for v in sorted(vs)] for k, vs in sorted(pooled.items())
    }
    assert dict(record.job_scalar_units) == dict(sorted(units.items()))
    assert list(record.job_metric_statuses) == sorted(Counter(summary.metric_statuses).elements())
    assert len(record.job_metric_statuses) == sum(summary.metric_statuses.values())
    assert record.job_columns() is record.columns


def _records_both_ways(
    summaries: list[BatchSummary], draw_hours: list[int]
) -> tuple[list[BatchRecord], list[BatchRecord]]:
    on_columns, on_fields = [], []
    for n, (summary, hours) in enumerate(zip(summaries, draw_hours, strict=False)):
        batch_id, created = uuid.UUID(int=100 + n), T0 + timedelta(hours=hours)
        record = BatchRecord.with_columns(batch_id, f"b{n}", created, _built(summary))
        on_columns.append(record)
        on_fields.append(
            BatchRecord(
                batch_id,
                f"b{n}",
                created,
                jobs=list(record.jobs),
                job_scalars={k: list(v) for k, v in record.job_scalars.items()},
                job_scalar_units=dict(record.job_scalar_units),
                job_metric_statuses=list(record.job_metric_statuses),
            )
        )
    return on_columns, on_fields


def _written(factory: object, records: list[BatchRecord]) -> bytes:
    aggregation = factory()  # type: ignore[operator]
    for record in records:
        aggregation.update(record)
    writer = MetricsWriter(uuid.UUID(int=9), deterministic=True)
    aggregation.finish(writer)
    return writer.serialize()


@examples(30)
@given(
    summaries=st.lists(_summaries, min_size=1, max_size=8),
    hours=st.lists(st.integers(0, 48), min_size=8, max_size=8),
)
def test_every_report_aggregation_writes_the_same_from_columns_or_fields(
    summaries: list[BatchSummary], hours: list[int]
) -> None:
    on_columns, on_fields = _records_both_ways(summaries, hours)
    for kind, factory in FACTORIES.items():
        assert _written(factory, on_columns) == _written(factory, on_fields), kind


@examples(80)
@given(
    groups=st.lists(st.integers(0, 3), max_size=30).flatmap(
        lambda g: st.tuples(st.just(g), st.lists(_values, min_size=len(g), max_size=len(g)))
    )
)
def test_group_medians_are_statistics_median(groups: tuple[list[int], list[float]]) -> None:
    codes, values = groups
    want: dict[int, float] = {}
    for code in sorted(set(codes)):
        mine = [v for c, v in zip(codes, values, strict=True) if c == code]
        finite = sorted(v + 0.0 for v in mine if math.isfinite(v))
        if finite:
            want[code] = statistics.median(finite)
    got = dict(_medians(np.asarray(codes, dtype=np.int64), np.asarray(values, dtype=np.float64)))
    assert {k: struct.pack("<d", v) for k, v in got.items()} == {
        k: struct.pack("<d", v) for k, v in want.items()
    }


@pytest.mark.parametrize(
    ("mangle", "message"),
    [
        (lambda b: b[: len(b) // 2], "truncated"),
        (lambda b: b + b"\x00", "past its end"),
        (lambda b: b[:6] + b"\x03" + b[7:], "index width 3"),
    ],
)
def test_bytes_that_are_no_summary_are_refused_as_columns(mangle: object, message: str) -> None:
    jobs = tuple(
        SummaryJob(uuid.UUID(int=i + 1), f"e{i % 2}", "PASSED", None, True, {"s": (1.0, "m")})
        for i in range(6)
    )
    payload = encode_summary(BatchSummary(jobs, {"PASSED": 6}))
    with pytest.raises(SummaryError, match=message):
        decode_summary_columns(mangle(payload))  # type: ignore[operator]


def test_report_aggregations_read_columns_and_make_no_job_objects(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    jobs = tuple(
        SummaryJob(uuid.UUID(int=i + 1), f"e{i % 3}", "PASSED", None, True, {"s": (i / 3, "m")})
        for i in range(30)
    )
    summary = BatchSummary(jobs, {"PASSED": 30})
    records = [
        BatchRecord.with_columns(
            uuid.UUID(int=100 + n), f"b{n}", T0 + timedelta(hours=n), _built(summary)
        )
        for n in range(7)
    ]
    for record in records:
        assert isinstance(record.jobs, JobSummaries)

    def made(columns: JobColumns) -> list[JobSummary]:
        raise AssertionError("an aggregation made the job objects")

    monkeypatch.setattr(JobColumns, "job_summaries", made)
    for factory in FACTORIES.values():
        _written(factory, records)


def test_the_views_are_sequences_and_mappings() -> None:
    jobs = tuple(
        SummaryJob(uuid.UUID(int=i + 1), "e", "PASSED", None, True, {"s": (3.0 - i, "m")})
        for i in range(3)
    )
    record = BatchRecord.with_columns(
        uuid.UUID(int=1), "b", T0, _built(BatchSummary(jobs, {"PASSED": 2, "ODD": 1}))
    )
    assert record.jobs[0].job_id == uuid.UUID(int=1)
    assert [j.scalars["s"] for j in record.jobs[1:]] == [2.0, 1.0]
    assert record.jobs != "abc"  # type: ignore[comparison-overlap]
    assert repr(record.jobs) == "JobSummaries(3 jobs)"
    assert record.job_scalars["s"] == [1.0, 2.0, 3.0]
    assert record.job_scalars.get("t") is None
    assert record.job_scalars != 1  # type: ignore[comparison-overlap]
    assert "PooledScalars" in repr(record.job_scalars)
    assert record.job_metric_statuses[0] == "ODD"
    assert list(record.job_metric_statuses[1:]) == ["PASSED", "PASSED"]
    assert record.job_metric_statuses != "ODD"
    assert "StatusList" in repr(record.job_metric_statuses)
    assert record.job_columns() != "columns"
    assert record.job_columns().job_id(2) == uuid.UUID(int=3)
