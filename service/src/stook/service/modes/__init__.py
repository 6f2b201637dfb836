"""The modes: test, batch and report mode, and the settings and inputs they run on.

On top of the fetch layer (it imports `stook.service.fetch` and `stook.service.api`, never
the CLI): stook.toml (`parse`, `load`), the platform's inputs folder (`detect`), each
mode's run, the configured client of a run (`open_api`) and what its traffic was.
"""

from stook.service.modes._batch import BatchAggregations, BatchResult, batch_aggregations, run_batch
from stook.service.modes._config import (
    EngineSettings,
    FetchSettings,
    StookConfig,
    engine_for,
    load,
    parse,
)
from stook.service.modes._errors import (
    ConfigError,
    InputsError,
    MissingJobsError,
    OutputsError,
    UserFunctionError,
)
from stook.service.modes._event_loop import event_loop_factory, run_on_event_loop
from stook.service.modes._inputs import ApiAccess, BatchInputs, ReportInputs, TestInputs, detect
from stook.service.modes._library import fetch_batch, fetch_batch_frame, fetch_report
from stook.service.modes._logging import configure_logging
from stook.service.modes._pipeline import (
    OUTPUT_NAME,
    RunResult,
    Traffic,
    check_outputs_folder,
    open_api,
)
from stook.service.modes._progress import (
    LogProgress,
    NoProgress,
    Progress,
    Snapshot,
    Tally,
    TerminalProgress,
    for_stream,
    human_bytes,
)
from stook.service.modes._report import ReportResult, report_aggregations, run_report
from stook.service.modes._test_mode import run_test_mode

__all__ = [
    "OUTPUT_NAME",
    "ApiAccess",
    "BatchAggregations",
    "BatchInputs",
    "BatchResult",
    "ConfigError",
    "EngineSettings",
    "FetchSettings",
    "InputsError",
    "LogProgress",
    "MissingJobsError",
    "NoProgress",
    "OutputsError",
    "Progress",
    "ReportInputs",
    "ReportResult",
    "RunResult",
    "Snapshot",
    "StookConfig",
    "Tally",
    "TerminalProgress",
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
]
