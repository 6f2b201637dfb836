"""WeightedMean: exact values on small hand-made jobs.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`.
"""

from __future__ import annotations

import math

import pytest

from stook.sdk import MetricStatus, MetricType, TextMetric
from stook.sdk.aggregations import Scalar, WeightedMean
from tests.sdk.aggregations.support import Output, fold, job


def test_weighted_mean_leaves_out_jobs_without_the_weight() -> None:
    jobs = [
        job(scalars={"err": Scalar(1.0, "m"), "dist": 1.0}),
        job(scalars={"err": Scalar(3.0, "m"), "dist": 3.0}),
        job(scalars={"err": Scalar(100.0, "m")}),  # no weight: left out
        job(scalars={"dist": 50.0}),  # no metric: ignored
    ]
    agg = fold(WeightedMean(name="Weighted error", metric="err", weight="dist"), jobs)
    assert isinstance(agg, WeightedMean)
    assert agg.jobs == 2
    assert agg.jobs_without_weight == 1
    out = Output(agg)
    m = out.metric("Weighted error", MetricType.SCALAR)
    assert m.value == (1.0 * 1.0 + 3.0 * 3.0) / 4.0 == 2.5
    assert m.unit == "m"
    assert m.status is MetricStatus.PASSED
    assert m.description == (
        "Mean of 'err' over 2 jobs, weighted by 'dist'; 1 jobs without 'dist' left out."
    )
    assert out.names == ["Weighted error"]


def test_weighted_mean_unweighted_and_unit_override() -> None:
    jobs = [job(scalars={"x": v}) for v in (1.0, 2.0, 4.0, 9.0)] + [job(scalars={"y": 7.0})]
    out = Output(fold(WeightedMean(name="Mean x", metric="x", unit="km"), jobs))
    m = out.metric("Mean x", MetricType.SCALAR)
    assert m.value == 4.0
    assert m.unit == "km"
    assert m.description == "Mean of 'x' over 4 jobs, unweighted."


def test_weighted_mean_is_correctly_rounded() -> None:
    # A naive running sum gives 0.0 here; fsum keeps the exact total.
    jobs = [job(scalars={"x": v}) for v in (1e16, 1.0, -1e16, 1.0)]
    out = Output(fold(WeightedMean(name="m", metric="x"), jobs))
    assert out.by_name["m"].value == 0.5


@pytest.mark.parametrize(
    "weights",
    [
        pytest.param([0.0, 0.0], id="all-zero"),
        pytest.param([2.0, -2.0], id="cancelling"),
        pytest.param([], id="no-jobs"),
    ],
)
def test_weighted_mean_zero_total_weight_is_not_applicable(weights: list[float]) -> None:
    jobs = [job(scalars={"x": 5.0 + i, "w": w}) for i, w in enumerate(weights)]
    out = Output(fold(WeightedMean(name="WM", metric="x", weight="w"), jobs))
    m = out.metric("WM", MetricType.TEXT)
    assert m.status is MetricStatus.NOT_APPLICABLE
    assert out.view.metric("WM", TextMetric).text == (
        "No job reported both 'x' and a non-zero weight; nothing to average."
    )
    assert out.writer.status is MetricStatus.PASSED


def test_weighted_mean_needs_its_scalars() -> None:
    assert WeightedMean(name="n", metric="x", weight="w").needs().scalars == {"x", "w"}
    assert WeightedMean(name="n", metric="x").needs().scalars == {"x"}
    assert WeightedMean(name="n", metric="x").needs().data == frozenset()


def test_weighted_mean_leaves_out_non_finite_values() -> None:
    # +inf and -inf are valid SCALAR values (both validators accept them); math.fsum
    # would raise ValueError on inf + -inf, so such jobs are left out and counted.
    jobs = [
        job(scalars={"x": Scalar(2.0, "m"), "w": 1.0}),
        job(scalars={"x": Scalar(math.inf, "m"), "w": 1.0}),
        job(scalars={"x": Scalar(-math.inf, "m"), "w": 1.0}),
        job(scalars={"x": Scalar(6.0, "m"), "w": 3.0}),
        job(scalars={"x": Scalar(1.0, "m"), "w": math.inf}),
        job(scalars={"x": Scalar(1.0, "m")}),
    ]
    out = Output(fold(WeightedMean(name="WM", metric="x", weight="w"), jobs))
    m = out.metric("WM", MetricType.SCALAR)
    assert m.value == (2.0 + 18.0) / 4.0
    assert m.unit == "m"
    assert m.description == (
        "Mean of 'x' over 2 jobs, weighted by 'w'; 1 jobs without 'w' left out; "
        "3 jobs with non-finite values left out."
    )


def test_weighted_mean_of_only_opposite_infinities_is_not_applicable() -> None:
    jobs = [job(scalars={"x": math.inf}), job(scalars={"x": -math.inf})]
    out = Output(fold(WeightedMean(name="WM", metric="x"), jobs))
    assert out.names == ["WM"]
    assert out.metric("WM", MetricType.TEXT).status is MetricStatus.NOT_APPLICABLE


def test_weighted_mean_reports_the_most_common_unit() -> None:
    def mean_unit(units: list[str]) -> str:
        jobs = [job(scalars={"x": Scalar(1.0, u)}) for u in units]
        unit = Output(fold(WeightedMean(name="WM", metric="x"), jobs)).by_name["WM"].unit
        assert unit is not None
        return unit

    assert mean_unit(["", "km", "m", "m"]) == "m"
    assert mean_unit(["m", "km"]) == "km"  # a tie: the first by name
    assert mean_unit(["km", "m"]) == "km"
    assert mean_unit(["", ""]) == ""
