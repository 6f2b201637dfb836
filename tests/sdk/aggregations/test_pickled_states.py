"""Every built-in batch aggregation's partial state travels between processes: it pickles to
an equal state, merging unpickled partials writes the bytes one fold writes, and its
pickled size is compact -- flat in the number of jobs where the output needs only counts,
and at most `per_job` bytes more per job where it needs each job's values (exact
quantiles, means summed exactly in any order, the per-job values a HISTOGRAM draws).

Sizes are measured after 1,000 and after 10,000 jobs (the same jobs, reused under new IDs).
"""

from __future__ import annotations

import dataclasses
import pickle
import uuid
from collections.abc import Callable
from typing import Any

import numpy as np
import polars as pl
import pytest

from stook.sdk import MetricsWriter
from stook.sdk.aggregations import (
    BatchAggregation,
    BatchSummaryWriter,
    ByExperienceTag,
    CategoryTotals,
    EventCounts,
    JobRecord,
    JobStatusCounts,
    MergedHistogram,
    MetricStatusCounts,
    ParameterSweep,
    PassRate,
    Scalar,
    ScalarDefaults,
    ScalarStats,
    WeightedMean,
    default_batch_aggregations,
)
from stook.sdk.aggregations._registry import BUILTIN
from stook.sdk.aggregations.baseline import BaselineComparison, BaselineInfo
from tests.sdk.aggregations.job_outputs import job_with
from tests.sdk.aggregations.support import BATCH_ID

SMALL, LARGE = 1_000, 10_000
STATUSES = ("PASSED", "WARNING", "BLOCKER", "ERROR", "PASSED")
BUCKETS = [(0.0, 10.0), (10.0, 20.0), (20.0, 30.0), (30.0, 40.0)]
SERIES_VALUES = 8  # per job, in series "s"
SCALARS = 3  # per job: a, b, w
#: a count or a Counter's count may take a few more bytes at 10,000 than at 1,000
FLAT_SLACK = 64


def _template(i: int) -> JobRecord:
    record = job_with(
        histogram=("Speed histogram", [1.0 + i, 12.0, 25.0 + i / 2, 39.0], BUCKETS),
        bars=("Detections", {"found": {"car": 3.0 + i, "bus": 1.0}, "missed": {"car": 1.0}}),
        per_category=("per class", {"car": [1.0, 2.0 + i], "truck": [4.0], "bike": [0.5 * i]}),
        scalars={"a": Scalar(1.5 * i - 4, "m"), "b": Scalar(i * i / 7), "w": Scalar(1.0 + i % 3)},
        parameters={"p": str(i % 4), "q": ["slow", "fast"][i % 2]},
        events=[("brake", "PASSED"), ("swerve", "FAIL_WARN")][: i % 3],
        tags=[f"tag {i % 3}"],
    )
    series = pl.Series("s", [(i * 7 + k * 3) % 23 - 11.5 for k in range(SERIES_VALUES)])
    return dataclasses.replace(
        record,
        series={"s": series},
        metric_statuses=("PASSED", "FAIL_WARN", "RAW")[: 1 + i % 3],
    )


TEMPLATES = [_template(i) for i in range(12)]


def jobs(start: int, stop: int) -> list[JobRecord]:
    """Jobs start..stop-1: the templates in turn, each under its own ID, experience, status."""
    return [
        dataclasses.replace(
            TEMPLATES[i % len(TEMPLATES)],
            job_id=uuid.UUID(int=i + 1),
            conflated_status=STATUSES[i % len(STATUSES)],
            experience_name=f"experience {i % 50}",
            experience_id=uuid.UUID(int=1_000_000 + i % 50),
        )
        for i in range(start, stop)
    ]


@dataclasses.dataclass(frozen=True)
class Case:
    kind: str  # the registry's kind, or "default" for a default aggregation
    factory: Callable[[], BatchAggregation]
    #: bytes the pickled state may grow per job (plus half a byte: counts that grow); 0:
    #: it must stay flat
    per_job: float
    why: str


CASES = [
    Case("default", ScalarDefaults, 8 * SCALARS, "every job's value, drawn as a HISTOGRAM"),
    Case("job_status_counts", JobStatusCounts, 0, "counts"),
    Case("metric_status_counts", MetricStatusCounts, 0, "counts"),
    Case("pass_rate", PassRate, 0, "two counts"),
    Case(
        "weighted_mean",
        lambda: WeightedMean(name="WM", metric="a", weight="w"),
        16,
        "w*x and w per job: fsum needs every term for a sum independent of job order",
    ),
    Case(
        "histogram",
        lambda: MergedHistogram(name="HC", data="s", lower=-12, upper=12, max_values=500),
        0,
        "counts mode: the bucket counts only",
    ),
    Case(
        "histogram",
        lambda: MergedHistogram(name="HM", metric="Speed histogram", max_values=500),
        0,
        "counts mode: the bucket counts only",
    ),
    Case(
        "histogram",
        lambda: MergedHistogram(name="HE", data="s", lower=-12, upper=12),
        8 * SERIES_VALUES,
        "exact mode: the histogram's values are the values, up to max_values",
    ),
    Case("scalar_stats", lambda: ScalarStats(metric="a"), 8, "exact quantiles need the values"),
    Case(
        "category_totals",
        lambda: CategoryTotals(data="per class"),
        8 * 3,
        "a job's sum per label (3 labels): exact totals in any order",
    ),
    Case(
        "category_totals",
        lambda: CategoryTotals(metric="Detections"),
        8 * 3,
        "a job's sum per legend and label (3 bars)",
    ),
    Case("events", EventCounts, 0, "counts per name and status"),
    Case(
        "sweep",
        lambda: ParameterSweep(parameters=["p", "q"], metrics=["a", "b"]),
        8 * 2,
        "each metric's values per row, for exact means",
    ),
    Case(
        "by_tag",
        lambda: ByExperienceTag(metrics=["a"]),
        8,
        "each metric's values per tag (one tag per job), for exact means",
    ),
    Case(
        "summary",
        BatchSummaryWriter,
        16 + 2 + SCALARS * 9.25,
        "the summary's layout: ID, two indexes, per scalar a double, a unit index, a bit",
    ),
]


def case_id(case: Case) -> str:
    return getattr(case.factory(), "name", "") or case.kind


def written(aggregation: BatchAggregation) -> bytes:
    writer = MetricsWriter(BATCH_ID, deterministic=True)
    aggregation.finish(writer)
    return writer.serialize()


def fold(aggregation: BatchAggregation, records: list[JobRecord]) -> BatchAggregation:
    for record in records:
        aggregation.update(record)
    return aggregation


def travelled(partial: BatchAggregation) -> Any:
    return pickle.loads(pickle.dumps(partial, pickle.HIGHEST_PROTOCOL))


def state(aggregation: Any) -> dict[str, Any]:
    """The fields, Series and arrays as lists (they compare element-wise)."""
    out = {}
    for key, value in vars(aggregation).items():
        if isinstance(value, list) and value and isinstance(value[0], pl.Series):
            value = pl.concat(value).to_list()
        elif isinstance(value, list) and value and isinstance(value[0], np.ndarray):
            value = np.concatenate(value).tolist()
        out[key] = value
    return out


def test_every_registry_kind_and_default_has_a_case() -> None:
    assert set(BUILTIN) <= {case.kind for case in CASES}
    covered = {type(case.factory()) for case in CASES}
    assert {type(a) for a in default_batch_aggregations()} <= covered


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_a_partial_pickles_to_an_equal_state_that_merges_alike(case: Case) -> None:
    records = jobs(0, 300)
    partial = fold(case.factory(), records)
    copy = travelled(partial)
    assert type(copy) is type(partial)
    assert state(copy) == state(partial)
    assert written(copy) == written(partial)
    # Shards folded apart, pickled, unpickled and merged: the bytes of one fold.
    shards = [travelled(fold(case.factory(), records[i::3])) for i in range(3)]
    merged = shards[0]
    for other in shards[1:]:
        merged.merge(other)
    assert written(merged) == written(partial)
    # An unpickled partial goes on folding.
    more = jobs(300, 400)
    assert written(fold(copy, more)) == written(fold(partial, more))


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_a_pickled_partial_is_compact(case: Case) -> None:
    partial = fold(case.factory(), jobs(0, SMALL))
    small = len(pickle.dumps(partial, pickle.HIGHEST_PROTOCOL))
    fold(partial, jobs(SMALL, LARGE))
    large = len(pickle.dumps(partial, pickle.HIGHEST_PROTOCOL))
    growth = (large - small) / (LARGE - SMALL)
    if case.per_job == 0:
        assert large - small <= FLAT_SLACK, f"{small} -> {large} bytes ({case.why})"
        assert large < 4_000, f"{large} bytes ({case.why})"
    else:
        assert growth <= case.per_job + 0.5, f"{growth:.2f} bytes a job ({case.why})"
        assert growth >= case.per_job / 4, "the state keeps what the bound says it keeps"


def _baseline_of(records: list[JobRecord], baseline: list[JobRecord]) -> BaselineComparison:
    comparison = BaselineComparison(resamples=200)
    for record in records:
        comparison.update(record)
    for record in baseline:
        comparison.update_baseline(record)
    return comparison


def _found(comparison: Any) -> Any:
    comparison.set_baseline(BaselineInfo(uuid.UUID(int=99), "nightly"), BATCH_ID)
    return comparison


def test_the_baseline_comparison_travels_and_merges_alike() -> None:
    # [batch.baseline] is built by the service, not the registry: both sides travel.
    candidate, baseline = jobs(0, 300), jobs(300, 600)
    whole = _baseline_of(candidate, baseline)
    copy = travelled(whole)
    assert copy == whole
    shards = [travelled(_baseline_of(candidate[i::3], baseline[i::3])) for i in range(3)]
    merged = shards[0]
    for other in shards[1:]:
        merged.merge(other)
    assert written(_found(merged)) == written(_found(whole))
    assert b"Compared with baseline" in written(merged)


def test_the_baseline_comparison_keeps_8_bytes_a_value() -> None:
    # Each side keeps every job's finite scalars per experience: the bootstrap resamples them.
    partial = _baseline_of(jobs(0, SMALL), [])
    small = len(pickle.dumps(partial, pickle.HIGHEST_PROTOCOL))
    for record in jobs(SMALL, LARGE):
        partial.update(record)
    growth = (len(pickle.dumps(partial, pickle.HIGHEST_PROTOCOL)) - small) / (LARGE - SMALL)
    assert 8 * SCALARS / 4 <= growth <= 8 * SCALARS + 0.5
