"""What every report gets: the report built-ins, set from the ``[report]`` settings.

Here rather than beside `default_batch_aggregations`, so that `stook.sdk.aggregations`
(which every batch run imports) does not import the report's modules.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from stook.sdk.aggregations._base import Aggregation
from stook.sdk.aggregations.report._change_report import ChangePoints
from stook.sdk.aggregations.report._experiences import (
    FlakyExperiences,
    MostFailedExperiences,
    UnstableExperiences,
)
from stook.sdk.aggregations.report._lines import JobScalarDistributions, ScalarLines
from stook.sdk.aggregations.report._statuses import (
    BatchMetricStatusCounts,
    JobMetricStatusCounts,
    TestStatusOverTime,
)


def default_report_aggregations(
    *,
    project_id: str,
    top_n: int = 10,
    regression_window: int = 10,
    regression_threshold: float = 3.5,
    job_metrics: Sequence[str] | None = None,
    change_points: bool = True,
    change_penalty: float = 3.0,
    unstable_experiences: bool = True,
) -> list[Aggregation[Any]]:
    """What every report gets; the arguments are the ``[report]`` settings."""
    aggregations: list[Aggregation[Any]] = [
        ScalarLines(
            window=regression_window,
            threshold=regression_threshold,
            change_points=change_points,
            change_penalty=change_penalty,
        ),
        MostFailedExperiences(top_n=top_n),
        TestStatusOverTime(project_id=project_id),
        JobMetricStatusCounts(),
        BatchMetricStatusCounts(),
        JobScalarDistributions(metrics=job_metrics),
        FlakyExperiences(top_n=top_n),
    ]
    if change_points:
        aggregations.append(ChangePoints(penalty=change_penalty, top_n=top_n))
    if unstable_experiences:
        aggregations.append(UnstableExperiences(top_n=top_n, metrics=job_metrics))
    return aggregations
