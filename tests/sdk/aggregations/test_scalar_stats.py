"""ScalarStats: statistics of one scalar across jobs, against an independent computation.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`.
"""

from __future__ import annotations

import math
import statistics

import pytest

from stook.sdk import MetricType, WriterError
from stook.sdk.aggregations import Scalar, ScalarStats
from tests.sdk.aggregations.support import Output, fold, job, linear_quantile

LATENCIES = [4.0, 1.0, 3.0, 2.0, 10.0, 7.5, 0.25]


def test_scalar_stats_against_an_independent_computation() -> None:
    stats = ["mean", "min", "max", "p50", "p95", "p10", "p99.5", "std", "count"]
    jobs = [job(scalars={"lat": Scalar(v, "ms")}) for v in LATENCIES] + [job(scalars={"x": 1.0})]
    agg = fold(ScalarStats(metric="lat", stats=stats), jobs)
    assert isinstance(agg, ScalarStats)
    expected = {
        "mean": statistics.fmean(LATENCIES),
        "min": min(LATENCIES),
        "max": max(LATENCIES),
        "p50": linear_quantile(LATENCIES, 0.50),
        "p95": linear_quantile(LATENCIES, 0.95),
        "p10": linear_quantile(LATENCIES, 0.10),
        "p99.5": linear_quantile(LATENCIES, 0.995),
        "std": statistics.stdev(LATENCIES),
        "count": 7.0,
    }
    assert expected["p50"] == 3.0
    computed = agg.compute()
    assert list(computed) == stats
    for stat in stats:
        assert computed[stat] == pytest.approx(expected[stat], rel=1e-12, abs=1e-12), stat
    out = Output(agg)
    assert out.names == [f"lat ({s})" for s in stats]
    for stat in stats:
        m = out.metric(f"lat ({stat})", MetricType.SCALAR)
        assert m.value == computed[stat]
        assert m.unit == ("" if stat == "count" else "ms")
        assert m.description == f"{stat} of 'lat' over 7 jobs."


def test_scalar_stats_defaults_name_and_unit_override() -> None:
    agg = fold(
        ScalarStats(metric="lat", name="Latency", unit="s"),
        [job(scalars={"lat": Scalar(v, "ms")}) for v in (2.0, 4.0)],
    )
    out = Output(agg)
    assert out.names == [
        "Latency (mean)",
        "Latency (min)",
        "Latency (max)",
        "Latency (p50)",
        "Latency (p95)",
    ]
    assert [out.by_name[n].value for n in out.names] == [3.0, 2.0, 4.0, 3.0, 3.9]
    assert {out.by_name[n].unit for n in out.names} == {"s"}


def test_scalar_stats_single_value_and_no_values() -> None:
    one = fold(ScalarStats(metric="x", stats=["std", "p95", "count"]), [job(scalars={"x": 5.0})])
    assert isinstance(one, ScalarStats)
    assert one.compute() == {"std": 0.0, "p95": 5.0, "count": 1.0}
    none = fold(ScalarStats(metric="x"), [job(scalars={"y": 1.0})])
    assert isinstance(none, ScalarStats)
    assert none.compute() == {}
    assert Output(none).names == []
    assert ScalarStats(metric="x").needs().scalars == {"x"}


@pytest.mark.parametrize("stat", ["median", "p100", "p", "P50", "p5x"])
def test_scalar_stats_refuses_unknown_statistics(stat: str) -> None:
    with pytest.raises(WriterError, match="unknown statistic"):
        ScalarStats(metric="x", stats=["mean", stat])


def test_scalar_stats_leaves_out_non_finite_values() -> None:
    # inf is a valid SCALAR value (the writer and both validators accept it); kept, it
    # would make std NaN, which no SCALAR may be.
    jobs = [job(scalars={"x": Scalar(v, "s")}) for v in (1.0, math.inf, 3.0, -math.inf, math.nan)]
    agg = fold(ScalarStats(metric="x", stats=["mean", "std", "p50", "count"]), jobs)
    assert isinstance(agg, ScalarStats)
    assert agg.not_finite == 3
    out = Output(agg)
    assert out.names == ["x (mean)", "x (std)", "x (p50)", "x (count)"]
    assert [out.by_name[n].value for n in out.names] == [
        2.0,
        statistics.stdev([1.0, 3.0]),
        2.0,
        2.0,
    ]
    assert out.by_name["x (mean)"].description == (
        "mean of 'x' over 2 jobs (3 non-finite values left out)."
    )
    assert out.by_name["x (mean)"].unit == "s"


def test_scalar_stats_of_only_non_finite_values_writes_nothing() -> None:
    agg = fold(ScalarStats(metric="x"), [job(scalars={"x": math.inf})])
    assert Output(agg).names == []
