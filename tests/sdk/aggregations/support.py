"""Helpers of the batch-aggregation tests: hand-made jobs, folding, and what was written."""

from __future__ import annotations

import bisect
import math
import pickle
import uuid
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TypeVar

import polars as pl
import resim.metrics.proto.metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.sdk import (
    BarChartMetric,
    HistogramMetric,
    JobMetricsView,
    MetricsWriter,
    MetricType,
    MetricView,
    read_job_metrics,
    validate_job_metrics,
)
from stook.sdk.aggregations import BatchAggregation, JobRecord, Scalar

BATCH_ID = uuid.UUID("0b0b0b0b-1111-4222-8333-444444444444")


def job(
    status: str = "PASSED",
    *,
    scalars: Mapping[str, Scalar | float] | None = None,
    series: Mapping[str, Sequence[float]] | None = None,
    metric_statuses: Sequence[str] = (),
) -> JobRecord:
    return JobRecord(
        job_id=uuid.uuid4(),
        conflated_status=status,
        scalars={
            k: v if isinstance(v, Scalar) else Scalar(float(v)) for k, v in (scalars or {}).items()
        },
        series={k: pl.Series(k, list(v), dtype=pl.Float64) for k, v in (series or {}).items()},
        metric_statuses=tuple(metric_statuses),
    )


_A = TypeVar("_A", bound=BatchAggregation)


def fold(aggregation: BatchAggregation, jobs: Iterable[JobRecord]) -> BatchAggregation:
    for record in jobs:
        aggregation.update(record)
    return aggregation


def folded_three_ways(
    make: Callable[[], _A], jobs: Sequence[JobRecord], split: int
) -> tuple[_A, _A, _A]:
    """`jobs` folded into one fresh aggregation (whole), that one pickled and read back
    (travelled), and two folded at `split` and merged (merged): for aggregations that keep
    updates waiting, each must read the same."""
    whole = make()
    fold(whole, jobs)
    travelled: _A = pickle.loads(pickle.dumps(whole))
    merged = make()
    fold(merged, jobs[:split])
    rest = make()
    fold(rest, jobs[split:])
    merged.merge(rest)
    return whole, travelled, merged


class Output:
    """What a set of finished aggregations wrote, read back and validated."""

    def __init__(self, *aggregations: BatchAggregation) -> None:
        self.writer = MetricsWriter(BATCH_ID, deterministic=True)
        for aggregation in aggregations:
            aggregation.finish(self.writer)
        raw = self.writer.serialize()
        validate_job_metrics(self.writer.to_proto())
        resim_validate(rp.JobMetrics.FromString(raw))
        self.view: JobMetricsView = read_job_metrics(raw)
        self.by_name = {m.name: m for m in self.view.metrics}

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.view.metrics]

    def metric(self, name: str, kind: MetricType) -> MetricView:
        m = self.by_name[name]
        assert m.type is kind
        return m

    def histogram(self, name: str) -> tuple[list[float], list[tuple[float, float]], MetricView]:
        hist = self.view.metric(name, HistogramMetric)
        assert hist.values_data is not None
        buckets: list[tuple[float, float]] = list(hist.buckets)
        assert hist.lower_bound == buckets[0][0]
        assert hist.upper_bound == buckets[-1][1]
        return hist.values_data.series().to_list(), buckets, hist.view

    def bars(self, name: str) -> dict[str, float]:
        (values,) = self.view.metric(name, BarChartMetric).values_data
        return values.by_label()


def reference_counts(values: Iterable[float], edges: Sequence[tuple[float, float]]) -> list[int]:
    """Bucket i holds lower_i <= v < upper_i; values below/above the range go to the edge
    buckets, the upper bound itself to the last one."""
    lowers = [lo for lo, _ in edges]
    counts = [0] * len(edges)
    for v in values:
        counts[min(max(bisect.bisect_right(lowers, v) - 1, 0), len(edges) - 1)] += 1
    return counts


def linear_quantile(values: Sequence[float], q: float) -> float:
    s = sorted(values)
    pos = q * (len(s) - 1)
    lo = math.floor(pos)
    hi = min(lo + 1, len(s) - 1)
    return s[lo] + (s[hi] - s[lo]) * (pos - lo)
