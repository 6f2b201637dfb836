"""Report mode: fold a report's batches into the report aggregations and write the output."""

from __future__ import annotations

import asyncio
import difflib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import structlog

from stook.sdk import MetricStatus, MetricsWriter
from stook.sdk.aggregations import (
    Aggregation,
    BatchRecord,
    Needs,
    default_report_aggregations,
)
from stook.service.api import RetryPolicy
from stook.service.fetch import ReportFetcher, ReportOutcome, fetch_deadline
from stook.service.modes._batch import OUTPUT_NAME, write_missing_jobs
from stook.service.modes._config import ConfigError, StookConfig
from stook.service.modes._inputs import ReportInputs
from stook.service.modes._open_api import HasTraffic, Traffic, open_api
from stook.service.modes._progress import NoProgress, Progress

log = structlog.get_logger("stook.report")


@dataclass(frozen=True, slots=True)
class ReportResult(HasTraffic):
    output: Path
    outcome: ReportOutcome
    metrics_written: list[str]
    status: MetricStatus
    regressions: str
    traffic: Traffic


def report_aggregations_for(config: StookConfig, project_id: str) -> list[Aggregation[Any]]:
    settings = config.report
    defaults: list[Aggregation[Any]] = []
    if settings.defaults:
        defaults = default_report_aggregations(
            project_id=project_id,
            top_n=settings.top_n,
            regression_window=settings.regression_window,
            regression_threshold=settings.regression_threshold,
            job_metrics=settings.job_metrics,
        )
    return defaults + config.report_aggregations()


def _check_job_metric_names(config: StookConfig, outcome: ReportOutcome) -> None:
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
) -> ReportResult:
    started = asyncio.get_running_loop().time()
    aggregations = report_aggregations_for(config, str(inputs.access.project_id))
    needs = Needs()
    for aggregation in aggregations:
        needs = needs | aggregation.needs()
    settings = config.fetch
    folded = 0

    def fold(record: BatchRecord) -> None:
        nonlocal folded
        folded += 1
        for aggregation in aggregations:
            aggregation.update(record)

    async with open_api(inputs.access, settings, retry) as api:
        shown = progress or NoProgress()

        def report(o: ReportOutcome) -> None:
            traffic = Traffic.of(api)
            shown.update(
                done=o.jobs, listed=o.jobs, requests=traffic.requests, retries=traffic.retries
            )

        fetcher = ReportFetcher(
            api,
            inputs.access.project_id,
            inputs.report_id,
            needs,
            workers=settings.concurrency,
            on_progress=report,
        )

        def how_far() -> str:
            return f"{folded:,} of {fetcher.outcome.batches:,} batches"

        try:
            async with fetch_deadline(settings.deadline, started=started, progress=how_far):
                outcome = await fetcher.run(fold)
        finally:
            shown.close()
        traffic = Traffic.of(api)

    _check_job_metric_names(config, outcome)
    writer = MetricsWriter(inputs.report_id, deterministic=True)
    write_missing_jobs(writer, outcome.missing, outcome.jobs, allow_missing_jobs)
    _write_summary(writer, outcome)
    for aggregation in aggregations:
        aggregation.finish(writer)
    output = writer.write(outputs_dir / OUTPUT_NAME)
    regressions = next(
        (
            m.proto.metric_values.text_metric_values.text
            for m in writer.metrics
            if m.name == "Regressions"
        ),
        "",
    )
    return ReportResult(
        output=output,
        outcome=outcome,
        metrics_written=[m.name for m in writer.metrics],
        status=writer.status,
        regressions=regressions,
        traffic=traffic,
    )


def _write_summary(writer: MetricsWriter, outcome: ReportOutcome) -> None:
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
