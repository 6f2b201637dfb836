"""The default report aggregations and report config tables, built and written together.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`. Batches
are fed out of creation order on purpose: the aggregations sort by creation time
themselves.
"""

from __future__ import annotations

from stook.sdk import MetricStatus
from stook.sdk.aggregations import Scalar, build_all
from stook.sdk.aggregations.report import (
    ChangePoints,
    FlakyExperiences,
    JobScalarDistributions,
    MostFailedExperiences,
    ScalarLines,
    TestStatusOverTime,
    UnstableExperiences,
    default_report_aggregations,
)
from tests.sdk.aggregations.report.support import PROJECT_ID, Output, batch, fold, scrambled


def test_default_report_aggregations_write_valid_metrics_together() -> None:
    records = [
        batch(
            i,
            float(i),
            scalars={"lat": Scalar(10.0 + (i == 5) * 50, "ms")},
            metric_statuses=["PASSED"],
            jobs=[("a", "PASSED"), ("b", "ERROR" if i % 2 else "PASSED")],
            job_scalars={"speed": [1.0, 2.0 + i]},
            job_metric_statuses=["PASSED", "FAIL_WARN"],
        )
        for i in range(6)
    ]
    aggregations = default_report_aggregations(project_id=PROJECT_ID, top_n=5)
    for aggregation in aggregations:
        fold(aggregation, scrambled(records))
    out = Output(*aggregations)
    assert out.names == [
        "lat over time",
        "Regressions",
        "Most failed experiences",
        "Test status over time",
        "Job metric statuses",
        "Batch metric statuses",
        "speed per batch",
        "Flaky experiences",
        "Change points",
        "Unstable experiences",
    ]
    assert out.bars("Most failed experiences") == {"b": 3.0}
    assert out.bars("Flaky experiences") == {"b": 5.0}
    assert out.by_name["lat over time"].status is MetricStatus.FAIL_WARN
    assert out.writer.status is MetricStatus.FAIL_WARN


def test_default_report_aggregations_take_the_report_settings() -> None:
    aggregations = default_report_aggregations(
        project_id=PROJECT_ID,
        top_n=3,
        regression_window=4,
        regression_threshold=2.0,
        job_metrics=["speed"],
        change_penalty=5.0,
    )
    lines, most, status, _, _, dist, flaky, changes, unstable = aggregations
    assert isinstance(lines, ScalarLines)
    assert (lines.window, lines.threshold) == (4, 2.0)
    assert (lines.change_points, lines.change_penalty) == (True, 5.0)
    assert isinstance(changes, ChangePoints)
    assert (changes.penalty, changes.top_n) == (5.0, 3)
    assert isinstance(unstable, UnstableExperiences)
    assert (unstable.top_n, unstable.metrics) == (3, ["speed"])
    assert isinstance(most, MostFailedExperiences)
    assert most.top_n == 3
    assert isinstance(status, TestStatusOverTime)
    assert status.project_id == PROJECT_ID
    assert isinstance(dist, JobScalarDistributions)
    assert dist.metrics == ["speed"]
    assert isinstance(flaky, FlakyExperiences)
    assert flaky.top_n == 3


def test_change_points_and_unstable_experiences_can_be_turned_off() -> None:
    aggregations = default_report_aggregations(
        project_id=PROJECT_ID, change_points=False, unstable_experiences=False
    )
    assert len(aggregations) == 7
    assert not any(isinstance(a, ChangePoints | UnstableExperiences) for a in aggregations)
    (lines,) = [a for a in aggregations if isinstance(a, ScalarLines)]
    assert lines.change_points is False


def test_report_section_builds_report_kinds() -> None:
    built = build_all(
        {
            "scalar_lines": [{"window": 3, "threshold": 2.0, "name": "R"}],
            "most_failed_experiences": [{"top_n": 2}],
            "test_status_over_time": [{"project_id": PROJECT_ID}],
        },
        section="report",
    )
    lines, most, status = built
    assert isinstance(lines, ScalarLines)
    assert (lines.window, lines.threshold) == (3, 2.0)
    assert isinstance(most, MostFailedExperiences)
    assert most.top_n == 2
    assert isinstance(status, TestStatusOverTime)
    records = [batch(i, float(i), scalars={"x": 1.0}) for i in range(5)]
    assert Output(fold(lines, records)).text("R")[0].endswith("of up to 3 earlier batches.")
