"""stook.service's public surface, pinned as tests/sdk/test_public_api.py pins the SDK's.

``stook.service`` re-exports what a program built on the library needs (clients, retry
policy, limiters, errors, models, fetch cores); each layer's package lists its own public
names. Adding or removing one is a deliberate act: the lists are written out below.
``stook.service``, ``stook.service.api`` and ``stook.service.cli`` import their names on
first use, so importing them stays cheap; that is checked here too.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import subprocess
import sys
from pathlib import Path

import pytest

SERVICE = Path(__file__).resolve().parents[2] / "service" / "src" / "stook" / "service"

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
        "BatchStatus",
        "BodyCap",
        "BodyTooLargeError",
        "Branch",
        "Build",
        "ConcurrencyLimit",
        "ConflatedBatchStatus",
        "ConflatedJobStatus",
        "EventTimestampType",
        "ExecutionStep",
        "ExperienceTag",
        "FixedLimit",
        "HttpTransport",
        "IdLike",
        "IncompleteBodyError",
        "Job",
        "JobEventListing",
        "JobLog",
        "JobStatus",
        "LimitStats",
        "LogType",
        "MetricOwner",
        "MetricsDataStorageType",
        "NestedLimit",
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
        "TransferStats",
        "Transport",
        "TransportError",
        "body_cap_mb",
        "configure_logging",
        "get_logger",
        "redact_event",
        "redact_text",
        "redact_url",
        "register_secret",
    ],
    "stook.service.fetch": [
        "BaselineFound",
        "BatchFetcher",
        "DeadlineReachedError",
        "FetchOutcome",
        "InvalidDataError",
        "MissingJob",
        "ReportFetcher",
        "ReportNotFoundError",
        "ReportOutcome",
        "decode_values",
        "failure_directions",
        "fetch_deadline",
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
        "BatchMode",
        "BatchResult",
        "ConfigError",
        "EngineSettings",
        "FetchSettings",
        "InputsError",
        "LogProgress",
        "MissingJobsError",
        "Mode",
        "NoProgress",
        "OutputsError",
        "Progress",
        "ReportInputs",
        "ReportMode",
        "ReportResult",
        "RunResult",
        "Snapshot",
        "StookConfig",
        "Tally",
        "TerminalProgress",
        "TestInputs",
        "Traffic",
        "UserFunctionError",
        "check_outputs_folder",
        "detect",
        "engine_for",
        "event_loop_factory",
        "fetch_batch",
        "fetch_batch_frame",
        "fetch_report",
        "fetch_step_for",
        "for_stream",
        "human_bytes",
        "load",
        "open_api",
        "parse",
        "run_batch",
        "run_on_event_loop",
        "run_pipeline",
        "run_report",
        "run_test_mode",
    ],
    "stook.service.preview": ["PREVIEW_NAME", "PreviewInput", "render_html", "write_preview"],
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
        "stable_id",
    ],
    "stook.service.cli": ["Voice", "build_parser", "main", "run_cli", "summary_lines"],
}
LAZY = [
    "stook.service",
    "stook.service.api",
    "stook.service.cli",
    "stook.service.fetch",
    "stook.service.modes",
]
PACKAGES = sorted(PUBLIC_API)


def source_of(package: str) -> Path:
    return SERVICE.joinpath(*package.split(".")[2:], "__init__.py")


@pytest.mark.parametrize("package", PACKAGES)
def test_all_is_exactly_the_pinned_list(package: str) -> None:
    assert importlib.import_module(package).__all__ == PUBLIC_API[package]


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_name_resolves(package: str) -> None:
    module = importlib.import_module(package)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == []
    assert set(module.__all__) <= set(dir(module))


@pytest.mark.parametrize("package", sorted(set(PACKAGES) - set(LAZY)))
def test_nothing_public_is_left_out_of_all(package: str) -> None:
    module = importlib.import_module(package)
    public = {
        name
        for name, value in vars(module).items()
        if not name.startswith("_") and not inspect.ismodule(value)
    }
    assert sorted(public) == sorted(module.__all__)


def lazy_tables(package: str) -> tuple[dict[str, str], dict[str, str]]:
    """What a lazy package imports for mypy (TYPE_CHECKING) and what it imports at run
    time (the lazy_exports table): name -> module, each."""
    tree = ast.parse(source_of(package).read_text())
    checked: dict[str, str] = {}
    runtime: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name):
            assert node.test.id == "TYPE_CHECKING"
            for statement in node.body:
                assert isinstance(statement, ast.ImportFrom)
                assert statement.module
                checked.update((alias.name, statement.module) for alias in statement.names)
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id == "lazy_exports"
        ):
            table = node.args[1]
            assert isinstance(table, ast.Dict)
            runtime = {
                ast.literal_eval(k): ast.literal_eval(v)
                for k, v in zip(table.keys, table.values, strict=True)
                if k
            }
    return checked, runtime


@pytest.mark.parametrize("package", LAZY)
def test_a_lazy_package_imports_for_mypy_what_it_imports_at_run_time(package: str) -> None:
    checked, runtime = lazy_tables(package)
    assert checked == runtime
    assert sorted(runtime) == sorted(PUBLIC_API[package])
    # Nothing else is public in the package: only what __getattr__ hands out.
    module = importlib.import_module(package)
    with pytest.raises(AttributeError, match="has no attribute 'NoSuchName'"):
        _ = module.NoSuchName


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
        "import stook.service.api; stook.service.api.redact_url",
        "import stook.service.cli",
        # `stook --help`: the console script's own path, up to argparse's exit.
        "from stook.service.cli import main\n"
        "try:\n    main(['--help'])\nexcept SystemExit:\n    pass",
    ],
)
def test_importing_the_service_stays_cheap(code: str) -> None:
    assert modules_after(code).isdisjoint({"aiohttp", "polars", "tenacity"})


def test_using_a_name_imports_its_layer() -> None:
    imported = modules_after("from stook.service import ApiClient")
    assert "aiohttp" in imported
    assert "tenacity" in imported  # every request's attempts run through it
