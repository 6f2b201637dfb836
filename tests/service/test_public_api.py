"""stook.service's public surface, pinned as tests/sdk/test_public_api.py pins the SDK's.

``stook.service`` re-exports what a program built on the library needs (clients, retry
policy, limiters, errors, models, fetch cores); each layer's package lists its own public
names. Adding or removing one is a deliberate act: the lists are written out below.
Every package re-exports its names plainly; heavy libraries are imported by the
functions that use them, so importing the packages stays cheap: that is checked here too.
"""

from __future__ import annotations

import importlib
import inspect
import subprocess
import sys

import pytest

PUBLIC_API: dict[str, list[str]] = {
    "stook.service": [
        "AimdLimiter",
        "ApiClient",
        "ApiError",
        "ApiMetric",
        "ApiMetricsData",
        "ApiResponseError",
        "ApiStatusError",
        "AuthError",
        "Batch",
        "BatchFetcher",
        "BodyCap",
        "Build",
        "FetchOutcome",
        "FixedLimit",
        "InvalidDataError",
        "Job",
        "MetricOwner",
        "MissingJob",
        "NotFoundError",
        "OriginUnavailableError",
        "PresignedUrlExpiredError",
        "Report",
        "ReportFetcher",
        "ReportNotFoundError",
        "ReportOutcome",
        "RetriesExhaustedError",
        "RetryAfterTooLongError",
        "RetryPolicy",
        "StorageClient",
        "StorageError",
        "TransportError",
        "fetch_batch",
        "fetch_batch_frame",
        "fetch_report",
    ],
    "stook.service.api": [
        "AimdLimiter",
        "ApiClient",
        "ApiError",
        "ApiMetric",
        "ApiMetricStatus",
        "ApiMetricType",
        "ApiMetricsData",
        "ApiResponseError",
        "ApiStatusError",
        "AuthError",
        "Batch",
        "BatchMetric",
        "BatchMetricsData",
        "BatchStatus",
        "BodyCap",
        "BodyTooLargeError",
        "Branch",
        "Build",
        "ConcurrencyLimit",
        "ConflatedBatchStatus",
        "ConflatedJobStatus",
        "CustomField",
        "CustomFieldType",
        "EventTimestampType",
        "ExecutionStep",
        "Experience",
        "ExperienceTag",
        "FixedLimit",
        "Job",
        "JobEventListing",
        "JobLog",
        "JobStatus",
        "LimitStats",
        "LogType",
        "MetricOwner",
        "MetricsDataStorageType",
        "NotFoundError",
        "Origin",
        "OriginUnavailableError",
        "OriginUnreachableError",
        "PresignedUrlExpiredError",
        "RedirectedRefusalError",
        "Report",
        "Response",
        "RetriesExhaustedError",
        "RetryAfterTooLongError",
        "RetryPolicy",
        "StorageClient",
        "StorageError",
        "TrafficCounts",
        "Transport",
        "TransportError",
        "body_cap_mb",
        "redact_text",
        "redact_url",
    ],
    "stook.service.fetch": [
        "BaselineFound",
        "BatchFetcher",
        "DeadlineReachedError",
        "FetchError",
        "FetchOutcome",
        "InvalidDataError",
        "JobEmissions",
        "MissingJob",
        "OnEmissions",
        "ReportFetcher",
        "ReportNotFoundError",
        "ReportOutcome",
        "decode_values",
        "failure_directions",
        "fetch_emissions",
        "fetch_emissions_log",
        "find_baseline",
        "is_scalar",
        "read_scalars",
        "search_for",
    ],
    "stook.service.modes": [
        "OUTPUT_NAME",
        "ApiAccess",
        "BatchInputs",
        "BatchResult",
        "ConfigError",
        "EngineSettings",
        "FetchSettings",
        "InputsError",
        "MissingJobsError",
        "OutputsError",
        "Progress",
        "RecordingProgress",
        "ReportInputs",
        "ReportResult",
        "RunResult",
        "StookConfig",
        "TestInputs",
        "Traffic",
        "UserFunctionError",
        "batch_aggregations",
        "check_outputs_folder",
        "configure_logging",
        "detect",
        "engine_for",
        "event_loop_factory",
        "fetch_batch",
        "fetch_batch_frame",
        "fetch_report",
        "for_stream",
        "human_bytes",
        "load",
        "open_api",
        "parse",
        "report_aggregations",
        "run_batch",
        "run_on_event_loop",
        "run_report",
        "run_test_mode",
    ],
    "stook.service.preview": [
        "PREVIEW_NAME",
        "PreviewInput",
        "render_html",
        "summary_lines",
        "write_preview",
    ],
    "stook.service.metrics_config": [
        "LEVELS",
        "EmissionsError",
        "EmissionsSet",
        "Evaluation",
        "JobMeta",
        "Level",
        "Metric",
        "MetricsConfig",
        "MetricsConfigError",
        "OfflineJob",
        "QueryError",
        "Tables",
        "TemplateError",
        "Topic",
        "check_config",
        "evaluate",
        "find_jobs",
        "load_config",
        "read_config",
        "stable_id",
    ],
    "stook.service.cli": ["Voice", "build_parser", "main", "run_cli"],
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
    assert set(module.__all__) <= set(dir(module))


@pytest.mark.parametrize("package", PACKAGES)
def test_nothing_public_is_left_out_of_all(package: str) -> None:
    module = importlib.import_module(package)
    public = {
        name
        for name, value in vars(module).items()
        if not name.startswith("_") and not inspect.ismodule(value)
    }
    # Not equality: `stook.service` binds its names on first use (its docstring says why).
    assert sorted(public - set(module.__all__)) == []


def modules_after(code: str) -> set[str]:
    """The top-level modules a fresh interpreter has imported after running `code`."""
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            f"{code}\nimport sys\nprint(' '.join({{m.split('.')[0] for m in sys.modules}}))",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    return set(done.stdout.splitlines()[-1].split())


@pytest.mark.parametrize(
    "code",
    [
        "import stook.service",
        "import stook.service.cli",
        # `stook --help`: the console script's own path, up to argparse's exit.
        "from stook.service.cli import main\n"
        "try:\n    main(['--help'])\nexcept SystemExit:\n    pass",
    ],
)
def test_importing_the_service_stays_cheap(code: str) -> None:
    assert modules_after(code).isdisjoint({"aiohttp", "polars", "tenacity"})


def test_the_api_layer_imports_its_http_stack_but_no_frames() -> None:
    # The HTTP client's own dependencies come with it, as httpx's do; frames never.
    imported = modules_after("import stook.service.api; stook.service.api.redact_url")
    assert {"aiohttp", "tenacity"} <= imported
    assert imported.isdisjoint({"polars", "numpy"})


def test_opening_a_client_imports_aiohttp() -> None:
    imported = modules_after(
        "import asyncio\nfrom stook.service import ApiClient\n"
        "async def main():\n"
        "    async with ApiClient('http://127.0.0.1:9', 'token'):\n"
        "        pass\n"
        "asyncio.run(main())"
    )
    assert "aiohttp" in imported
    assert "tenacity" in imported  # every request's attempts run through it
