"""The SDK's public surface, pinned: adding or removing a public name is a deliberate act.

Each package's ``__all__`` is written out in full below, so that a name added to it,
or dropped from it, by accident fails here. The other tests make sure the listed names
resolve and that nothing public in a package is left out of its ``__all__`` (as httpx
checks its own exports). Everything in an ``_``-module is private; the service and
user code import from these packages only.
"""

from __future__ import annotations
import __future__

import importlib
import inspect

import pytest

PUBLIC_API: dict[str, list[str]] = {
    "stook.sdk": [
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
    ],
    "stook.sdk.dtypes": [
        "KIND_DTYPE",
        "STATUS_DTYPE",
    ],
    "stook.sdk.data": [
        "MetricsData",
        "doubles",
        "external_file",
        "per_category",
        "status_like",
        "statuses",
        "strings",
        "timestamps",
        "uuids",
    ],
    "stook.sdk.aggregations": [
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
    ],
    "stook.sdk.testing": [
        "CHECK_JOB_ID",
        "MergeLaws",
        "check_merge_laws",
    ],
    "stook.sdk.stats": [
        "Better",
        "ComparisonVerdict",
        "Interval",
        "MeanDifference",
        "bootstrap_mean_difference",
        "comparison_verdict",
        "holm_adjusted",
        "mean_interval",
        "newcombe_difference",
        "normal_quantile",
        "seed_from",
        "wilson_interval",
    ],
    "stook.sdk.aggregations.baseline": [
        "BaselineComparison",
        "BaselineInfo",
        "ComparisonResult",
        "MetricComparison",
        "PassRateComparison",
    ],
    "stook.sdk.aggregations.report": [
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
    ],
}

PACKAGES = sorted(PUBLIC_API)


@pytest.mark.parametrize("package", PACKAGES)
def test_all_is_exactly_the_pinned_list(package: str) -> None:
    assert importlib.import_module(package).__all__ == PUBLIC_API[package]


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_name_resolves(package: str) -> None:
    module = importlib.import_module(package)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == []


@pytest.mark.parametrize("package", PACKAGES)
def test_nothing_public_is_left_out_of_all(package: str) -> None:
    module = importlib.import_module(package)
    # Subpackages become attributes when imported (stook.sdk.aggregations, example);
    # they are reached by their dotted name, not through __all__. Nor is the
    # ``annotations`` of ``from __future__ import annotations`` a name of the module's.
    public = {
        name
        for name, value in vars(module).items()
        if not name.startswith("_")
        and not (inspect.ismodule(value) and name not in module.__all__)
        and value is not __future__.annotations
    }
    assert sorted(public) == sorted(module.__all__)


def test_names_the_service_uses_are_public() -> None:
    # What stook.service needs from the SDK; it must never need an _-module for these.
    sdk = importlib.import_module("stook.sdk")
    aggregations = importlib.import_module("stook.sdk.aggregations")
    for name in (
        "MetricStatus",
        "MetricType",
        "SeriesKind",
        "StookError",
        "ReadError",
        "InvalidMetricsError",
        "OutputWriteError",
        "WriterError",
        "JobMetricsView",
        "MetricView",
        "read_job_metrics",
        "read_metric",
        "read_metrics_data",
        "find_problems",
        "MetricsWriter",
        "write_atomic",
        "remove_stale_temp_files",
        "data",
    ):
        assert name in sdk.__all__, name
    for name in (
        "UNKNOWN_STATUS",
        "Aggregation",
        "AggregationConfigError",
        "BatchAggregation",
        "BatchRecord",
        "JobRecord",
        "JobSummary",
        "Needs",
        "ReportAggregation",
        "Scalar",
        "SeriesByName",
        "build_all",
        "default_batch_aggregations",
    ):
        assert name in aggregations.__all__, name


def test_ruff_bans_every_private_sdk_module_outside_the_sdk() -> None:
    # The rule (TID251) lists modules one by one; a new _-module must join the list, and a
    # module merged away must leave it.
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    settings = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["ruff"]["lint"]
    banned = set(settings["flake8-tidy-imports"]["banned-api"])
    src = root / "sdk" / "src"
    private = {
        ".".join(path.relative_to(src).with_suffix("").parts)
        for path in src.rglob("_*.py")
        if path.name != "__init__.py"
    }
    assert private <= banned, sorted(private - banned)
    sdk_banned = {name for name in banned if name.startswith("stook.sdk.")}
    assert sdk_banned <= private, sorted(sdk_banned - private)  # none left for a module gone
    assert "TID251" in settings["select"]
    assert settings["per-file-ignores"] == {"sdk/**": ["TID251"], "tests/**": ["TID251"]}


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_name_is_in_the_api_reference(package: str) -> None:
    # Each name renders from its docstring (mkdocstrings), as `::: package.Name`, or
    # with its whole module, as `::: package`.
    from pathlib import Path

    reference = Path(__file__).resolve().parents[2] / "docs" / "reference"
    entries = {
        line.removeprefix("::: ").strip()
        for page in reference.glob("*.md")
        for line in page.read_text().splitlines()
        if line.startswith("::: ")
    }
    if package in entries:
        return
    missing = [name for name in PUBLIC_API[package] if f"{package}.{name}" not in entries]
    assert missing == []
