"""Aggregations: batch metrics computed as mergeable partial states.

An aggregation folds in one job at a time (`update`), combines with another
partial state built from other jobs (`merge`) and writes its metrics (`finish`)
through a `MetricsWriter`. Write your own by subclassing `Aggregation` as a
dataclass, and name it in the config as ``[[batch.custom]] class = "pkg.mod:Class"``
or register it under the ``stook.aggregations`` entry-point group.
"""

from stook.sdk._errors import (
    AggregationConfigError,
    JobDataError,
    SummaryError,
    SummaryVersionError,
)
from stook.sdk.aggregations._base import (
    UNKNOWN_STATUS,
    Aggregation,
    BatchAggregation,
    BatchRecord,
    JobEvent,
    JobRecord,
    Needs,
    ReportAggregation,
    Scalar,
    SeriesByName,
)
from stook.sdk.aggregations._columns import JobColumns, JobSummary, ScalarColumn
from stook.sdk.aggregations._histogram import MergedHistogram
from stook.sdk.aggregations._job_metrics import CategoryTotals
from stook.sdk.aggregations._registry import (
    build,
    build_all,
    default_batch_aggregations,
)
from stook.sdk.aggregations._scalar_stats import (
    ByExperienceTag,
    ParameterSweep,
    ScalarDefaults,
    ScalarStats,
    WeightedMean,
)
from stook.sdk.aggregations._status_counts import (
    JOB_STATUSES,
    METRIC_STATUSES,
    EventCounts,
    JobStatusCounts,
    MetricStatusCounts,
    PassRate,
)
from stook.sdk.aggregations._summary import (
    SUMMARY_DATA_NAME,
    SUMMARY_VERSION,
    BatchSummary,
    BatchSummaryWriter,
    ColumnarSummary,
    SummaryJob,
    decode_summary,
    encode_summary,
    summary_columns_from_data,
    summary_from_data,
)

__all__ = [
    "JOB_STATUSES",
    "METRIC_STATUSES",
    "SUMMARY_DATA_NAME",
    "SUMMARY_VERSION",
    "UNKNOWN_STATUS",
    "Aggregation",
    "AggregationConfigError",
    "BatchAggregation",
    "BatchRecord",
    "BatchSummary",
    "BatchSummaryWriter",
    "ByExperienceTag",
    "CategoryTotals",
    "ColumnarSummary",
    "EventCounts",
    "JobColumns",
    "JobDataError",
    "JobEvent",
    "JobRecord",
    "JobStatusCounts",
    "JobSummary",
    "MergedHistogram",
    "MetricStatusCounts",
    "Needs",
    "ParameterSweep",
    "PassRate",
    "ReportAggregation",
    "Scalar",
    "ScalarColumn",
    "ScalarDefaults",
    "ScalarStats",
    "SeriesByName",
    "SummaryError",
    "SummaryJob",
    "SummaryVersionError",
    "WeightedMean",
    "build",
    "build_all",
    "decode_summary",
    "default_batch_aggregations",
    "encode_summary",
    "summary_columns_from_data",
    "summary_from_data",
]
