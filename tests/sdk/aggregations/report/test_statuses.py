"""TestStatusOverTime and the metric status counts across batches.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`. Batches
are fed out of creation order on purpose: the aggregations sort by creation time
themselves.
"""

from __future__ import annotations

import uuid

from stook.sdk import BarChartMetric, BatchwiseBarChartMetric, MetricStatus, MetricType
from stook.sdk.aggregations.report import (
    BatchMetricStatusCounts,
    JobMetricStatusCounts,
    TestStatusOverTime,
)
from tests.sdk.aggregations.report.support import PROJECT_ID, Output, batch, fold, scrambled

# ---------------------------------------------------------------- TestStatusOverTime


def test_status_over_time_counts_jobs_per_status_per_batch() -> None:
    records = [
        batch(0, 0.0, jobs=[("a", "PASSED"), ("b", "PASSED"), ("c", "BLOCKER")]),
        batch(1, 0.25),  # no jobs: zeros everywhere
        batch(
            2,
            2.0,
            jobs=[("a", "PASSED"), ("b", "ERROR"), ("c", "ODD"), ("d", "CANCELLED")],
        ),
    ]
    out = Output(fold(TestStatusOverTime(project_id=PROJECT_ID), scrambled(records)))
    m = out.metric("Test status over time", MetricType.BATCHWISE_BAR_CHART)
    bv = out.view.metric(m.name, BatchwiseBarChartMetric)
    # PASSED always; others only when seen, in the app's order; unknown ones after, by name
    assert bv.categories == ("PASSED", "BLOCKER", "ERROR", "CANCELLED", "ODD")
    assert bv.colors == ("#2e7d32", "#c62828", "#6a1b9a", "#757575", "#9e9e9e")
    assert bv.project_id == uuid.UUID(PROJECT_ID)
    assert (bv.x_axis_name, bv.y_axis_name, bv.stack_bars) == ("Batch", "Jobs", True)
    expected = {
        "PASSED": [2.0, 0.0, 1.0],
        "BLOCKER": [1.0, 0.0, 0.0],
        "ERROR": [0.0, 0.0, 1.0],
        "CANCELLED": [0.0, 0.0, 1.0],
        "ODD": [0.0, 0.0, 1.0],
    }
    ids = tuple(r.batch_id for r in records)
    for category, times, values in zip(bv.categories, bv.times_data, bv.values_data, strict=True):
        assert values.name == f"Test status over time: {category}"
        assert values.labelled() == tuple(zip(ids, expected[category], strict=True))
        assert times.series().to_list() == [r.created for r in records]
        assert values.index_id == times.index_id
    assert m.status is MetricStatus.PASSED
    assert m.description == "Jobs per conflated status in each of 3 batches."


def test_status_over_time_of_batches_without_jobs_shows_passed_zeros() -> None:
    out = Output(
        fold(TestStatusOverTime(project_id=PROJECT_ID, name="S"), [batch(0, 0.0), batch(1, 1.0)])
    )
    bv = out.view.metric("S", BatchwiseBarChartMetric)
    assert bv.categories == ("PASSED",)
    assert bv.values_data[0].values() == (0.0, 0.0)
    assert Output(TestStatusOverTime(project_id=PROJECT_ID)).names == []


# ---------------------------------------------------------------- status counts


def test_job_metric_status_counts_across_batches() -> None:
    records = [
        batch(0, 0.0, job_metric_statuses=["PASSED"] * 3 + ["FAIL_WARN", "RAW"]),
        batch(1, 1.0, job_metric_statuses=["NO_STATUS_REPORTED", "PASSED", "ODD"]),
        batch(2, 2.0),
    ]
    agg = JobMetricStatusCounts()
    assert agg.needs().job_metrics is True
    out = Output(fold(agg, scrambled(records)))
    bars = out.bars("Job metric statuses")
    assert list(bars.items()) == [
        ("PASSED", 4.0),
        ("FAIL_WARN", 1.0),
        ("FAIL_BLOCK", 0.0),
        ("RAW", 1.0),
        ("NO_STATUS_REPORTED", 1.0),
        ("ODD", 1.0),
    ]
    m = out.by_name["Job metric statuses"]
    assert m.status is MetricStatus.FAIL_WARN
    assert m.description == "8 job metrics by status."
    bv = out.view.metric(m.name, BarChartMetric)
    assert (bv.x_axis_name, bv.y_axis_name) == ("Metric status", "Job metrics")


def test_batch_metric_status_counts_across_batches() -> None:
    records = [
        batch(0, 0.0, metric_statuses=["PASSED", "FAIL_BLOCK"]),
        batch(1, 1.0, metric_statuses=["NOT_APPLICABLE", "FAIL_WARN", "PASSED"]),
    ]
    agg = BatchMetricStatusCounts()
    assert agg.needs().job_metrics is False
    out = Output(fold(agg, records))
    assert out.bars("Batch metric statuses") == {
        "PASSED": 2.0,
        "FAIL_WARN": 1.0,
        "FAIL_BLOCK": 1.0,
        "NOT_APPLICABLE": 1.0,
    }
    m = out.by_name["Batch metric statuses"]
    assert m.status is MetricStatus.FAIL_BLOCK
    assert m.description == "5 batch metrics by status."
    assert out.view.metric(m.name, BarChartMetric).y_axis_name == "Batch metrics"


def test_status_counts_all_passed_and_empty() -> None:
    out = Output(fold(BatchMetricStatusCounts(), [batch(0, 0.0, metric_statuses=["PASSED"])]))
    assert out.bars("Batch metric statuses") == {
        "PASSED": 1.0,
        "FAIL_WARN": 0.0,
        "FAIL_BLOCK": 0.0,
    }
    assert out.by_name["Batch metric statuses"].status is MetricStatus.PASSED
    assert Output(fold(JobMetricStatusCounts(), [batch(0, 0.0)])).names == []
    assert Output(fold(BatchMetricStatusCounts(), [batch(0, 0.0)])).names == []
