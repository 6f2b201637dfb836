"""JobStatusCounts, MetricStatusCounts and PassRate: counts in the app's order.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`.
"""

from __future__ import annotations

import pytest

from stook.sdk import BarChartMetric, MetricStatus, MetricType
from stook.sdk.aggregations import JobStatusCounts, MetricStatusCounts, PassRate
from tests.sdk.aggregations.support import Output, fold, folded_three_ways, job


def test_job_status_counts_in_app_order_with_unknown_statuses_last() -> None:
    statuses = ["PASSED", "ERROR", "PASSED", "CANCELLED", "ZZZ", "WARNING", "PASSED", "AAA"]
    agg = fold(JobStatusCounts(), [job(s) for s in statuses])
    assert isinstance(agg, JobStatusCounts)
    assert agg.status is MetricStatus.FAIL_WARN
    out = Output(agg)
    assert out.bars("Job statuses") == {
        "PASSED": 3.0,
        "WARNING": 1.0,
        "BLOCKER": 0.0,
        "ERROR": 1.0,
        "CANCELLED": 1.0,
        "AAA": 1.0,
        "ZZZ": 1.0,
    }
    assert list(out.bars("Job statuses")) == [
        "PASSED",
        "WARNING",
        "BLOCKER",
        "ERROR",
        "CANCELLED",
        "AAA",
        "ZZZ",
    ]
    m = out.by_name["Job statuses"]
    assert m.status is MetricStatus.FAIL_WARN
    assert m.description == "Conflated status of the batch's 8 jobs."
    bv = out.view.metric(m.name, BarChartMetric)
    assert (bv.x_axis_name, bv.y_axis_name) == ("Conflated job status", "Jobs")
    assert out.writer.status is MetricStatus.FAIL_WARN


@pytest.mark.parametrize(
    ("statuses", "expected"),
    [
        pytest.param(["PASSED", "PASSED"], MetricStatus.PASSED, id="all-passed"),
        pytest.param(["PASSED", "CANCELLED", "RUNNING"], MetricStatus.PASSED, id="cancelled"),
        pytest.param(["PASSED", "ERROR"], MetricStatus.FAIL_WARN, id="error"),
        pytest.param(["WARNING", "PASSED"], MetricStatus.FAIL_WARN, id="warning"),
        pytest.param(["WARNING", "BLOCKER", "ERROR"], MetricStatus.FAIL_BLOCK, id="blocker"),
        pytest.param([], MetricStatus.PASSED, id="no-jobs"),
    ],
)
def test_job_status_counts_status(statuses: list[str], expected: MetricStatus) -> None:
    out = Output(fold(JobStatusCounts(), [job(s) for s in statuses]))
    assert out.by_name["Job statuses"].status is expected
    assert out.writer.status is expected
    bars = out.bars("Job statuses")
    assert list(bars)[:4] == ["PASSED", "WARNING", "BLOCKER", "ERROR"]
    assert sum(bars.values()) == len(statuses)
    assert bars["PASSED"] == statuses.count("PASSED")


def test_metric_status_counts() -> None:
    jobs = [
        job(metric_statuses=["PASSED", "PASSED", "RAW"]),
        job(metric_statuses=["FAIL_WARN", "NOT_APPLICABLE", "PASSED"]),
        job(metric_statuses=[]),
        job(metric_statuses=["NO_STATUS_REPORTED", "ODD"]),
    ]
    out = Output(fold(MetricStatusCounts(), jobs))
    assert out.bars("Job metric statuses") == {
        "PASSED": 3.0,
        "FAIL_WARN": 1.0,
        "FAIL_BLOCK": 0.0,
        "NOT_APPLICABLE": 1.0,
        "RAW": 1.0,
        "NO_STATUS_REPORTED": 1.0,
        "ODD": 1.0,
    }
    m = out.by_name["Job metric statuses"]
    assert m.status is MetricStatus.FAIL_WARN
    bv = out.view.metric(m.name, BarChartMetric)
    assert (bv.x_axis_name, bv.y_axis_name) == ("Metric status", "Job metrics")


def test_metric_status_counts_block_and_pass_and_empty() -> None:
    blocked = Output(fold(MetricStatusCounts(), [job(metric_statuses=["FAIL_WARN", "FAIL_BLOCK"])]))
    assert blocked.by_name["Job metric statuses"].status is MetricStatus.FAIL_BLOCK
    passed = Output(fold(MetricStatusCounts(name="MS"), [job(metric_statuses=["PASSED"])]))
    assert passed.by_name["MS"].status is MetricStatus.PASSED
    assert passed.bars("MS") == {"PASSED": 1.0, "FAIL_WARN": 0.0, "FAIL_BLOCK": 0.0}
    assert Output(fold(MetricStatusCounts(), [job(), job()])).names == []


def test_pass_rate() -> None:
    statuses = ["PASSED", "PASSED", "ERROR", "PASSED", "WARNING", "PASSED", "BLOCKER", "PASSED"]
    out = Output(fold(PassRate(), [job(s) for s in statuses]))
    m = out.metric("Pass rate", MetricType.SCALAR)
    assert m.value == 62.5
    assert m.unit == "%"
    assert m.status is MetricStatus.PASSED
    assert m.description == "5 of 8 jobs passed."
    assert Output(fold(PassRate(), [])).names == []
    assert Output(fold(PassRate(name="PR"), [job("ERROR")])).by_name["PR"].value == 0.0


def test_metric_statuses_of_many_jobs_are_counted_however_read() -> None:
    # More jobs than wait to be counted at once: the counts are every job's statuses,
    # read after the fold, after pickling or after a merge, and the output is the same.
    from collections import Counter

    statuses = ("PASSED", "FAIL_WARN", "RAW", "FAIL_BLOCK", "SOMETHING_NEW")
    jobs = [job(metric_statuses=statuses[: i % 6]) for i in range(700)]
    expected = Counter(s for j in jobs for s in j.metric_statuses)
    whole, travelled, merged = folded_three_ways(MetricStatusCounts, jobs, 300)
    for agg in (travelled, merged, whole):
        agg._count_waiting()  # the ones still waiting, if any
        assert agg.counts == expected
        assert Output(agg).writer.serialize() == Output(whole).writer.serialize()
