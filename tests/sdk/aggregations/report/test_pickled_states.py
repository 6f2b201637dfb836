"""Every built-in report aggregation's partial state travels between processes: it pickles
to an equal state, merging unpickled partials writes the bytes one fold writes, and its
pickled size does not depend on the number of jobs in a batch -- it grows with batches (a
point on a line, a count per batch) by at most `per_batch` bytes, whatever their jobs.
"""

from __future__ import annotations

import pickle
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from typing import Any

import pytest

from stook.sdk import MetricsWriter
from stook.sdk.aggregations import (
    BatchRecord,
    JobSummary,
    ReportAggregation,
    Scalar,
)
from stook.sdk.aggregations._registry import REPORT_BUILTIN
from stook.sdk.aggregations.report import (
    BatchMetricStatusCounts,
    ChangePoints,
    FlakyExperiences,
    JobMetricStatusCounts,
    JobScalarDistributions,
    MostFailedExperiences,
    ScalarLines,
    TestStatusOverTime,
    UnstableExperiences,
    default_report_aggregations,
)

REPORT_ID = uuid.UUID("0e0e0e0e-1111-4222-8333-444444444444")
PROJECT_ID = "5e5e5e5e-1111-4222-8333-444444444444"
T0 = datetime(2024, 3, 1, 12, 0, tzinfo=UTC)
STATUSES = ("PASSED", "WARNING", "BLOCKER", "ERROR", "PASSED", "CANCELLED")
EXPERIENCES = 10
#: a count may take a few more bytes when batches have more jobs
COUNT_SLACK_PER_BATCH = 16


def _jobs(count: int, salt: int) -> list[JobSummary]:
    return [
        JobSummary(
            uuid.UUID(int=salt * 1_000_003 + i + 1),
            f"experience {i % EXPERIENCES}",
            STATUSES[(i + salt) % len(STATUSES)],
            scalars={"s": (i * 37 + salt) % 101 / 7, "t": float(i % 5 + salt % 3)},
        )
        for i in range(count)
    ]


def batches(count: int, jobs: int) -> list[BatchRecord]:
    """`count` batches of `jobs` jobs; a handful of job lists is reused (cheap, and as
    varied as the state needs)."""
    pool = [_jobs(jobs, salt) for salt in range(4)]
    out = []
    for b in range(count):
        summaries = pool[b % len(pool)]
        out.append(
            BatchRecord(
                batch_id=uuid.UUID(int=b + 1),
                name=f"nightly {b}",
                created=T0 + timedelta(hours=6 * b),
                scalars={
                    "a": Scalar(10.0 + b % 7, "m", "PASSED"),
                    "b": Scalar(float(b % 3 == 0), "", "FAIL_WARN"),
                },
                metric_statuses=("PASSED", "FAIL_WARN"),
                jobs=summaries,
                job_scalars={name: [job.scalars[name] for job in summaries] for name in ("s", "t")},
                job_scalar_units={"s": "m", "t": ""},
                job_metric_statuses=("PASSED",) * (jobs % 7) + ("FAIL_BLOCK",),
                build_id=uuid.UUID(int=b % 3 + 1),
            )
        )
    return out


@dataclass(frozen=True)
class Case:
    kind: str  # the registry's kind, or "default"
    factory: Callable[[], ReportAggregation]
    #: bytes the pickled state may grow per batch
    per_batch: float
    why: str


CASES = [
    Case("scalar_lines", ScalarLines, 160, "a point and value per batch metric (2) and batch"),
    Case("most_failed_experiences", MostFailedExperiences, 20, "each batch's ID"),
    Case("flaky_experiences", FlakyExperiences, 140, "an outcome per experience and batch"),
    Case(
        "test_status_over_time",
        lambda: TestStatusOverTime(project_id=PROJECT_ID),
        120,
        "a count per status and batch",
    ),
    Case("job_metric_status_counts", JobMetricStatusCounts, 0, "counts"),
    Case("batch_metric_status_counts", BatchMetricStatusCounts, 0, "counts"),
    Case(
        "job_scalar_distributions",
        JobScalarDistributions,
        200,
        "three quantiles per job metric (2) and batch",
    ),
    Case(
        "change_points",
        ChangePoints,
        270,
        "a value per batch metric and batch; failures per experience and batch",
    ),
    Case(
        "unstable_experiences",
        UnstableExperiences,
        450,
        "a median per experience (10), job metric (2) and batch",
    ),
]


def written(aggregation: ReportAggregation) -> bytes:
    writer = MetricsWriter(REPORT_ID, deterministic=True)
    aggregation.finish(writer)
    return writer.serialize()


def fold(aggregation: ReportAggregation, records: list[BatchRecord]) -> ReportAggregation:
    for record in records:
        aggregation.update(record)
    return aggregation


def size(aggregation: ReportAggregation) -> int:
    return len(pickle.dumps(aggregation, pickle.HIGHEST_PROTOCOL))


def test_every_registry_kind_and_default_has_a_case() -> None:
    assert set(REPORT_BUILTIN) <= {case.kind for case in CASES}
    defaults = default_report_aggregations(project_id=PROJECT_ID)
    assert {type(a) for a in defaults} <= {type(case.factory()) for case in CASES}


def travelled(partial: ReportAggregation) -> Any:
    return pickle.loads(pickle.dumps(partial, pickle.HIGHEST_PROTOCOL))


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.kind)
def test_a_partial_pickles_to_an_equal_state_that_merges_alike(case: Case) -> None:
    records = batches(12, 30)
    partial = fold(case.factory(), records)
    copy = travelled(partial)
    assert copy == partial
    assert written(copy) == written(partial)
    shards = [travelled(fold(case.factory(), records[i::3])) for i in range(3)]
    merged = shards[0]
    for other in shards[1:]:
        merged.merge(other)
    assert written(merged) == written(partial)
    more = batches(16, 30)[12:]
    assert written(fold(copy, more)) == written(fold(partial, more))


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.kind)
def test_a_pickled_partial_grows_with_batches_not_jobs(case: Case) -> None:
    few_jobs = size(fold(case.factory(), batches(40, 10)))
    many_jobs = size(fold(case.factory(), batches(40, 1_000)))
    assert many_jobs - few_jobs <= 40 * COUNT_SLACK_PER_BATCH, (few_jobs, many_jobs)
    many_batches = size(fold(case.factory(), batches(400, 10)))
    growth = (many_batches - few_jobs) / 360
    if case.per_batch == 0:
        assert many_batches - few_jobs <= 64, f"{few_jobs} -> {many_batches} ({case.why})"
    else:
        assert growth <= case.per_batch, f"{growth:.1f} bytes a batch ({case.why})"
