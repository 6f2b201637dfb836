"""stook's SDK: write, read and validate ReSim-compatible ``metrics.binproto`` files.

No network code lives here. The public surface is re-exported below; everything
in ``_modules`` is private.

    from stook.sdk import MetricsWriter, MetricStatus, data

    w = MetricsWriter(job_id)
    w.scalar("Max speed", 31.2, unit="m/s", fails_above=35.0)
    w.histogram("Speeds", data.doubles("speeds", speeds), buckets=20, lower=0, upper=40)
    w.write("/tmp/resim/outputs/metrics.binproto")
"""

import typing as _typing

# Each name is imported on first use (see stook.sdk._lazy): `stook show` reads a file and
# need not import the writer, and the two polars dtypes import polars (and numpy), which
# reading, writing and validating a file do not need.
if _typing.TYPE_CHECKING:
    from stook.sdk import data
    from stook.sdk._atomic import remove_stale_temp_files, write_atomic
    from stook.sdk._data import MetricsData
    from stook.sdk._enums import MetricImportance, MetricStatus, MetricType, SeriesKind
    from stook.sdk._errors import (
        InvalidMetricsError,
        MissingDataError,
        OutputWriteError,
        Problem,
        ReadError,
        StookError,
        WriterError,
    )
    from stook.sdk._handle import MetricHandle, MetricOptions
    from stook.sdk._metric_views import (
        BarChartMetric,
        BatchwiseBarChartMetric,
        Bucket,
        DoubleOverTimeMetric,
        DoubleSummaryMetric,
        FailureLimits,
        HistogramMetric,
        ImageListMetric,
        ImageMetric,
        LinePlotMetric,
        PlotlyMetric,
        ScalarMetric,
        StatesOverTimeMetric,
        TextMetric,
        TypedMetric,
        UnknownMetric,
    )
    from stook.sdk._reader import (
        parse_job_metrics,
        parse_metric,
        parse_metrics_data,
        read_job_metrics,
        read_metric,
        read_metrics_data,
    )
    from stook.sdk._series import KIND_DTYPE, STATUS_DTYPE
    from stook.sdk._validate import find_problems, validate_job_metrics
    from stook.sdk._views import EventView, JobMetricsView, MetricsDataView, MetricView
    from stook.sdk._writer import MetricsWriter
else:
    from stook.sdk._lazy import lazy_exports as _lazy_exports

    __getattr__, __dir__ = _lazy_exports(
        __name__,
        {
            "remove_stale_temp_files": "._atomic",
            "write_atomic": "._atomic",
            "MetricsData": "._data",
            "MetricImportance": "._enums",
            "MetricStatus": "._enums",
            "MetricType": "._enums",
            "SeriesKind": "._enums",
            "InvalidMetricsError": "._errors",
            "MissingDataError": "._errors",
            "OutputWriteError": "._errors",
            "Problem": "._errors",
            "ReadError": "._errors",
            "StookError": "._errors",
            "WriterError": "._errors",
            "MetricHandle": "._handle",
            "MetricOptions": "._handle",
            "BarChartMetric": "._metric_views",
            "BatchwiseBarChartMetric": "._metric_views",
            "Bucket": "._metric_views",
            "DoubleOverTimeMetric": "._metric_views",
            "DoubleSummaryMetric": "._metric_views",
            "FailureLimits": "._metric_views",
            "HistogramMetric": "._metric_views",
            "ImageListMetric": "._metric_views",
            "ImageMetric": "._metric_views",
            "LinePlotMetric": "._metric_views",
            "PlotlyMetric": "._metric_views",
            "ScalarMetric": "._metric_views",
            "StatesOverTimeMetric": "._metric_views",
            "TextMetric": "._metric_views",
            "TypedMetric": "._metric_views",
            "UnknownMetric": "._metric_views",
            "parse_job_metrics": "._reader",
            "parse_metric": "._reader",
            "parse_metrics_data": "._reader",
            "read_job_metrics": "._reader",
            "read_metric": "._reader",
            "read_metrics_data": "._reader",
            "find_problems": "._validate",
            "validate_job_metrics": "._validate",
            "EventView": "._views",
            "JobMetricsView": "._views",
            "MetricsDataView": "._views",
            "MetricView": "._views",
            "MetricsWriter": "._writer",
            "KIND_DTYPE": "._series",
            "STATUS_DTYPE": "._series",
            "data": ".data",
        },
    )


__all__ = [
    "KIND_DTYPE",
    "STATUS_DTYPE",
    "BarChartMetric",
    "BatchwiseBarChartMetric",
    "Bucket",
    "DoubleOverTimeMetric",
    "DoubleSummaryMetric",
    "EventView",
    "FailureLimits",
    "HistogramMetric",
    "ImageListMetric",
    "ImageMetric",
    "InvalidMetricsError",
    "JobMetricsView",
    "LinePlotMetric",
    "MetricHandle",
    "MetricImportance",
    "MetricOptions",
    "MetricStatus",
    "MetricType",
    "MetricView",
    "MetricsData",
    "MetricsDataView",
    "MetricsWriter",
    "MissingDataError",
    "OutputWriteError",
    "PlotlyMetric",
    "Problem",
    "ReadError",
    "ScalarMetric",
    "SeriesKind",
    "StatesOverTimeMetric",
    "StookError",
    "TextMetric",
    "TypedMetric",
    "UnknownMetric",
    "WriterError",
    "data",
    "find_problems",
    "parse_job_metrics",
    "parse_metric",
    "parse_metrics_data",
    "read_job_metrics",
    "read_metric",
    "read_metrics_data",
    "remove_stale_temp_files",
    "validate_job_metrics",
    "write_atomic",
]
