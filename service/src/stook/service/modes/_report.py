"""Report mode: a report's batches, folded into the report aggregations (see _pipeline)."""

from __future__ import annotations

import dataclasses
import difflib
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import structlog

from stook.sdk import MetricStatus, MetricsWriter
from stook.sdk.aggregations import default_report_aggregations
from stook.service.api import ApiClient, RetryPolicy
from stook.service.fetch import MissingJob, ReportFetcher, ReportOutcome
from stook.service.modes._config import ConfigError, StookConfig
from stook.service.modes._inputs import ReportInputs
from stook.service.modes._pipeline import RunResult, run_pipeline
from stook.service.modes._progress import Progress, Snapshot

if TYPE_CHECKING:
    # The report aggregations are imported by report mode, not by every run.
    from stook.sdk.aggregations import Aggregation, Needs
    from stook.sdk.aggregations.report import RegressionSummary
    from stook.service.modes._config_metrics import ConfigMetricsStep

log = structlog.get_logger("stook.report")


@dataclass(frozen=True, slots=True)
class ReportResult(RunResult[ReportOutcome]):
    """A report run's result, with what its regression check found (None without one)."""

    regressions: RegressionSummary | None = None


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


@dataclass(slots=True)
class ReportMode:
    """The report-mode pieces of the pipeline."""

    inputs: ReportInputs
    config: StookConfig
    aggregations: list[Aggregation[Any]] = field(init=False)
    kind: str = "report"

    # The config-defined dashboard metrics ([metrics_config]); None without.
    config_metrics: ConfigMetricsStep | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        self.aggregations = report_aggregations_for(self.config, str(self.inputs.access.project_id))
        if self.config.metrics_config is not None:
            # Its config loaded and checked now, before the first request.
            from stook.service.modes._config_metrics import config_metrics_step

            self.config_metrics = config_metrics_step(
                self.config, self.inputs.access, report_id=self.inputs.report_id
            )

    @property
    def output_id(self) -> uuid.UUID:
        return self.inputs.report_id

    def fetcher(
        self, api: ApiClient, needs: Needs, on_progress: Callable[[ReportOutcome], None]
    ) -> ReportFetcher:
        return ReportFetcher(
            api,
            self.inputs.access.project_id,
            self.inputs.report_id,
            needs,
            workers=self.config.fetch.concurrency,
            on_progress=on_progress,
            use_summaries=self.config.report.use_summaries,
        )

    def progress(self, outcome: ReportOutcome) -> Snapshot:
        listed = outcome.jobs_total is not None or outcome.batches > 0
        return Snapshot(
            jobs_done=outcome.jobs_done,
            jobs_listed=outcome.jobs,
            jobs_total=outcome.jobs_total,
            batches_done=outcome.batches_done,
            batches_total=outcome.batches if listed else None,
        )

    def how_far(self, outcome: ReportOutcome, folded: int) -> str:
        return f"{folded:,} of {outcome.batches:,} batches"

    def counts(self, outcome: ReportOutcome) -> dict[str, int]:
        return {
            "batches": outcome.batches,
            "jobs": outcome.jobs,
            "jobs_missing": len(outcome.missing),
            "batches_summarised": outcome.batches_summarised,
        }

    def missing(self, outcome: ReportOutcome) -> tuple[list[MissingJob], int]:
        return outcome.missing, outcome.jobs

    def check(self, needs: Needs, outcome: ReportOutcome) -> None:
        check_job_metric_names(self.config, outcome)

    def preface(self, writer: MetricsWriter, outcome: ReportOutcome) -> None:
        write_summary(writer, outcome)

    def regressions(self) -> RegressionSummary | None:
        """What the default regression check found, read from the aggregation itself."""
        from stook.sdk.aggregations.report import ScalarLines

        lines = [a for a in self.aggregations if isinstance(a, ScalarLines)]
        return lines[0].regressions() if lines else None


async def run_report(
    inputs: ReportInputs,
    config: StookConfig,
    outputs_dir: Path,
    *,
    allow_missing_jobs: float = 0.0,
    retry: RetryPolicy | None = None,
    progress: Progress | None = None,
) -> ReportResult:
    """Fetch the report's batches, fold them into the aggregations, write the output."""
    mode = ReportMode(inputs, config)
    result = await run_pipeline(
        mode,
        inputs.access,
        config.fetch,
        outputs_dir,
        allow_missing_jobs=allow_missing_jobs,
        retry=retry,
        progress=progress,
    )
    parts = {f.name: getattr(result, f.name) for f in dataclasses.fields(RunResult)}
    return ReportResult(**parts, regressions=mode.regressions())


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
