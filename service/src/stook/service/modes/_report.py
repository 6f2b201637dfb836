"""Report mode: a report's batches, folded into the report aggregations, written once."""

from __future__ import annotations

import asyncio
import difflib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import structlog

from stook.sdk import MetricStatus, MetricsWriter
from stook.sdk.aggregations import Aggregation
from stook.service.api import ApiClient, RetryPolicy
from stook.service.fetch import ReportFetcher, ReportOutcome
from stook.service.modes._config import EngineSettings, StookConfig
from stook.service.modes._config_metrics import ConfigMetrics, JobRows
from stook.service.modes._errors import ConfigError
from stook.service.modes._inputs import ReportInputs
from stook.service.modes._pipeline import (
    FetchRun,
    RunResult,
    fold_here,
    needs_of,
    write_missing_jobs,
    write_output,
)
from stook.service.modes._progress import FetchProgress, NoProgress, Progress

log = structlog.get_logger("stook.run")

if TYPE_CHECKING:
    from stook.sdk.aggregations.report import RegressionSummary


@dataclass(frozen=True, slots=True)
class ReportResult(RunResult[ReportOutcome]):
    """A report run's result, with what its regression check found (None without one)."""

    regressions: RegressionSummary | None = None


def report_aggregations(config: StookConfig, project_id: str) -> list[Aggregation[Any]]:
    # The report aggregations' modules are imported by the report run that builds them:
    # `stook.service.modes` exports both modes, and a batch run has no use for them.
    from stook.sdk.aggregations.report import default_report_aggregations

    settings = config.report
    defaults: list[Aggregation[Any]] = []
    if settings.defaults:
        defaults = default_report_aggregations(
            project_id=project_id,
            top_n=settings.top_n,
            regression_window=settings.regression_window,
            regression_threshold=settings.regression_threshold,
            job_metrics=settings.job_metrics,
            change_points=settings.change_points,
            change_penalty=settings.change_penalty,
            unstable_experiences=settings.unstable_experiences,
        )
    return defaults + config.report_aggregations()


def check_job_metric_names(config: StookConfig, outcome: ReportOutcome) -> None:
    wanted = config.report.job_metrics
    if not wanted or outcome.jobs_with_metrics == 0:
        return
    for name in wanted:
        if name not in outcome.job_scalar_names:
            close = difflib.get_close_matches(name, sorted(outcome.job_scalar_names), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ConfigError(
                f"{config.source}: [report] job_metrics names {name!r}, which no job in the "
                f"report's batches has{hint}"
            )


async def run_report(
    inputs: ReportInputs,
    config: StookConfig,
    outputs_dir: Path,
    *,
    allow_missing_jobs: float = 0.0,
    retry: RetryPolicy | None = None,
    progress: Progress | None = None,
    engine: EngineSettings | None = None,
) -> ReportResult:
    """Fetch the report's batches, fold them into the aggregations, write the output.

    `engine` is where the fetch and fold runs (default: the config's `[engine]`)."""
    # The report aggregations come with the report run (see report_aggregations).
    from stook.sdk.aggregations.report import ScalarLines

    started = asyncio.get_running_loop().time()
    aggregations = report_aggregations(config, str(inputs.access.project_id))
    # [metrics_config]: its config loaded and checked now, before the first request.
    config_metrics = ConfigMetrics.load(config, "dashboard")
    dashboard = None
    if config_metrics is not None and config_metrics.wanted:
        dashboard = _DashboardRows(config_metrics, inputs)
    needs = needs_of(aggregations)
    run = FetchRun(
        kind="report",
        output_id=inputs.report_id,
        aggregations=aggregations,
        needs=needs,
        access=inputs.access,
        settings=config.fetch,
        retry=retry,
        progress=progress or NoProgress(),
        progress_of=report_progress,
        how_far=lambda outcome, folded: f"{folded:,} of {outcome.batches:,} batches",
        started=started,
        then=None if dashboard is None else dashboard.fetch,
    )
    engine = engine or config.engine
    if engine.kind == "local":

        def fetcher_for(
            api: ApiClient, on_progress: Callable[[ReportOutcome], None]
        ) -> ReportFetcher:
            return ReportFetcher(
                api,
                inputs.access.project_id,
                inputs.report_id,
                needs,
                on_progress=on_progress,
                use_summaries=config.report.use_summaries,
            )

        outcome, traffic = await fold_here(run, fetcher_for)
    else:
        # The sharded engine (worker processes or Ray) comes with the runs that use it.
        from stook.service.modes._engine import ReportPlan, fold_sharded

        outcome, traffic = await fold_sharded(run, ReportPlan(inputs, config), engine, config.file)

    check_job_metric_names(config, outcome)
    writer = MetricsWriter(inputs.report_id, deterministic=True)
    write_missing_jobs(writer, outcome.missing, outcome.jobs, allow_missing_jobs)
    write_summary(writer, outcome)
    if config_metrics is not None and dashboard is not None:
        config_metrics.write(dashboard.rows, writer)
    output = write_output(writer, aggregations, outputs_dir)
    lines = [a for a in aggregations if isinstance(a, ScalarLines)]
    return ReportResult(
        kind="report",
        output=output,
        outcome=outcome,
        metrics_written=[m.name for m in writer.metrics],
        status=writer.status,
        traffic=traffic,
        counts={
            "batches": outcome.batches,
            "jobs": outcome.jobs,
            "jobs_missing": len(outcome.missing),
            "batches_summarised": outcome.batches_summarised,
        },
        seconds=asyncio.get_running_loop().time() - started,
        # What the default regression check found, read from the aggregation itself.
        regressions=lines[0].regressions() if lines else None,
    )


class _DashboardRows:
    """The dashboard metrics' rows: every job of the report's batches with its emissions,
    fetched once the report's fetch is done, on its client (modes/_config_metrics.py)."""

    def __init__(self, config_metrics: ConfigMetrics, inputs: ReportInputs):
        self._config_metrics, self._inputs = config_metrics, inputs
        self.rows: JobRows | None = None

    async def fetch(self, api: ApiClient, outcome: ReportOutcome) -> None:
        log.info("config metrics: fetching the report's jobs' emissions logs")
        report = outcome.report
        self.rows = await self._config_metrics.fetch_report_rows(
            api,
            self._inputs.access.project_id,
            outcome.found_batches,
            end=None if report is None else report.end_timestamp,
        )


def report_progress(outcome: ReportOutcome) -> FetchProgress:
    """Jobs and batches done, listed and in all so far, for the progress display."""
    listed = outcome.jobs_total is not None or outcome.batches > 0
    return FetchProgress(
        jobs_done=outcome.jobs_done,
        jobs_listed=outcome.jobs,
        jobs_total=outcome.jobs_total,
        batches_done=outcome.batches_done,
        batches_total=outcome.batches if listed else None,
    )


def write_summary(writer: MetricsWriter, outcome: ReportOutcome) -> None:
    report = outcome.report
    if report is None:  # the fetcher sets it first thing; without it there is no window
        raise RuntimeError("report mode finished without the report")
    window = (
        f"test suite {report.test_suite_id} on branch {report.branch_id}, created between "
        f"{report.start_timestamp:%Y-%m-%d %H:%M} and {report.end_timestamp:%Y-%m-%d %H:%M} UTC"
    )
    if report.respect_revision_boundary:
        window += f", revision {report.test_suite_revision}"
    if outcome.batches == 0:
        writer.text(
            "Report summary",
            f"No batches of {window}: nothing to report.",
            status=MetricStatus.NOT_APPLICABLE,
        )
        writer.override_status(MetricStatus.NOT_APPLICABLE)
        return
    first = outcome.first or report.start_timestamp
    last = outcome.last or report.end_timestamp
    writer.text(
        "Report summary",
        f"{outcome.batches} batches of {window}: {outcome.jobs} jobs, the first batch "
        f"created {first:%Y-%m-%d %H:%M}, the last {last:%Y-%m-%d %H:%M} UTC.",
    )
