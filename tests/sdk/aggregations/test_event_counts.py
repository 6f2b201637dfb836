"""[[batch.events]]: the jobs' events counted by name and status, one stacked BAR_CHART."""

from __future__ import annotations

from stook.sdk import MetricStatus, MetricType
from stook.sdk.aggregations import EventCounts, Needs
from tests.sdk.aggregations.job_outputs import bar_series, job_with
from tests.sdk.aggregations.support import Output, fold, job


def test_events_are_counted_by_name_stacked_by_status() -> None:
    jobs = [
        job_with(events=[("Collision", "FAIL_BLOCK"), ("Hard brake", "PASSED")]),
        job_with(events=[("Collision", "FAIL_BLOCK"), ("Collision", "PASSED")]),
        job_with(events=[("Lane change", "SOMETHING_NEW"), ("Hard brake", "FAIL_WARN")]),
        job(),
    ]
    out = Output(fold(EventCounts(), jobs))
    name = "Events by name and status"
    m = out.metric(name, MetricType.BAR_CHART)
    assert m.raw.metric_values.bar_chart_metric_values.stack_bars
    series = bar_series(out, name)
    # Known statuses in the app's order, then others sorted; names sorted.
    assert list(series) == ["PASSED", "FAIL_WARN", "FAIL_BLOCK", "SOMETHING_NEW"]
    assert series == {
        "PASSED": {"Collision": 1.0, "Hard brake": 1.0, "Lane change": 0.0},
        "FAIL_WARN": {"Collision": 0.0, "Hard brake": 1.0, "Lane change": 0.0},
        "FAIL_BLOCK": {"Collision": 2.0, "Hard brake": 0.0, "Lane change": 0.0},
        "SOMETHING_NEW": {"Collision": 0.0, "Hard brake": 0.0, "Lane change": 1.0},
    }
    assert m.description.startswith("6 events of 3 of the batch's 4 jobs")


def test_a_batch_without_events_says_so() -> None:
    out = Output(fold(EventCounts(name="Events"), [job(), job()]))
    m = out.metric("Events", MetricType.TEXT)
    assert m.status is MetricStatus.NOT_APPLICABLE
    assert m.raw.metric_values.text_metric_values.text == "None of the batch's 2 jobs had events."


def test_it_asks_for_events() -> None:
    assert EventCounts().needs() == Needs(events=True)
