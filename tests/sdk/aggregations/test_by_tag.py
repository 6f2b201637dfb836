"""[[batch.by_tag]]: pass rate and scalar means per experience tag, a BAR_CHART each."""

from __future__ import annotations

import math

import pytest

from stook.sdk import MetricStatus, MetricType
from stook.sdk.aggregations import ByExperienceTag, Needs, Scalar
from tests.sdk.aggregations.job_outputs import job_with
from tests.sdk.aggregations.support import Output, fold


def tagged(status: str, tags: list[str], **scalars: float | Scalar):  # type: ignore[no-untyped-def]
    return job_with(status, tags=tags, scalars=scalars)


def test_pass_rate_and_means_per_tag_untagged_last() -> None:
    jobs = [
        tagged("PASSED", ["night", "rain"], Speed=Scalar(10.0, "m/s")),
        tagged("BLOCKER", ["rain"], Speed=20.0),
        tagged("PASSED", [], Speed=5.0),
        tagged("ERROR", ["night"], Speed=math.inf),
        tagged("PASSED", ["city"]),
    ]
    out = Output(fold(ByExperienceTag(metrics=["Speed"]), jobs))
    assert out.names == ["Pass rate by experience tag", "Speed (mean) by experience tag"]
    assert out.bars("Pass rate by experience tag") == {
        "city": 100.0,
        "night": 50.0,
        "rain": 50.0,
        "(untagged)": 100.0,
    }
    # Tags without the scalar (city) or with only non-finite values (none here) have no bar.
    assert out.bars("Speed (mean) by experience tag") == {
        "night": 10.0,
        "rain": 15.0,
        "(untagged)": 5.0,
    }
    speed = out.metric("Speed (mean) by experience tag", MetricType.BAR_CHART)
    assert speed.raw.metric_values.bar_chart_metric_values.y_axis_name == "Speed (mean, m/s)"


def test_a_metric_no_job_has_writes_no_chart() -> None:
    out = Output(fold(ByExperienceTag(metrics=["Absent"]), [tagged("PASSED", ["a"])]))
    assert out.names == ["Pass rate by experience tag"]


def test_no_jobs_say_so() -> None:
    out = Output(ByExperienceTag())
    m = out.metric("Pass rate by experience tag", MetricType.TEXT)
    assert m.status is MetricStatus.NOT_APPLICABLE


def test_needs_tags_and_scalars() -> None:
    assert ByExperienceTag(metrics=["A"]).needs() == Needs(
        experience_tags=True, scalars=frozenset({"A"})
    )
    with pytest.raises(ValueError, match="names one twice"):
        ByExperienceTag(metrics=["A", "A"])
