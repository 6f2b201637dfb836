"""stook's SDK: write, read and validate ReSim-compatible ``metrics.binproto`` files.

No network code lives here. The public surface is re-exported below; everything
in ``_modules`` is private.

    from stook.sdk import MetricsWriter, MetricStatus, data

    w = MetricsWriter(job_id)
    w.scalar("Max speed", 31.2, unit="m/s", fails_above=35.0)
    w.histogram("Speeds", data.doubles("speeds", speeds), buckets=20, lower=0, upper=40)
    w.write("/tmp/resim/outputs/metrics.binproto")
"""

# polars and numpy are imported by the functions that build frames, not here: reading,
# writing and validating a file do not need them (the frames' dtypes are in stook.sdk.dtypes).
from stook.sdk import data
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
from stook.sdk._output import MetricHandle, MetricOptions, remove_stale_temp_files, write_atomic
from stook.sdk._reader import (
    parse_job_metrics,
    parse_metric,
    parse_metrics_data,
    read_job_metrics,
    read_metric,
    read_metrics_data,
)
from stook.sdk._validate import find_problems, validate_job_metrics
from stook.sdk._views import (
    BarChartMetric,
    BatchwiseBarChartMetric,
    Bucket,
    DoubleOverTimeMetric,
    DoubleSummaryMetric,
    EventView,
    FailureLimits,
    HistogramMetric,
    ImageListMetric,
    ImageMetric,
    JobMetricsView,
    LinePlotMetric,
    MetricsDataView,
    MetricView,
    PlotlyMetric,
    ScalarMetric,
    StatesOverTimeMetric,
    TextMetric,
    TypedMetric,
    UnknownMetric,
)
from stook.sdk._writer import MetricsWriter

__all__ = [
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
