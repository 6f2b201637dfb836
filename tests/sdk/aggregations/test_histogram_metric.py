"""[[batch.histogram]] metric = ...: the tests' own HISTOGRAM metrics, merged on their buckets."""

from __future__ import annotations

import uuid

import pytest

from stook.sdk import MetricStatus, MetricType
from stook.sdk.aggregations import JobDataError, MergedHistogram, Needs
from tests.sdk.aggregations.job_outputs import job_with
from tests.sdk.aggregations.support import Output, fold, job, reference_counts

BUCKETS = [(-8.0 + i, -7.0 + i) for i in range(16)]
UNEVEN = [(0.0, 1.0), (1.0, 5.0), (5.0, 100.0)]


def speeds(values: list[float], buckets: list[tuple[float, float]] = BUCKETS, **kw: object):  # type: ignore[no-untyped-def]
    return job_with(histogram=("Speed histogram", values, buckets), **kw)  # type: ignore[arg-type]


def merged(**kw: object) -> MergedHistogram:
    return MergedHistogram(name="Speeds", metric="Speed histogram", **kw)  # type: ignore[arg-type]


def test_values_of_every_job_are_merged_on_the_buckets_the_jobs_used() -> None:
    jobs = [speeds([1.5, -3.0]), speeds([7.5]), job(), speeds([-8.0, 0.0, 0.25])]
    out = Output(fold(merged(), jobs))
    values, buckets, m = out.histogram("Speeds")
    assert values == [-8.0, -3.0, 0.0, 0.25, 1.5, 7.5]
    assert buckets == BUCKETS
    assert "6 values of histogram metric 'Speed histogram' from 3 jobs" in m.description


def test_uneven_buckets_are_kept_as_they_were() -> None:
    out = Output(fold(merged(), [speeds([0.5, 2.0], UNEVEN), speeds([50.0], UNEVEN)]))
    values, buckets, _ = out.histogram("Speeds")
    assert buckets == UNEVEN
    assert values == [0.5, 2.0, 50.0]


def test_past_the_cap_it_counts_per_bucket_of_the_jobs_buckets() -> None:
    values = [0.5, 2.0, 3.0, 50.0, 99.0, 500.0, -1.0]
    agg = fold(merged(max_values=3), [speeds(values[:4], UNEVEN), speeds(values[4:], UNEVEN)])
    assert isinstance(agg, MergedHistogram)
    assert agg.counts == reference_counts(values, UNEVEN) == [2, 2, 3]
    assert agg.outside == 2
    out = Output(agg)
    assert out.bars("Speeds (counts)") == {"[0, 1)": 2.0, "[1, 5)": 2.0, "[5, 100)": 3.0}
    _, buckets, _ = out.histogram("Speeds")
    assert buckets == UNEVEN


def test_differing_buckets_are_invalid_data_naming_two_jobs() -> None:
    a, b = uuid.uuid4(), uuid.uuid4()
    agg = merged()
    agg.update(speeds([1.0], job_id=a))
    shifted = [(lo + 0.5, hi + 0.5) for lo, hi in BUCKETS]
    with pytest.raises(JobDataError) as info:
        agg.update(speeds([1.0], shifted, job_id=b))
    message = str(info.value)
    assert str(a) in message
    assert str(b) in message
    assert "16 from -8 to 8 vs 16 from -7.5 to 8.5" in message


def test_buckets_differing_inside_the_same_range_name_the_first_bucket_apart() -> None:
    inner = [(0.0, 2.0), (2.0, 5.0), (5.0, 100.0)]
    agg = merged()
    agg.update(speeds([1.0], UNEVEN))
    with pytest.raises(JobDataError, match=r"bucket 0 is \[0, 1\) vs \[0, 2\)"):
        agg.update(speeds([1.0], inner))


def test_differing_buckets_are_found_when_partials_merge() -> None:
    left, right = merged(), merged()
    left.update(speeds([1.0]))
    right.update(speeds([1.0], UNEVEN))
    with pytest.raises(JobDataError, match="different buckets"):
        left.merge(right)
    # An empty partial takes the other's buckets; one without jobs adds nothing.
    empty = merged()
    empty.merge(left)
    assert empty.edges == BUCKETS
    left.merge(merged())
    assert left.edges == BUCKETS


def test_a_metric_of_another_type_is_invalid_data_naming_the_job() -> None:
    bad = job_with(bars=("Speed histogram", {"a": {"x": 1.0}}))
    with pytest.raises(JobDataError, match=rf"job {bad.job_id}: metric 'Speed histogram' is a "):
        merged().update(bad)


def test_no_job_with_the_metric_says_so() -> None:
    out = Output(fold(merged(), [job(), job_with(histogram=("Other", [1.0], BUCKETS))]))
    m = out.metric("Speeds", MetricType.TEXT)
    assert m.status is MetricStatus.NOT_APPLICABLE
    assert "histogram metric 'Speed histogram'" in m.raw.metric_values.text_metric_values.text


def test_the_x_axis_name_is_the_jobs_when_they_agree() -> None:
    same = [speeds([1.0], x_axis_name="m/s"), speeds([2.0], x_axis_name="m/s")]
    axis = Output(fold(merged(), same)).histogram("Speeds")[2]
    assert axis.raw.metric_values.histogram_metric_values.x_axis_name == "m/s"
    differ = [*same, speeds([3.0], x_axis_name="km/h")]
    axis = Output(fold(merged(), differ)).histogram("Speeds")[2]
    assert axis.raw.metric_values.histogram_metric_values.x_axis_name == ""
    axis = Output(fold(merged(x_axis_name="speed"), differ)).histogram("Speeds")[2]
    assert axis.raw.metric_values.histogram_metric_values.x_axis_name == "speed"


def test_it_asks_for_the_metric_not_for_data() -> None:
    assert merged().needs() == Needs(metrics=frozenset({"Speed histogram"}))


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"metric": "M", "data": "d"}, "exactly one of 'data'"),
        ({}, "exactly one of 'data'"),
        ({"metric": "M", "lower": 0.0}, "'lower' cannot be given with 'metric'"),
        ({"metric": "M", "buckets": 4}, "'buckets' cannot be given with 'metric'"),
        ({"data": "d", "upper": 1.0}, "missing key 'lower'"),
    ],
)
def test_bad_combinations_of_keys_are_refused(options: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        MergedHistogram(name="H", **options)  # type: ignore[arg-type]
