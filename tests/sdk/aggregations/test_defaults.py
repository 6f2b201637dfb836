"""The default batch aggregations, built and written together.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`.
"""

from __future__ import annotations

from stook.sdk import MetricStatus
from stook.sdk.aggregations import (
    JobStatusCounts,
    MetricStatusCounts,
    PassRate,
    Scalar,
    ScalarDefaults,
    default_batch_aggregations,
)
from tests.sdk.aggregations.support import Output, fold, job


def test_default_batch_aggregations_together() -> None:
    defaults = default_batch_aggregations()
    assert [type(a) for a in defaults] == [
        ScalarDefaults,
        JobStatusCounts,
        MetricStatusCounts,
        PassRate,
    ]
    assert default_batch_aggregations()[0] is not defaults[0]
    jobs = [
        job("PASSED", scalars={"x": Scalar(2.0, "s")}, metric_statuses=["PASSED"]),
        job("BLOCKER", scalars={"x": Scalar(4.0, "s")}, metric_statuses=["FAIL_BLOCK"]),
    ]
    for aggregation in defaults:
        fold(aggregation, jobs)
    out = Output(*defaults)
    assert out.names == [
        "x (mean)",
        "x (distribution)",
        "Job statuses",
        "Job metric statuses",
        "Pass rate",
    ]
    assert out.by_name["x (mean)"].value == 3.0
    assert out.by_name["Pass rate"].value == 50.0
    assert out.writer.status is MetricStatus.FAIL_BLOCK
