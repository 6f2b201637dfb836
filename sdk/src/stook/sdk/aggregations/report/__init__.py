"""Report aggregations: longitudinal metrics over a test suite's batches.

Each folds in one `BatchRecord` at a time, like batch aggregations fold in jobs.
"""

from stook.sdk.aggregations._registry import default_report_aggregations
from stook.sdk.aggregations.report._change_points import Verdict, check
from stook.sdk.aggregations.report._change_report import ChangePoints, ChangePointSummary
from stook.sdk.aggregations.report._experiences import (
    FlakyExperiences,
    MostFailedExperiences,
    UnstableExperiences,
)
from stook.sdk.aggregations.report._lines import (
    JobScalarDistributions,
    RegressionSummary,
    ScalarLines,
)
from stook.sdk.aggregations.report._statuses import (
    BatchMetricStatusCounts,
    JobMetricStatusCounts,
    TestStatusOverTime,
)

__all__ = [
    "BatchMetricStatusCounts",
    "ChangePointSummary",
    "ChangePoints",
    "FlakyExperiences",
    "JobMetricStatusCounts",
    "JobScalarDistributions",
    "MostFailedExperiences",
    "RegressionSummary",
    "ScalarLines",
    "TestStatusOverTime",
    "UnstableExperiences",
    "Verdict",
    "check",
    "default_report_aggregations",
]
