"""MergedHistogram: exact values and counts on hand-made jobs, in both modes.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`.
"""

from __future__ import annotations

import math
import struct
import uuid

import polars as pl
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stook.sdk import (
    HistogramMetric,
    MetricsDataView,
    MetricStatus,
    MetricsWriter,
    MetricType,
    SeriesKind,
    TextMetric,
    WriterError,
    data,
    read_metrics_data,
)
from stook.sdk._writer import histogram_buckets
from stook.sdk.aggregations import JobRecord, MergedHistogram, SeriesByName, _histogram
from tests.sdk.aggregations.support import Output, fold, job, reference_counts


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
    assert out.view.metric("Speed", HistogramMetric).x_axis_name == "v [m/s]"
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
    assert out.view.metric("H", TextMetric).text == (
        "No job wrote values for 'd'; nothing to draw."
    )


def test_histogram_needs_its_data_and_checks_its_bounds() -> None:
    assert MergedHistogram(name="H", data="d", lower=0, upper=1).needs().data == {"d"}
    with pytest.raises(WriterError, match="lower < upper"):
        MergedHistogram(name="H", data="d", lower=1, upper=1)
    with pytest.raises(ValueError, match="max_values must be at least 1"):
        MergedHistogram(name="H", data="d", lower=0, upper=1, max_values=0)


def _per_category_record(name: str, values: dict[str, list[float]]) -> JobRecord:
    """A job whose data `name` is per category, as the fetcher hands it: in `data`, with
    no single series."""
    index = data.per_category(
        f"{name} index", SeriesKind.STRING, {k: ["x"] * len(v) for k, v in values.items()}
    )
    per_class = data.per_category(name, SeriesKind.DOUBLE, values, index=index)
    writer = MetricsWriter(uuid.uuid4(), deterministic=True)
    writer.bar_chart("bars", per_class)
    msg = next(d for d in writer.to_proto().metrics_data if d.name == name)
    return JobRecord(
        job_id=uuid.uuid4(),
        conflated_status="PASSED",
        data={name: read_metrics_data(msg.SerializeToString())},
    )


def test_histogram_of_per_category_data_pools_the_categories() -> None:
    jobs = [
        _per_category_record("per class", {"car": [1.0, 3.0], "truck": [2.0]}),
        job(series={"per class": [0.5]}),  # plain doubles of that name still count
        _per_category_record("other", {"car": [9.0]}),
    ]
    agg = fold(MergedHistogram(name="H", data="per class", lower=0.0, upper=4.0, buckets=4), jobs)
    assert isinstance(agg, MergedHistogram)
    assert (agg.total, agg.jobs) == (4, 2)
    assert agg.values().to_list() == [0.5, 1.0, 2.0, 3.0]


def _fetched_job(values: list[float]) -> JobRecord:
    """A job as a fetch hands it over: its series made only when asked for."""
    d = data.doubles("v", values)
    writer = MetricsWriter(uuid.uuid4(), deterministic=True)
    writer.add_data(d)
    view = read_metrics_data(writer.to_proto().metrics_data[0].SerializeToString())
    return JobRecord(uuid.uuid4(), "PASSED", series=SeriesByName({"v": view}), data={"v": view})


@pytest.mark.parametrize("max_values", [10**6, 150, 1])  # exact, switching, counts at once
@pytest.mark.parametrize("length", [5, 90])
def test_histogram_of_fetched_series_is_the_same_as_of_polars_series(
    max_values: int, length: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    special = [math.nan, -0.0, 4.0, 0.0, -math.inf, math.inf, 1.0, 2.5, -7.0, 11.0]
    per_job = [
        [special[(i * 3 + j) % len(special)] + (j % 4) * 0.37 for j in range(length)]
        for i in range(12)
    ]
    jobs = [job(series={"v": vs}) for vs in per_job]
    fetched = [_fetched_job(vs) for vs in per_job]
    # The fetched jobs' series are made only when asked for: the histogram does not ask.
    made: list[str] = []

    def series(view: MetricsDataView) -> None:
        made.append(view.name)  # fails the test below, whatever the fold does next

    monkeypatch.setattr(MetricsDataView, "series", series)

    def histogram() -> MergedHistogram:
        return MergedHistogram("H", "v", lower=0.0, upper=4.0, buckets=4, max_values=max_values)

    mine, mixed, theirs = histogram(), histogram(), histogram()
    fold(mine, fetched)
    fold(mixed, [pair[i % 2] for i, pair in enumerate(zip(fetched, jobs, strict=True))])
    fold(theirs, jobs)
    assert mixed.counts == theirs.counts
    assert (mixed.total, mixed.dropped_nan, mixed.outside) == (
        theirs.total,
        theirs.dropped_nan,
        theirs.outside,
    )
    assert mine.counts == theirs.counts
    assert (mine.total, mine.dropped_nan, mine.jobs, mine.outside) == (
        theirs.total,
        theirs.dropped_nan,
        theirs.jobs,
        theirs.outside,
    )
    assert mine.dropped_nan > 0
    if mine.counts is None:
        assert mine.values().to_numpy().tobytes() == theirs.values().to_numpy().tobytes()
    assert Output(mine).writer.serialize() == Output(theirs).writer.serialize()
    assert made == []


def test_fetched_and_hand_made_jobs_alike_across_many_jobs() -> None:
    # Past _CONSOLIDATE_AT jobs, fetched jobs (values read from the message) and hand-made
    # ones (polars series) alternate in runs: the histogram holds the appended values,
    # whether read directly, after pickling or after a merge.
    import pickle

    per_job = [[i + 0.25, -float(i), 0.0 if i % 7 else -0.0] for i in range(700)]
    records = [
        _fetched_job(vs) if (i // 50) % 3 else job(series={"v": vs}) for i, vs in enumerate(per_job)
    ]
    appended = sorted(v + 0.0 for vs in per_job for v in vs)

    def histogram(part: list[JobRecord]) -> MergedHistogram:
        agg = fold(MergedHistogram("H", "v", lower=0.0, upper=4.0, buckets=4), part)
        assert isinstance(agg, MergedHistogram)
        return agg

    whole = histogram(records)
    assert whole.total == len(appended)
    merged, travelled = histogram(records[:333]), histogram(records[:333])
    merged.merge(histogram(records[333:]))
    travelled.merge(pickle.loads(pickle.dumps(histogram(records[333:]))))
    polars_only = histogram([job(series={"v": vs}) for vs in per_job])
    for agg in (whole, merged, travelled):
        assert agg.values().to_list() == appended
        assert agg.values().to_numpy().tobytes() == polars_only.values().to_numpy().tobytes()
        assert Output(agg).writer.serialize() == Output(polars_only).writer.serialize()


def test_fetched_values_switch_to_counts_with_the_ones_still_waiting() -> None:
    per_job = [[float(i % 5), 9.0] for i in range(300)]
    fetched = fold(
        MergedHistogram("H", "v", lower=0.0, upper=4.0, buckets=4, max_values=500),
        [_fetched_job(vs) for vs in per_job],
    )
    expected = fold(
        MergedHistogram("H", "v", lower=0.0, upper=4.0, buckets=4, max_values=500),
        [job(series={"v": vs}) for vs in per_job],
    )
    assert isinstance(fetched, MergedHistogram)
    assert isinstance(expected, MergedHistogram)
    assert fetched.binned
    assert (fetched.counts, fetched.outside, fetched.total) == (
        expected.counts,
        expected.outside,
        expected.total,
    )


@pytest.mark.parametrize("compare_up_to", [0, 10**6], ids=["search", "compare"])
@given(
    buckets=st.sampled_from([1, 2, 7, 20, 129]),
    picks=st.lists(st.integers(0, 10**6), max_size=60),
    extra=st.lists(
        st.floats(allow_nan=False) | st.sampled_from([-0.0, 0.0, 4.0, math.inf, -math.inf]),
        max_size=20,
    ),
)
def test_both_ways_of_binning_count_as_the_reference(
    compare_up_to: int, buckets: int, picks: list[int], extra: list[float]
) -> None:
    # Up to _COMPARE_UP_TO buckets values are counted by a comparison pass per edge, past
    # it by a search of the edges: each must put every value where `reference_counts` does.
    edges = histogram_buckets("H", buckets, 0.0, 4.0)
    on_edges = [lo for lo, _ in edges] + [4.0]
    values = [on_edges[p % len(on_edges)] for p in picks] + extra
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(_histogram, "_COMPARE_UP_TO", compare_up_to)
        agg = fold(
            MergedHistogram("H", "v", lower=0.0, upper=4.0, buckets=buckets, max_values=1),
            [job(series={"v": [9.0, 9.0]}), job(series={"v": values})],
        )
        assert isinstance(agg, MergedHistogram)
        assert agg.counts == reference_counts([9.0, 9.0, *values], edges)
        assert agg.outside == 2 + sum(1 for v in values if v < 0.0 or v > 4.0)


def test_kept_values_are_sorted_with_negative_zero_as_zero() -> None:
    per_job = [[2.0, -0.0, math.inf], [0.0, -math.inf, -0.0, 5e-324, -5e-324], [1.0, -2.0]]
    agg = fold(MergedHistogram("H", "v", lower=0.0, upper=4.0), [_fetched_job(per_job[0])])
    agg = fold(agg, [job(series={"v": vs}) for vs in per_job[1:]])
    assert isinstance(agg, MergedHistogram)
    got = agg.values()
    expected = sorted(0.0 if v == 0.0 else v for vs in per_job for v in vs)
    assert (got.name, got.dtype) == ("v", pl.Float64())
    assert got.to_numpy().tobytes() == struct.pack(f"<{len(expected)}d", *expected)


def test_kept_nulls_read_as_zeros_as_they_always_have() -> None:
    # Only a hand-made record's series can hold nulls (a read one cannot): they are kept
    # as zeros, which the written histogram shows, as before.
    agg = fold(
        MergedHistogram("H", "v", lower=0.0, upper=4.0),
        [
            job(series={"v": [1.0, -0.0]}),
            JobRecord(uuid.uuid4(), "PASSED", series={"v": pl.Series([None, 3.0])}),
        ],
    )
    assert isinstance(agg, MergedHistogram)
    assert agg.values().to_list() == [0.0, 0.0, 1.0, 3.0]
