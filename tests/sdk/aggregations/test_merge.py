"""Partial states merge: folding jobs into k partials and merging them writes the same bytes as
folding every job into one, and the order the jobs arrive in does not change the bytes."""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable

import polars as pl
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stook.sdk import MetricsWriter
from stook.sdk.aggregations import (
    JOB_STATUSES,
    METRIC_STATUSES,
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
)
from tests import merge_laws
from tests.hypothesis_profiles import examples

BATCH_ID = uuid.UUID("0c0c0c0c-1111-4222-8333-444444444444")

FACTORIES: dict[str, Callable[[], BatchAggregation]] = {
    "weighted_mean": lambda: WeightedMean(name="WM", metric="a", weight="w"),
    "unweighted_mean": lambda: WeightedMean(name="UM", metric="b"),
    "histogram_exact": lambda: MergedHistogram(name="H", data="s", lower=-10, upper=10, buckets=5),
    "histogram_counts": lambda: MergedHistogram(
        name="HC", data="s", lower=-10, upper=10, buckets=5, max_values=4
    ),
    "scalar_stats": lambda: ScalarStats(
        metric="a", stats=["mean", "min", "max", "std", "count", "p50", "p95", "p10"]
    ),
    "scalar_defaults": ScalarDefaults,
    "job_status_counts": JobStatusCounts,
    "metric_status_counts": MetricStatusCounts,
    "pass_rate": PassRate,
}

# Awkward values on purpose: -0.0 sorts equal to 0.0, and non-finite scalars are left out.
AWKWARD = [0.0, -0.0, math.inf, -math.inf, math.nan]
scalar_values = st.one_of(
    st.floats(min_value=-1e6, max_value=1e6, allow_nan=False), st.sampled_from(AWKWARD)
)
weights = st.one_of(st.floats(min_value=0, max_value=100), st.sampled_from(AWKWARD))
series_values = st.one_of(
    st.floats(min_value=-15, max_value=15),
    st.sampled_from([-10.0, 10.0, 4.0, *AWKWARD]),
)
# Jobs may disagree on a unit: the most common one is reported, whatever the order.
units = st.sampled_from(["", "m", "km"])


@st.composite
def job_records(draw: st.DrawFn) -> JobRecord:
    scalars: dict[str, Scalar] = {}
    for name in draw(st.sets(st.sampled_from(["a", "b", "w"]))):
        value = draw(weights if name == "w" else scalar_values)
        status = draw(st.sampled_from(["PASSED", "FAIL_WARN"]))
        scalars[name] = Scalar(value, draw(units), status)
    series = {}
    if draw(st.booleans()):
        series["s"] = pl.Series("s", draw(st.lists(series_values, max_size=6)), dtype=pl.Float64)
    return JobRecord(
        job_id=uuid.UUID(int=draw(st.integers(0, 2**64))),
        conflated_status=draw(st.sampled_from([*JOB_STATUSES, "ODD"])),
        scalars=scalars,
        series=series,
        metric_statuses=draw(st.lists(st.sampled_from([*METRIC_STATUSES, "ODD"]), max_size=4)),
    )


def written(aggregation: BatchAggregation) -> bytes:
    writer = MetricsWriter(BATCH_ID, deterministic=True)
    aggregation.finish(writer)
    return writer.serialize()


def fold_all(factory: Callable[[], BatchAggregation], records: list[JobRecord]) -> bytes:
    return merge_laws.fold_all(factory, records, written)


@examples(60)
@given(records=st.lists(job_records(), max_size=12), data=st.data())
def test_merging_partials_equals_folding_everything(
    records: list[JobRecord], data: st.DataObject
) -> None:
    merge_laws.assert_split_merge_equals_whole(FACTORIES, records, data, max_partials=5)


@examples(60)
@given(records=st.lists(job_records(), max_size=12), data=st.data())
def test_job_order_does_not_change_the_output(
    records: list[JobRecord], data: st.DataObject
) -> None:
    merge_laws.assert_arrival_order_free(FACTORIES, records, data)


def test_the_properties_are_not_vacuous() -> None:
    # Different jobs do give different bytes, and the counts histogram does bin.
    one = [JobRecord(uuid.uuid4(), "PASSED", scalars={"a": Scalar(1.0, "m")})]
    two = [JobRecord(uuid.uuid4(), "ERROR", scalars={"a": Scalar(2.0, "m")})]
    for kind in ("scalar_stats", "scalar_defaults", "job_status_counts", "pass_rate"):
        assert fold_all(FACTORIES[kind], one) != fold_all(FACTORIES[kind], two), kind
    hist = FACTORIES["histogram_counts"]()
    assert isinstance(hist, MergedHistogram)
    hist.update(JobRecord(uuid.uuid4(), "PASSED", series={"s": pl.Series([1.0] * 5)}))
    assert hist.binned


def test_merging_exact_into_counts_and_counts_into_exact() -> None:
    make = FACTORIES["histogram_counts"]
    small = JobRecord(uuid.uuid4(), "PASSED", series={"s": pl.Series([1.0, -20.0])})
    big = JobRecord(uuid.uuid4(), "PASSED", series={"s": pl.Series([2.0, 3.0, 9.0, 11.0, 0.5])})
    expected = fold_all(make, [small, big])
    for order in ((small, big), (big, small)):
        a, b = make(), make()
        a.update(order[0])
        b.update(order[1])
        a.merge(b)
        assert isinstance(a, MergedHistogram)
        assert a.binned
        assert a.counts == [1, 0, 2, 2, 2]
        assert a.outside == 2
        assert written(a) == expected


# ---------------------------------------------------------------- order dependence, pinned


@pytest.mark.parametrize("kind", ["histogram_exact", "scalar_defaults"])
def test_signed_zeros_do_not_make_the_output_order_dependent(kind: str) -> None:
    # -0.0 and 0.0 compare equal, so a sort alone keeps them in arrival order.
    records = [
        JobRecord(uuid.uuid4(), "PASSED", scalars={"b": Scalar(v)}, series={"s": pl.Series([v])})
        for v in (0.0, -0.0, 1.0)
    ]
    assert fold_all(FACTORIES[kind], records) == fold_all(FACTORIES[kind], records[::-1])


def test_signed_zeros_are_written_as_zeros() -> None:
    records = [JobRecord(uuid.uuid4(), "PASSED", series={"s": pl.Series([-0.0, 0.0, -1.0])})]
    hist = FACTORIES["histogram_exact"]()
    for record in records:
        hist.update(record)
    assert isinstance(hist, MergedHistogram)
    values = hist.values().to_list()
    assert values == [-1.0, 0.0, 0.0]
    assert [math.copysign(1.0, v) for v in values] == [-1.0, 1.0, 1.0]


@pytest.mark.parametrize("kind", ["weighted_mean", "scalar_stats", "scalar_defaults"])
def test_conflicting_units_do_not_make_the_output_order_dependent(kind: str) -> None:
    records = [
        JobRecord(uuid.uuid4(), "PASSED", scalars={"a": Scalar(1.0, unit), "w": Scalar(1.0)})
        for unit in ("m", "km", "", "m")
    ]
    assert fold_all(FACTORIES[kind], records) == fold_all(FACTORIES[kind], records[::-1])
    assert fold_all(FACTORIES[kind], records[:2]) == fold_all(FACTORIES[kind], records[1::-1])
