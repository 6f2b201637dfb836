"""ScalarDefaults: the mean and distribution of every scalar.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`.
"""

from __future__ import annotations

import math
import uuid

import pytest
import resim.metrics.proto.metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.sdk import HistogramMetric, MetricsWriter, MetricType, validate_job_metrics
from stook.sdk.aggregations import (
    JobRecord,
    Scalar,
    ScalarDefaults,
    ScalarStats,
    default_batch_aggregations,
)
from tests.sdk.aggregations.support import Output, fold, folded_three_ways, job


def test_scalar_defaults_mean_and_distribution_of_every_scalar() -> None:
    jobs = [
        job(scalars={"dist": Scalar(3.0, "m"), "count": Scalar(2.0)}),
        job(scalars={"dist": Scalar(1.0, "m"), "count": Scalar(2.0)}),
        job(scalars={"dist": Scalar(math.inf, "m")}),  # not finite: dropped
        job(scalars={"dist": Scalar(8.0, ""), "only_inf": Scalar(-math.inf, "s")}),
    ]
    out = Output(fold(ScalarDefaults(), jobs))
    # Sorted by scalar name; a scalar with no finite value writes nothing.
    assert out.names == [
        "count (mean)",
        "count (distribution)",
        "dist (mean)",
        "dist (distribution)",
    ]

    mean = out.metric("dist (mean)", MetricType.SCALAR)
    assert mean.value == 4.0
    assert mean.unit == "m"
    assert mean.description == "Mean of 'dist' over the 3 jobs that reported it."
    values, buckets, hist = out.histogram("dist (distribution)")
    assert values == [1.0, 3.0, 8.0]
    # about sqrt(3) -> 2 equal buckets from the smallest to the largest value
    assert buckets == [(1.0, 4.5), (4.5, 8.0)]
    assert out.view.metric(hist.name, HistogramMetric).x_axis_name == "dist [m]"
    assert hist.description == "'dist' of each of the 3 jobs that reported it."
    assert out.view.data_by_name["dist (distribution) values"].unit == "m"

    count_mean = out.metric("count (mean)", MetricType.SCALAR)
    assert count_mean.value == 2.0
    assert count_mean.unit == ""
    values, buckets, hist = out.histogram("count (distribution)")
    assert values == [2.0, 2.0]
    assert buckets == [(1.5, 2.5)]  # one value: a single bucket around it
    assert out.view.metric(hist.name, HistogramMetric).x_axis_name == "count"


def test_scalar_defaults_bucket_count_grows_with_the_jobs() -> None:
    jobs = [job(scalars={"x": float(i)}) for i in range(500)]
    out = Output(fold(ScalarDefaults(), jobs))
    values, buckets, _ = out.histogram("x (distribution)")
    assert values == [float(i) for i in range(500)]
    assert len(buckets) == 20  # ceil(sqrt(500)) = 23, capped at 20
    assert buckets[0][0] == 0.0
    assert buckets[-1][1] == 499.0
    assert out.by_name["x (mean)"].value == 249.5


def test_scalar_defaults_without_scalars_writes_nothing() -> None:
    assert Output(fold(ScalarDefaults(), [job(), job("ERROR")])).names == []


def test_scalar_defaults_and_scalar_stats_can_share_a_batch() -> None:
    # With defaults = true, a [[batch.scalar_stats]] for "lat" would write "lat (mean)"
    # a second time; the mean is the same number, so it is written once.
    jobs = [job(scalars={"lat": Scalar(v, "ms")}) for v in (1.0, 2.0)]
    aggregations = [*default_batch_aggregations(), ScalarStats(metric="lat")]
    for aggregation in aggregations:
        fold(aggregation, jobs)
    out = Output(*aggregations)
    assert out.names.count("lat (mean)") == 1
    assert out.by_name["lat (mean)"].value == 1.5
    assert out.by_name["lat (mean)"].description == (
        "Mean of 'lat' over the 2 jobs that reported it."
    )
    assert [n for n in out.names if n.startswith("lat (")] == [
        "lat (mean)",
        "lat (distribution)",
        "lat (min)",
        "lat (max)",
        "lat (p50)",
        "lat (p95)",
    ]
    assert out.by_name["lat (p95)"].value == 1.95


@pytest.mark.parametrize(
    "values",
    [[0.0, 5e-324], [-1e308, 1e308], [1.7e308, 1.7e308], [0.0, 1e-300, 2e-300]],
    ids=["subnormal-range", "huge-range", "huge-equal", "tiny-range"],
)
def test_scalar_defaults_distribution_survives_extreme_ranges(values: list[float]) -> None:
    # Found by hypothesis: equal-width buckets over [0, 5e-324] are not distinct floats.
    agg = ScalarDefaults()
    for v in values:
        agg.update(JobRecord(uuid.uuid4(), "PASSED", scalars={"x": Scalar(v)}))
    writer = MetricsWriter(uuid.UUID(int=3), deterministic=True)
    agg.finish(writer)
    validate_job_metrics(writer.to_proto())
    resim_validate(rp.JobMetrics.FromString(writer.serialize()))
    assert writer.has_metric("x (distribution)")


def test_scalar_defaults_columns_are_the_jobs_scalars_in_arrival_order() -> None:
    # More jobs than wait to be added at once, some without some scalars, some units
    # differing: the columns hold each scalar's values in the order the jobs came, and
    # the units counted, whether read after the fold, after pickling or after a merge.

    jobs = [
        job(
            scalars={
                **({"a": Scalar(i * 0.5, "m" if i % 4 else "km")} if i % 3 else {}),
                **({"b": Scalar(-float(i))} if i % 5 else {}),
            }
        )
        for i in range(700)
    ]
    expected = {
        name: [j.scalars[name].value for j in jobs if name in j.scalars] for name in ("a", "b")
    }
    whole, travelled, merged = folded_three_ways(ScalarDefaults, jobs, 300)
    for agg in (travelled, merged, whole):
        agg._add_waiting()  # the ones still waiting, if any
        assert {n: list(c.values) for n, c in sorted(agg.columns.items())} == expected
        assert agg.columns["a"].units == {"m": 350, "km": 116}
        assert Output(agg).writer.serialize() == Output(whole).writer.serialize()


@pytest.mark.parametrize(
    "values",
    [
        [3.0, -1.5, 2.25],
        [1.0, -0.0, 0.0, -2.0],  # -0.0 made 0.0: the element path
        [1.0, math.nan, -math.inf, 2.0],
        [1e308, 1e308, -5.0],  # finite values whose sum is not
        [],
    ],
)
def test_sorted_finite_values_agree_with_the_element_path(values: list[float]) -> None:
    from array import array

    from stook.sdk.aggregations._scalar_stats import _sorted_finite

    got = _sorted_finite(array("d", values))
    expected = sorted(v + 0.0 for v in values if math.isfinite(v))
    assert [math.copysign(1.0, v) for v in got] == [math.copysign(1.0, v) for v in expected]
    assert got == expected


@pytest.mark.parametrize("units", [["m"] * 5, ["m", "s", "m"], [], ["", ""]])
def test_units_counted_as_counter_update_counts_them(units: list[str]) -> None:
    from collections import Counter

    from stook.sdk.aggregations._scalar_stats import _count_units

    counts: Counter[str] = Counter({"m": 1})
    _count_units(counts, units)
    assert counts == Counter({"m": 1}) + Counter(units)
