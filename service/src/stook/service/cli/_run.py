"""`stook run`: detect the mode from the inputs folder, run it, map failures to exit codes.

Exit codes (also in docs/cli.md):
  0  metrics.binproto written
  1  an unexpected error, or the user's own test-metrics function raised
  2  bad usage, config or inputs (malformed JSON, missing key, non-UUID ID, bad TOML,
     a misspelt config file name), or an outputs folder that cannot be written (checked
     before the first request); a metric or data name in the config that no job has
     (a close one after the first 100 jobs, modes/_batch.py; any other after the batch)
  3  the API or storage failed for [fetch] retry_for or asked to wait longer than
     stook waits, refused the token, too many jobs stayed unavailable, or the
     [fetch] deadline was reached; an answer over its cap; a listing that does not end
  4  invalid metrics data: a downloaded item could not be decoded, or the output
     would not validate
  5  the output could not be written (disk full, file-size limit, I/O error)
  130, 143  interrupted by SIGINT or SIGTERM (stook.service.cli._signals)

Whatever the failure, metrics.binproto is written atomically or not at all.
"""

from __future__ import annotations

import contextlib
import enum
import os
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import structlog

from stook.sdk import (
    InvalidMetricsError,
    MetricStatus,
    OutputWriteError,
    ReadError,
    WriterError,
    remove_stale_temp_files,
)
from stook.service.api import ApiError, AuthError
from stook.service.cli._usage import UsageError
from stook.service.fetch import FetchError
from stook.service.modes import (
    OUTPUT_NAME,
    BatchInputs,
    ConfigError,
    EngineSettings,
    InputsError,
    OutputsError,
    Progress,
    ReportInputs,
    RunResult,
    StookConfig,
    TestInputs,
    UserFunctionError,
    check_outputs_folder,
    detect,
    engine_for,
    for_stream,
    human_bytes,
    load,
    run_batch,
    run_report,
    run_test_mode,
)

log = structlog.get_logger("stook.run")

DEFAULT_INPUTS = Path("/tmp/resim/inputs")
DEFAULT_OUTPUTS = Path("/tmp/resim/outputs")
DEFAULT_CONFIG_NAME = "stook.toml"


class ExitCode(enum.IntEnum):
    OK = 0
    UNEXPECTED = 1
    USAGE = 2
    API = 3
    INVALID_DATA = 4
    OUTPUT = 5


@dataclass(frozen=True, slots=True)
class RunOptions:
    inputs: Path
    outputs: Path
    config: Path | None
    allow_missing_jobs: float = 0.0
    project_id: uuid.UUID | None = None
    preview: bool = False
    engine: str | None = None  # --engine: replaces [engine] kind


def resolve_options(
    *,
    inputs: str | None,
    outputs: str | None,
    config: str | None,
    allow_missing_jobs: float | None,
    project_id: str | None,
    preview: bool = False,
    cwd: Path | None = None,
    engine: str | None = None,
) -> RunOptions:
    """Flags first, then STOOK_* environment variables, then the platform's defaults."""
    env = os.environ
    config_path = config or env.get("STOOK_CONFIG")
    if config_path is None:
        local = (cwd or Path.cwd()) / DEFAULT_CONFIG_NAME
        config_path = str(local) if local.is_file() else None
    share = allow_missing_jobs
    if share is None and env.get("STOOK_ALLOW_MISSING_JOBS"):
        try:
            share = float(env["STOOK_ALLOW_MISSING_JOBS"])
        except ValueError:
            raise UsageError("STOOK_ALLOW_MISSING_JOBS must be a number from 0 to 1") from None
    share = 0.0 if share is None else share
    if not 0.0 <= share <= 1.0:
        raise UsageError(f"--allow-missing-jobs must be a fraction from 0 to 1, got {share:g}")
    project_text = project_id or env.get("STOOK_PROJECT_ID")
    project = None
    if project_text:
        try:
            project = uuid.UUID(project_text)
        except ValueError:
            raise UsageError(f"project ID {project_text!r} is not a UUID") from None
    return RunOptions(
        inputs=Path(inputs or env.get("STOOK_INPUTS") or DEFAULT_INPUTS),
        outputs=Path(outputs or env.get("STOOK_OUTPUTS") or DEFAULT_OUTPUTS),
        config=Path(config_path) if config_path else None,
        allow_missing_jobs=share,
        project_id=project,
        preview=preview,
        engine=engine,
    )


@dataclass(frozen=True, slots=True)
class Written:
    """What a run wrote: its result, and the preview beside the output when it made one.

    The run's last words: `line` for a person at a terminal, `log` (the run's summary
    event, then the preview's) for the platform's log view and JSON logs.
    """

    result: RunResult[Any]
    preview: Path | None = None

    def line(self) -> str:
        """``wrote out/metrics.binproto: 18 metrics from 120 jobs in 2.4 s, metrics status
        FAIL_BLOCK (the run itself succeeded)``: the status is the metrics' verdict, which
        a run that wrote them passes on and does not share."""
        result = self.result
        written = str(result.output)
        if self.preview is not None:
            written += f" and {self.preview}"
        line = f"wrote {written}: {_count(len(result.metrics_written), 'metric')}"
        counts = result.counts
        if "jobs" in counts:
            line += f" from {_count(counts['jobs'], 'job')}"
            if "batches" in counts:
                line += f" of {_count(counts['batches'], 'batch', 'batches')}"
            if counts.get("jobs_missing"):
                line += f" ({counts['jobs_missing']:,} missing)"
            line += f" in {result.seconds:.1f} s"
        line += f", metrics status {result.status.name}"
        if result.status is not MetricStatus.PASSED:
            line += " (the run itself succeeded)"
        return line

    def log(self) -> None:
        result, traffic = self.result, self.result.traffic
        fields: dict[str, Any] = {}
        if result.kind != "test":  # test mode makes no requests
            fields = {
                "requests": traffic.requests,
                "retries": traffic.retries,
                "received": human_bytes(traffic.bytes_received),
                "seconds": round(result.seconds, 2),
            }
        log.info(
            f"{result.kind} metrics written",
            output=str(result.output),
            status=result.status.name,
            **result.counts,
            metrics=len(result.metrics_written),
            **fields,
        )
        if self.preview is not None:
            log.info("preview written", preview=str(self.preview))


def _count(count: int, noun: str, nouns: str = "") -> str:
    """``1 metric``, ``18 metrics``, ``1,204 jobs``."""
    return f"{count:,} {noun if count == 1 else nouns or noun + 's'}"


async def run(
    options: RunOptions,
    *,
    progress: Progress | None = None,
    say: Callable[[Written], None] = Written.log,
) -> Path:
    """Run the detected mode and return the output's path; raises the typed errors that
    `exit_code_for` maps.

    `progress` is shown how far the fetch got (default: a bar on a terminal, a progress
    event every 10 s off one); `say` tells what was written (default: the summary event;
    the CLI's `Voice.finished` says it in a line on a terminal).
    """
    config: StookConfig = load(options.config)
    engine = engine_for(config, options.engine)
    mode = detect(options.inputs, project_id=options.project_id)
    created = _missing_folders(options.outputs)
    check_outputs_folder(options.outputs)  # before the first request, not after the fetch
    try:
        result = await _run_mode(mode, config, engine, options, progress)
        written = Written(result, _preview(result.output, options, config))
    except BaseException:
        # A failed run leaves nothing behind, not even the empty folder it made.
        for folder in created:
            with contextlib.suppress(OSError):  # not empty: something else wrote there
                folder.rmdir()
        raise
    say(written)
    return written.result.output


def _missing_folders(folder: Path) -> list[Path]:
    """`folder` and those of its parents that do not exist yet, deepest first."""
    missing = []
    while not folder.exists() and folder != folder.parent:
        missing.append(folder)
        folder = folder.parent
    return missing


async def _run_mode(
    mode: BatchInputs | ReportInputs | TestInputs,
    config: StookConfig,
    engine: EngineSettings,
    options: RunOptions,
    progress: Progress | None,
) -> RunResult[Any]:
    output = options.outputs / OUTPUT_NAME
    _remove_stale_temp_files(output)
    if isinstance(mode, TestInputs):
        log.info("test mode", config=config.source)
        return await run_test_mode(mode, config, output)
    progress = progress or for_stream(label="jobs")
    if isinstance(mode, BatchInputs):
        log.info("batch mode", batch_id=str(mode.batch_id), config=config.source)
        return await run_batch(
            mode,
            config,
            options.outputs,
            allow_missing_jobs=options.allow_missing_jobs,
            progress=progress,
            engine=engine,
        )
    log.info("report mode", report_id=str(mode.report_id), config=config.source)
    return await run_report(
        mode,
        config,
        options.outputs,
        allow_missing_jobs=options.allow_missing_jobs,
        progress=progress,
        engine=engine,
    )


def _preview(output: Path, options: RunOptions, config: StookConfig) -> Path | None:
    """metrics.html beside the output when asked for (--preview, [output] preview)."""
    if not (options.preview or config.preview):
        return None
    from stook.service.preview import PREVIEW_NAME, write_preview  # only the runs that preview

    return write_preview([output], output.with_name(PREVIEW_NAME))


def _remove_stale_temp_files(output: Path) -> None:
    """Temporary files that an earlier, killed run's write left beside the output."""
    removed = remove_stale_temp_files(output)
    if removed:
        log.info("removed stale temporary files", files=[str(p) for p in removed])


def explain(error: BaseException) -> str:
    """The one line printed for a failure, with a hint where the cause is likely local."""
    if isinstance(error, AuthError):
        return f"the API refused the token (authToken in the inputs config): {error}"
    return str(error)


def exit_code_for(error: BaseException) -> ExitCode:
    """The documented exit code of an expected failure; UNEXPECTED for anything else."""
    from stook.service.metrics_config import (
        EmissionsError,
        MetricsConfigError,
        QueryError,
        TemplateError,
    )

    if isinstance(error, UsageError | ConfigError | InputsError | OutputsError):
        return ExitCode.USAGE
    if isinstance(error, MetricsConfigError):
        return ExitCode.USAGE
    if isinstance(error, EmissionsError | QueryError | TemplateError):
        return ExitCode.INVALID_DATA
    if isinstance(error, ApiError | FetchError):
        return ExitCode.API
    if isinstance(error, ReadError | InvalidMetricsError):
        return ExitCode.INVALID_DATA
    if isinstance(error, OutputWriteError):
        return ExitCode.OUTPUT
    if isinstance(error, WriterError):
        # A config that asks for two metrics of one name, or impossible bounds.
        return ExitCode.USAGE
    if isinstance(error, UserFunctionError):
        return ExitCode.UNEXPECTED
    return ExitCode.UNEXPECTED
