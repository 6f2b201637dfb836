"""The modes: test, batch and report mode, and the settings and inputs they run on.

On top of the fetch layer (it imports `stook.service.fetch` and `stook.service.api`, never
the CLI). What other layers and users need, and nothing else:

- settings: `parse`, `load` (stook.toml), `StookConfig`, `FetchSettings`, `EngineSettings`,
  `engine_for` (the `--engine` override);
- inputs and outputs: `detect` (the platform's inputs folder) with `TestInputs`,
  `BatchInputs`, `ReportInputs`, `ApiAccess`; `check_outputs_folder`, `OUTPUT_NAME`;
- the runs: `run_test_mode`, `run_batch`, `run_report` (their `RunResult`, `BatchResult`,
  `ReportResult`, with the run's `Traffic`), `batch_aggregations`, `report_aggregations`;
- the library: `fetch_batch`, `fetch_batch_frame`, `fetch_report`;
- a run's client as the probe opens it: `open_api` (the pipeline's, modes/_pipeline.py);
- the process around a run: `configure_logging`, `event_loop_factory`,
  `run_on_event_loop`, and the progress shown (`Progress`, `for_stream`;
  `RecordingProgress`, which keeps the last for the CLI's line; `human_bytes`);
- the errors (their tree in modes/_errors.py): `ConfigError`, `InputsError`,
  `OutputsError`, `MissingJobsError`, `UserFunctionError`.
"""

from stook.service.modes._batch import BatchResult, batch_aggregations, run_batch
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
    Progress,
    RecordingProgress,
    for_stream,
    human_bytes,
)
from stook.service.modes._report import ReportResult, report_aggregations, run_report
from stook.service.modes._test_mode import run_test_mode

__all__ = [
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
]
