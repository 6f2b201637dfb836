"""Aggregations: batch metrics computed as mergeable partial states.

An aggregation folds in one job at a time (`update`), combines with another
partial state built from other jobs (`merge`) and writes its metrics (`finish`)
through a `MetricsWriter`. Write your own by subclassing `Aggregation` as a
dataclass, and name it in the config as ``[[batch.custom]] class = "pkg.mod:Class"``
or register it under the ``stook.aggregations`` entry-point group.
"""

# Each name is imported on first use (see stook.sdk._lazy): a batch run reads Needs and
# builds four aggregations, and need not import the rest, nor the report aggregations.
import typing as _typing

if _typing.TYPE_CHECKING:
    from stook.sdk.aggregations._base import Aggregation, BatchAggregation, Needs, ReportAggregation
    from stook.sdk.aggregations._baseline import (
        BaselineComparison,
        BaselineInfo,
        ComparisonResult,
        MetricComparison,
        PassRateComparison,
    )
    from stook.sdk.aggregations._by_tag import ByExperienceTag
    from stook.sdk.aggregations._category_totals import CategoryTotals
    from stook.sdk.aggregations._columns import JobColumns, ScalarColumn
    from stook.sdk.aggregations._errors import JobDataError
    from stook.sdk.aggregations._event_counts import EventCounts
    from stook.sdk.aggregations._histogram import MergedHistogram
    from stook.sdk.aggregations._record import (
        UNKNOWN_STATUS,
        BatchRecord,
        JobEvent,
        JobRecord,
        JobSummary,
        Scalar,
    )
    from stook.sdk.aggregations._registry import (
        AggregationConfigError,
        build,
        build_all,
        default_batch_aggregations,
        default_report_aggregations,
    )
    from stook.sdk.aggregations._scalar_defaults import ScalarDefaults
    from stook.sdk.aggregations._scalar_stats import ScalarStats
    from stook.sdk.aggregations._series_map import SeriesByName
    from stook.sdk.aggregations._status_counts import (
        JOB_STATUSES,
        METRIC_STATUSES,
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
        SummaryError,
        SummaryJob,
        SummaryVersionError,
        decode_summary,
        encode_summary,
        summary_columns_from_data,
        summary_from_data,
    )
    from stook.sdk.aggregations._sweep import ParameterSweep
    from stook.sdk.aggregations._weighted_mean import WeightedMean
else:
    from stook.sdk._lazy import lazy_exports as _lazy_exports

    __getattr__, __dir__ = _lazy_exports(
        __name__,
        {
            "Aggregation": "._base",
            "BatchAggregation": "._base",
            "Needs": "._base",
            "ReportAggregation": "._base",
            "BaselineComparison": "._baseline",
            "BaselineInfo": "._baseline",
            "ComparisonResult": "._baseline",
            "MetricComparison": "._baseline",
            "PassRateComparison": "._baseline",
            "ByExperienceTag": "._by_tag",
            "CategoryTotals": "._category_totals",
            "JobColumns": "._columns",
            "ScalarColumn": "._columns",
            "JobDataError": "._errors",
            "EventCounts": "._event_counts",
            "MergedHistogram": "._histogram",
            "UNKNOWN_STATUS": "._record",
            "BatchRecord": "._record",
            "JobEvent": "._record",
            "JobRecord": "._record",
            "JobSummary": "._record",
            "Scalar": "._record",
            "AggregationConfigError": "._registry",
            "build": "._registry",
            "build_all": "._registry",
            "default_batch_aggregations": "._registry",
            "default_report_aggregations": "._registry",
            "ScalarDefaults": "._scalar_defaults",
            "ScalarStats": "._scalar_stats",
            "SeriesByName": "._series_map",
            "JOB_STATUSES": "._status_counts",
            "METRIC_STATUSES": "._status_counts",
            "JobStatusCounts": "._status_counts",
            "MetricStatusCounts": "._status_counts",
            "PassRate": "._status_counts",
            "SUMMARY_DATA_NAME": "._summary",
            "SUMMARY_VERSION": "._summary",
            "BatchSummary": "._summary",
            "BatchSummaryWriter": "._summary",
            "ColumnarSummary": "._summary",
            "SummaryError": "._summary",
            "SummaryJob": "._summary",
            "SummaryVersionError": "._summary",
            "decode_summary": "._summary",
            "encode_summary": "._summary",
            "summary_columns_from_data": "._summary",
            "summary_from_data": "._summary",
            "ParameterSweep": "._sweep",
            "WeightedMean": "._weighted_mean",
        },
    )

__all__ = [
    "JOB_STATUSES",
    "METRIC_STATUSES",
    "SUMMARY_DATA_NAME",
    "SUMMARY_VERSION",
    "UNKNOWN_STATUS",
    "Aggregation",
    "AggregationConfigError",
    "BaselineComparison",
    "BaselineInfo",
    "BatchAggregation",
    "BatchRecord",
    "BatchSummary",
    "BatchSummaryWriter",
    "ByExperienceTag",
    "CategoryTotals",
    "ColumnarSummary",
    "ComparisonResult",
    "EventCounts",
    "JobColumns",
    "JobDataError",
    "JobEvent",
    "JobRecord",
    "JobStatusCounts",
    "JobSummary",
    "MergedHistogram",
    "MetricComparison",
    "MetricStatusCounts",
    "Needs",
    "ParameterSweep",
    "PassRate",
    "PassRateComparison",
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
    "default_report_aggregations",
    "encode_summary",
    "summary_columns_from_data",
    "summary_from_data",
]
