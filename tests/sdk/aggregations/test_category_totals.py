"""[[batch.category_totals]]: per-category sums and means per job across jobs, labels kept."""

from __future__ import annotations

import math

import pytest

from stook.sdk import MetricStatus, MetricType
from stook.sdk.aggregations import CategoryTotals, JobDataError, Needs
from tests.sdk.aggregations.job_outputs import bar_series, job_with
from tests.sdk.aggregations.support import Output, fold, job


def detections(by_class: dict[str, list[float]]):  # type: ignore[no-untyped-def]
    return job_with(per_category=("detections per class", by_class))


def test_per_category_data_is_summed_per_category_labels_sorted() -> None:
    jobs = [
        detections({"truck": [1.0, 2.0], "car": [5.0]}),
        detections({"car": [1.0], "pedestrian": [4.0, 0.5]}),
        job(),  # without the data: not counted in the means
    ]
    out = Output(fold(CategoryTotals(data="detections per class"), jobs))
    name = "detections per class (total)"
    assert out.names == [name, f"{name} (mean per job)"]
    totals = bar_series(out, name)
    assert totals == {"detections per class": {"car": 6.0, "pedestrian": 4.5, "truck": 3.0}}
    assert list(totals["detections per class"]) == ["car", "pedestrian", "truck"]
    means = bar_series(out, f"{name} (mean per job)")["detections per class"]
    assert means == {"car": 3.0, "pedestrian": 2.25, "truck": 1.5}
    assert "across 2 jobs" in out.by_name[name].description


def test_doubles_indexed_by_string_labels_are_summed_per_label() -> None:
    jobs = [
        job_with(labelled=("per class", ["car", "bus", "car"], [1.0, 2.0, 3.0])),
        job_with(labelled=("per class", ["bus"], [10.0])),
    ]
    agg = CategoryTotals(data="per class", name="Per class")
    assert agg.needs() == Needs(
        data=frozenset({"per class"}), data_with_index=frozenset({"per class"})
    )
    out = Output(fold(agg, jobs))
    assert bar_series(out, "Per class") == {"per class": {"bus": 12.0, "car": 4.0}}


def test_labels_not_fetched_are_named_as_the_fix() -> None:
    record = job_with(labelled=("per class", ["car"], [1.0]), with_labels=False)
    with pytest.raises(JobDataError, match=r"not fetched \(declare it in Needs.data_with_index"):
        CategoryTotals(data="per class").update(record)


def test_a_bar_chart_metric_keeps_one_series_per_legend_name() -> None:
    jobs = [
        job_with(bars=("Detections per class", {"found": {"car": 3.0}, "missed": {"car": 1.0}})),
        job_with(bars=("Detections per class", {"found": {"bus": 2.0, "car": 1.0}})),
    ]
    agg = fold(CategoryTotals(metric="Detections per class", name="Detections"), jobs)
    out = Output(agg)
    assert bar_series(out, "Detections") == {
        "found": {"bus": 2.0, "car": 4.0},
        "missed": {"bus": 0.0, "car": 1.0},
    }
    assert bar_series(out, "Detections (mean per job)")["found"] == {"bus": 1.0, "car": 2.0}


def test_non_finite_values_are_left_out_and_counted() -> None:
    jobs = [detections({"car": [1.0, math.nan, math.inf]}), detections({"car": [2.0]})]
    out = Output(fold(CategoryTotals(data="detections per class", name="T"), jobs))
    assert bar_series(out, "T") == {"detections per class": {"car": 3.0}}
    assert "(2 NaN or infinite values left out)" in out.by_name["T"].description


def test_plain_doubles_have_no_categories_to_total() -> None:
    plain = job_with(histogram=("H", [1.0], [(0.0, 2.0)]))
    values = plain.job_metrics.data_by_name["H values"]  # type: ignore[union-attr]
    record = job_with()
    object.__setattr__(record, "data", {"H values": values})
    with pytest.raises(JobDataError, match=rf"job {record.job_id}: .*no categories to total"):
        CategoryTotals(data="H values").update(record)


def test_a_metric_of_another_type_is_invalid_data() -> None:
    bad = job_with(histogram=("Detections per class", [1.0], [(0.0, 2.0)]))
    with pytest.raises(JobDataError, match="is a HISTOGRAM, not a BAR_CHART"):
        CategoryTotals(metric="Detections per class").update(bad)


def test_no_job_with_the_source_says_so() -> None:
    out = Output(fold(CategoryTotals(data="detections per class"), [job()]))
    m = out.metric("detections per class (total)", MetricType.TEXT)
    assert m.status is MetricStatus.NOT_APPLICABLE


def test_needs_and_the_choice_of_source() -> None:
    assert CategoryTotals(data="d").needs() == Needs(
        data=frozenset({"d"}), data_with_index=frozenset({"d"})
    )
    assert CategoryTotals(metric="m").needs() == Needs(metrics=frozenset({"m"}))
    for options in ({}, {"data": "d", "metric": "m"}):
        with pytest.raises(ValueError, match="exactly one of 'data'"):
            CategoryTotals(**options)
