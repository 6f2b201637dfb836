"""The modes: test, batch and report mode, and the settings and inputs they run on.

On top of the fetch layer (it imports `stook.service.fetch` and `stook.service.api`, never
the CLI): stook.toml (`parse`, `load`), the platform's inputs folder (`detect`), each
mode's run, the configured client of a run (`open_api`) and what its traffic was.
"""

from __future__ import annotations

# typing.TYPE_CHECKING without importing typing (see cli/_main.py). Names are imported on
# first use (see stook.service._lazy): a local batch run does not import the sharded
# engines' machinery, nor the fetch library.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from stook.service.modes._batch import BatchMode, BatchResult, run_batch
    from stook.service.modes._config import ConfigError, FetchSettings, StookConfig, load, parse
    from stook.service.modes._engine_config import EngineSettings
    from stook.service.modes._engine_step import engine_for, fetch_step_for
    from stook.service.modes._event_loop import event_loop_factory, run_on_event_loop
    from stook.service.modes._inputs import (
        ApiAccess,
        BatchInputs,
        InputsError,
        ReportInputs,
        TestInputs,
        detect,
    )
    from stook.service.modes._library import fetch_batch, fetch_batch_frame, fetch_report
    from stook.service.modes._open_api import Traffic, open_api
    from stook.service.modes._outputs import OutputsError, check_outputs_folder
    from stook.service.modes._pipeline import (
        OUTPUT_NAME,
        MissingJobsError,
        Mode,
        RunResult,
        run_pipeline,
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
    from stook.service.modes._report import ReportMode, ReportResult, run_report
    from stook.service.modes._test_mode import UserFunctionError, run_test_mode
else:
    from stook.service._lazy import lazy_exports

    __getattr__, __dir__ = lazy_exports(
        __name__,
        {
            "BatchMode": "stook.service.modes._batch",
            "BatchResult": "stook.service.modes._batch",
            "run_batch": "stook.service.modes._batch",
            "ConfigError": "stook.service.modes._config",
            "FetchSettings": "stook.service.modes._config",
            "StookConfig": "stook.service.modes._config",
            "load": "stook.service.modes._config",
            "parse": "stook.service.modes._config",
            "engine_for": "stook.service.modes._engine_step",
            "fetch_step_for": "stook.service.modes._engine_step",
            "EngineSettings": "stook.service.modes._engine_config",
            "event_loop_factory": "stook.service.modes._event_loop",
            "run_on_event_loop": "stook.service.modes._event_loop",
            "ApiAccess": "stook.service.modes._inputs",
            "BatchInputs": "stook.service.modes._inputs",
            "InputsError": "stook.service.modes._inputs",
            "ReportInputs": "stook.service.modes._inputs",
            "TestInputs": "stook.service.modes._inputs",
            "detect": "stook.service.modes._inputs",
            "fetch_batch": "stook.service.modes._library",
            "fetch_batch_frame": "stook.service.modes._library",
            "fetch_report": "stook.service.modes._library",
            "Traffic": "stook.service.modes._open_api",
            "open_api": "stook.service.modes._open_api",
            "OutputsError": "stook.service.modes._outputs",
            "check_outputs_folder": "stook.service.modes._outputs",
            "OUTPUT_NAME": "stook.service.modes._pipeline",
            "MissingJobsError": "stook.service.modes._pipeline",
            "Mode": "stook.service.modes._pipeline",
            "RunResult": "stook.service.modes._pipeline",
            "run_pipeline": "stook.service.modes._pipeline",
            "LogProgress": "stook.service.modes._progress",
            "NoProgress": "stook.service.modes._progress",
            "Progress": "stook.service.modes._progress",
            "Snapshot": "stook.service.modes._progress",
            "Tally": "stook.service.modes._progress",
            "TerminalProgress": "stook.service.modes._progress",
            "for_stream": "stook.service.modes._progress",
            "human_bytes": "stook.service.modes._progress",
            "ReportMode": "stook.service.modes._report",
            "ReportResult": "stook.service.modes._report",
            "run_report": "stook.service.modes._report",
            "UserFunctionError": "stook.service.modes._test_mode",
            "run_test_mode": "stook.service.modes._test_mode",
        },
    )

__all__ = [
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
]
