"""JobScalarDistributions: quantiles of job scalars per batch.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`. Batches
are fed out of creation order on purpose: the aggregations sort by creation time
themselves.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from datetime import timedelta

import pytest

from stook.sdk import LinePlotMetric, MetricStatus
from stook.sdk.aggregations.report import JobScalarDistributions
from tests.sdk.aggregations.report.support import T0, Output, batch, fold, scrambled


def expected_quantiles(values: Sequence[float]) -> list[float]:
    """p10, median, p90 by linear interpolation (statistics' 'inclusive' method)."""
    finite = sorted(v for v in values if math.isfinite(v))
    if len(finite) == 1:
        return finite * 3
    deciles = statistics.quantiles(finite, n=10, method="inclusive")
    return [deciles[0], statistics.median(finite), deciles[8]]


SPEED_0 = [3.0, 1.0, 2.0, 10.0, math.nan, 7.5, -4.0]
SPEED_2 = [4.0, -0.0, 0.0, 8.0, math.inf]

DISTRIBUTION_BATCHES = [
    batch(0, 0.0),  # the report's first batch, without job metrics: the axis starts here
    batch(
        1,
        1.0,
        job_scalars={"speed": SPEED_0, "dist": [5.0]},
        job_scalar_units={"speed": "m/s", "dist": "m"},
    ),
    batch(2, 2.0, job_scalars={"speed": [math.inf, -math.inf, math.nan]}),  # no finite value
    batch(3, 3.5, job_scalars={"speed": SPEED_2}, job_scalar_units={"speed": "m/s"}),
    batch(4, 4.0, job_scalars={"dist": []}),
]


def test_job_scalar_distributions_quantiles_per_batch() -> None:
    out = Output(fold(JobScalarDistributions(), scrambled(DISTRIBUTION_BATCHES)))
    assert out.names == ["dist per batch", "speed per batch"]
    p10, median, p90 = out.lines("speed per batch")
    assert p10.x == median.x == p90.x == [1.0, 3.5]  # b2 has no finite value: a gap
    assert p10.times == [T0 + timedelta(days=1), T0 + timedelta(days=3.5)]
    rows = [expected_quantiles(SPEED_0), expected_quantiles(SPEED_2)]
    # sorted finite: -4, 1, 2, 3, 7.5, 10 -> p10 at 0.5: -1.5; median 2.5; p90 at 4.5: 8.75
    assert rows[0] == [-1.5, 2.5, 8.75]
    # sorted finite: 0, 0, 4, 8 -> p10 at 0.3: 0; median 2; p90 at 2.7: 6.8
    assert rows[1] == pytest.approx([0.0, 2.0, 6.8])
    for i, line in enumerate((p10, median, p90)):
        assert line.y == pytest.approx([rows[0][i], rows[1][i]], rel=1e-12)
        assert line.statuses == ["PASSED", "PASSED"]
        assert line.y_unit == "m/s"
    assert math.copysign(1.0, p10.y[1]) == 1.0  # -0.0 is written as 0.0
    assert [p10.y_name, median.y_name, p90.y_name] == [
        "speed per batch (p10)",
        "speed per batch (median)",
        "speed per batch (p90)",
    ]
    m = out.by_name["speed per batch"]
    lv = out.view.metric(m.name, LinePlotMetric)
    assert lv.legend == ("p10", "median", "p90")
    assert lv.x_axis_name == "Days since 2024-03-01 12:00 UTC"
    assert lv.y_axis_name == "speed [m/s]"
    assert m.status is MetricStatus.PASSED
    assert m.description == (
        "10th percentile, median and 90th percentile of 'speed' across each batch's jobs "
        "(10 job values in 2 batches)."
    )

    dist = out.lines("dist per batch")
    assert [line.y for line in dist] == [[5.0], [5.0], [5.0]]
    assert dist[0].x == [1.0]
    assert out.view.metric("dist per batch", LinePlotMetric).y_axis_name == "dist [m]"


def test_job_scalar_distributions_against_interpolation_on_more_values() -> None:
    values = [((i * 7919) % 1009) / 13.0 - 20.0 for i in range(97)]
    records = [
        batch(i, float(i), job_scalars={"v": values[i * 10 : i * 10 + 10 + i]}) for i in range(8)
    ]
    out = Output(fold(JobScalarDistributions(), scrambled(records)))
    lines = out.lines("v per batch")
    for q, line in enumerate(lines):
        assert line.x == [float(i) for i in range(8)]
        assert line.y == pytest.approx(
            [expected_quantiles(r.job_scalars["v"])[q] for r in records], rel=1e-12
        )


def test_job_scalar_distributions_only_the_metrics_asked_for() -> None:
    agg = JobScalarDistributions(metrics=["dist"])
    assert agg.needs().job_metrics is True
    assert agg.needs().scalars == {"dist"}
    out = Output(fold(agg, DISTRIBUTION_BATCHES))
    assert out.names == ["dist per batch"]
    assert Output(fold(JobScalarDistributions(metrics=[]), DISTRIBUTION_BATCHES)).names == []
    assert Output(fold(JobScalarDistributions(), [batch(0, 0.0)])).names == []
