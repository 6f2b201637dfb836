"""The built-in aggregations: exact values on small hand-made jobs.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle).
"""

from __future__ import annotations

import bisect
import math
import statistics
import uuid
from collections.abc import Iterable, Mapping, Sequence

import polars as pl
import pytest
import resim.metrics.proto.metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.sdk import (
    JobMetricsView,
    MetricStatus,
    MetricsWriter,
    MetricType,
    MetricView,
    WriterError,
    read_job_metrics,
    validate_job_metrics,
)
from stook.sdk._buckets import histogram_buckets
from stook.sdk.aggregations import (
    BatchAggregation,
    JobRecord,
    JobStatusCounts,
    MergedHistogram,
    MetricStatusCounts,
    PassRate,
    Scalar,
    ScalarDefaults,
    ScalarStats,
    WeightedMean,
    default_batch_aggregations,
)

BATCH_ID = uuid.UUID("0b0b0b0b-1111-4222-8333-444444444444")


# ---------------------------------------------------------------- helpers


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


def fold(aggregation: BatchAggregation, jobs: Iterable[JobRecord]) -> BatchAggregation:
    for record in jobs:
        aggregation.update(record)
    return aggregation


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
        m = self.metric(name, MetricType.HISTOGRAM)
        hv = m.raw.metric_values.histogram_metric_values
        values = self.view.data_by_id[uuid.UUID(hv.values_data_id.id.data)].series().to_list()
        buckets = [(b.lower, b.upper) for b in hv.buckets]
        assert hv.lower_bound == buckets[0][0]
        assert hv.upper_bound == buckets[-1][1]
        return values, buckets, m

    def bars(self, name: str) -> dict[str, float]:
        m = self.metric(name, MetricType.BAR_CHART)
        bv = m.raw.metric_values.bar_chart_metric_values
        assert len(bv.values_data_id) == 1
        values = self.view.data_by_id[uuid.UUID(bv.values_data_id[0].id.data)]
        assert values.index_id is not None
        labels = self.view.data_by_id[values.index_id].series().to_list()
        return dict(zip(labels, values.series().to_list(), strict=True))


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


# ---------------------------------------------------------------- WeightedMean


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
    assert m.raw.metric_values.text_metric_values.text == (
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


# ---------------------------------------------------------------- MergedHistogram


def test_histogram_exact_mode_holds_exactly_the_appended_values() -> None:
    jobs = [
        job(series={"speed": [3.0, 1.0]}),
        job(series={"speed": [2.5, math.nan, 0.5, 3.75]}),
        job(series={"other": [100.0]}),  # no "speed": not counted
        job(series={"speed": [1.0]}),
    ]
    agg = fold(
        MergedHistogram(
            name="Speed", data="speed", lower=0.0, upper=4.0, buckets=4, x_axis_name="v [m/s]"
        ),
        jobs,
    )
    assert isinstance(agg, MergedHistogram)
    assert not agg.binned
    assert (agg.total, agg.jobs, agg.dropped_nan) == (6, 3, 1)
    out = Output(agg)
    values, buckets, m = out.histogram("Speed")
    assert values == [0.5, 1.0, 1.0, 2.5, 3.0, 3.75]
    assert buckets == [(0.0, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 4.0)]
    hv = m.raw.metric_values.histogram_metric_values
    assert hv.x_axis_name == "v [m/s]"
    assert m.description == "Histogram of 6 values of 'speed' from 3 jobs (1 NaN values dropped)."
    assert out.names == ["Speed"]
    assert out.view.data_by_name["Speed values"].series().to_list() == values


def test_histogram_exact_mode_up_to_max_values_inclusive() -> None:
    jobs = [job(series={"d": [0.1, 0.2]}), job(series={"d": [0.3]})]
    agg = fold(MergedHistogram(name="H", data="d", lower=0, upper=1, max_values=3), jobs)
    assert isinstance(agg, MergedHistogram)
    assert not agg.binned
    out = Output(agg)
    values, buckets, m = out.histogram("H")
    assert values == [0.1, 0.2, 0.3]
    assert len(buckets) == 20
    assert "H (counts)" not in out.by_name
    assert not m.description.startswith("Pre-binned")


def test_histogram_above_max_values_switches_to_exact_counts() -> None:
    per_job = [
        [0.25, 1.5, 9.0],  # 9.0 is above the upper bound: counted in the last bucket
        [math.nan, 2.25, 2.75, -3.0],  # -3.0 below: first bucket
        [3.5, 3.5, 0.75, 1.25],
        [3.9],
    ]
    agg = fold(
        MergedHistogram(name="Speed", data="v", lower=0.0, upper=4.0, buckets=4, max_values=5),
        [job(series={"v": vs}) for vs in per_job],
    )
    assert isinstance(agg, MergedHistogram)
    assert agg.binned
    finite = [v for vs in per_job for v in vs if not math.isnan(v)]
    edges = histogram_buckets("Speed", 4, 0.0, 4.0)
    expected = reference_counts(finite, edges)
    assert expected == [3, 2, 2, 4]
    assert agg.counts == expected
    assert agg.outside == 2

    out = Output(agg)
    values, buckets, m = out.histogram("Speed")
    assert buckets == edges
    assert m.description.startswith(
        "Pre-binned: 11 values of 'v' from 4 jobs (1 NaN values dropped) exceed the cap of "
        "5 values, so each value shown stands for 3 values at its bucket's midpoint"
    )
    assert "exact counts are in 'Speed (counts)'" in m.description
    assert m.description.endswith("; 2 values outside [0.0, 4.0] counted in the edge buckets.")
    # Each value shown is a midpoint, repeated round(count / per_value) times.
    per_value = math.ceil(len(finite) / 5)
    shown: list[float] = []
    for (lo, hi), c in zip(edges, expected, strict=True):
        shown += [(lo + hi) / 2] * round(c / per_value)
    assert values == shown == [0.5, 1.5, 2.5, 3.5]

    bars = out.bars("Speed (counts)")
    assert bars == {"[0, 1)": 3.0, "[1, 2)": 2.0, "[2, 3)": 2.0, "[3, 4)": 4.0}
    assert out.by_name["Speed (counts)"].description == (
        "Exact bucket counts of 11 values of 'v' from 4 jobs (1 NaN values dropped)."
    )
    assert out.names == ["Speed", "Speed (counts)"]


def test_histogram_counts_match_an_independent_binning_on_many_values() -> None:
    values = [((i * 7919) % 1000) / 37.0 - 3.0 for i in range(1000)]  # spans -3 .. 24
    agg = fold(
        MergedHistogram(name="H", data="d", lower=-1.0, upper=20.0, buckets=7, max_values=100),
        [job(series={"d": values[i : i + 90]}) for i in range(0, 1000, 90)],
    )
    assert isinstance(agg, MergedHistogram)
    edges = histogram_buckets("H", 7, -1.0, 20.0)
    assert agg.counts == reference_counts(values, edges)
    assert agg.outside == sum(1 for v in values if v < -1.0 or v > 20.0)
    out = Output(agg)
    assert list(out.bars("H (counts)").values()) == [
        float(c) for c in reference_counts(values, edges)
    ]


@pytest.mark.parametrize(
    ("lower", "upper", "buckets"),
    [(-3.3, 0.0, 3), (-3.3, 0.0, 20), (-1.0, -0.3, 3), (0.0, 1.0, 10), (0.1, 3.4, 7)],
)
def test_histogram_counts_put_edge_values_in_the_bucket_they_start(
    lower: float, upper: float, buckets: int
) -> None:
    # Values exactly on each edge: a division by the bucket width rounds some of them into
    # the bucket below (e.g. -2.2 for [-3.3, 0] in 3 buckets).
    edges = histogram_buckets("H", buckets, lower, upper)
    on_edges = [lo for lo, _ in edges] + [upper]
    agg = fold(
        MergedHistogram(
            name="H", data="d", lower=lower, upper=upper, buckets=buckets, max_values=1
        ),
        [job(series={"d": on_edges})],
    )
    assert isinstance(agg, MergedHistogram)
    expected = [1] * buckets
    expected[-1] = 2  # the upper bound belongs to the last bucket
    assert agg.counts == reference_counts(on_edges, edges) == expected
    assert agg.outside == 0


def test_histogram_without_values_is_not_applicable() -> None:
    agg = fold(
        MergedHistogram(name="H", data="d", lower=0, upper=1),
        [job(series={"e": [1.0]}), job(series={"d": [math.nan]})],
    )
    out = Output(agg)
    m = out.metric("H", MetricType.TEXT)
    assert m.status is MetricStatus.NOT_APPLICABLE
    assert m.raw.metric_values.text_metric_values.text == (
        "No job wrote values for 'd'; nothing to draw."
    )


def test_histogram_needs_its_data_and_checks_its_bounds() -> None:
    assert MergedHistogram(name="H", data="d", lower=0, upper=1).needs().data == {"d"}
    with pytest.raises(WriterError, match="lower < upper"):
        MergedHistogram(name="H", data="d", lower=1, upper=1)
    with pytest.raises(ValueError, match="max_values must be at least 1"):
        MergedHistogram(name="H", data="d", lower=0, upper=1, max_values=0)


# ---------------------------------------------------------------- ScalarStats


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


# ---------------------------------------------------------------- ScalarDefaults


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
    assert hist.raw.metric_values.histogram_metric_values.x_axis_name == "dist [m]"
    assert hist.description == "'dist' of each of the 3 jobs that reported it."
    assert out.view.data_by_name["dist (distribution) values"].unit == "m"

    count_mean = out.metric("count (mean)", MetricType.SCALAR)
    assert count_mean.value == 2.0
    assert count_mean.unit == ""
    values, buckets, hist = out.histogram("count (distribution)")
    assert values == [2.0, 2.0]
    assert buckets == [(1.5, 2.5)]  # one value: a single bucket around it
    assert hist.raw.metric_values.histogram_metric_values.x_axis_name == "count"


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


# ---------------------------------------------------------------- status counts


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
    bv = m.raw.metric_values.bar_chart_metric_values
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
    bv = m.raw.metric_values.bar_chart_metric_values
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


def test_fresh_keeps_configuration_and_drops_state() -> None:
    agg = fold(
        MergedHistogram(name="H", data="d", lower=0, upper=2, buckets=2, max_values=1),
        [job(series={"d": [0.5, 1.5]})],
    )
    assert isinstance(agg, MergedHistogram)
    assert agg.binned
    new = agg.fresh()
    assert (new.name, new.data, new.lower, new.upper, new.buckets, new.max_values) == (
        "H",
        "d",
        0,
        2,
        2,
        1,
    )
    assert (new.total, new.counts, new.chunks, new.jobs) == (0, None, [], 0)
    stats = fold(ScalarStats(metric="x", stats=["max"], name="X"), [job(scalars={"x": 1.0})])
    fresh_stats = stats.fresh()
    assert isinstance(fresh_stats, ScalarStats)
    assert (fresh_stats.name, list(fresh_stats.stats), len(fresh_stats.values)) == ("X", ["max"], 0)


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
