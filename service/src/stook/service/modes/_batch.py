"""Batch mode: fetch every job of the batch, fold it into the aggregations, write the output."""

from __future__ import annotations

import asyncio
import difflib
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import structlog

from stook.sdk import MetricStatus, MetricsWriter
from stook.sdk.aggregations import BatchAggregation, JobRecord, Needs, default_batch_aggregations
from stook.service.api import ApiError, RetryPolicy
from stook.service.fetch import BatchFetcher, FetchOutcome, FetchPlan, MissingJob, fetch_deadline
from stook.service.modes._config import ConfigError, StookConfig
from stook.service.modes._inputs import BatchInputs
from stook.service.modes._open_api import HasTraffic, Traffic, open_api
from stook.service.modes._progress import NoProgress, Progress

log = structlog.get_logger("stook.batch")

OUTPUT_NAME = "metrics.binproto"


class MissingJobsError(ApiError):
    """More jobs stayed unavailable than --allow-missing-jobs allows (exit code 3)."""


@dataclass(frozen=True, slots=True)
class BatchResult(HasTraffic):
    output: Path
    outcome: FetchOutcome
    metrics_written: list[str]
    status: MetricStatus
    traffic: Traffic


def aggregations_for(config: StookConfig) -> list[BatchAggregation]:
    defaults = default_batch_aggregations() if config.batch_defaults else []
    return defaults + config.batch_aggregations()


def plan_for(aggregations: Iterable[BatchAggregation]) -> tuple[Needs, FetchPlan]:
    needs = Needs()
    for aggregation in aggregations:
        needs = needs | aggregation.needs()
    return needs, FetchPlan(data=needs.data, scalars=needs.scalars, every_scalar=needs.every_scalar)


def check_names(needs: Needs, outcome: FetchOutcome, source: str) -> None:
    """A name in the config that no job has is a typo, not an empty result: say so."""
    if outcome.jobs_with_metrics == 0:
        return  # an empty batch, or one whose jobs all failed, proves nothing about names
    for kind, wanted, seen in (
        ("scalar metric", needs.scalars, outcome.scalar_names),
        ("metrics data", needs.data, outcome.data_names),
    ):
        for name in sorted(wanted - seen):
            close = difflib.get_close_matches(name, sorted(seen), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ConfigError(f"{source}: no job in the batch has a {kind} named {name!r}{hint}")


async def run_batch(
    inputs: BatchInputs,
    config: StookConfig,
    outputs_dir: Path,
    *,
    allow_missing_jobs: float = 0.0,
    retry: RetryPolicy | None = None,
    progress: Progress | None = None,
) -> BatchResult:
    started = asyncio.get_running_loop().time()
    aggregations = aggregations_for(config)
    needs, plan = plan_for(aggregations)
    settings = config.fetch

    def fold(record: JobRecord) -> None:
        for aggregation in aggregations:
            aggregation.update(record)

    log.info(
        "batch fetch starting",
        batch_id=str(inputs.batch_id),
        concurrency=settings.concurrency,
        data=sorted(plan.data),
    )
    async with open_api(inputs.access, settings, retry) as api:
        shown = progress or NoProgress()

        def report(o: FetchOutcome) -> None:
            traffic = Traffic.of(api)
            shown.update(
                done=o.jobs_done + len(o.missing),
                listed=o.jobs_listed,
                requests=traffic.requests,
                retries=traffic.retries,
            )

        fetcher = BatchFetcher(
            api,
            inputs.access.project_id,
            inputs.batch_id,
            plan,
            workers=settings.concurrency,
            on_progress=report,
        )

        def how_far() -> str:
            o = fetcher.outcome
            return f"{o.jobs_done + len(o.missing):,} of {o.jobs_listed:,} jobs"

        try:
            async with fetch_deadline(settings.deadline, started=started, progress=how_far):
                outcome = await fetcher.run(fold)
        finally:
            shown.close()
        traffic = Traffic.of(api)

    check_names(needs, outcome, config.source)
    writer = MetricsWriter(inputs.batch_id, deterministic=True)
    write_missing_jobs(writer, outcome.missing, outcome.jobs_listed, allow_missing_jobs)
    if outcome.jobs_listed == 0:
        writer.text(
            "Batch summary",
            "The batch has no jobs, so there is nothing to aggregate.",
            status=MetricStatus.NOT_APPLICABLE,
        )
        writer.override_status(MetricStatus.NOT_APPLICABLE)
    for aggregation in aggregations:
        aggregation.finish(writer)
    output = writer.write(outputs_dir / OUTPUT_NAME)
    return BatchResult(
        output=output,
        outcome=outcome,
        metrics_written=[m.name for m in writer.metrics],
        status=writer.status,
        traffic=traffic,
    )


def write_missing_jobs(
    writer: MetricsWriter, missing: list[MissingJob], jobs: int, allowed: float
) -> None:
    """Fail naming the first missing job, or, within the allowed share, say which are missing."""
    if not missing:
        return
    share = len(missing) / max(jobs, 1)
    first = missing[0]
    if share > allowed:
        more = f" and {len(missing) - 1} more" if len(missing) > 1 else ""
        # A summary: each job's reason was said once already, in its "unavailable" warning.
        raise MissingJobsError(
            f"job {first.job_id}{more} could not be fetched (see the warnings above); "
            f"{len(missing)} of {jobs} jobs missing, allowed share {allowed:g}"
        )
    lines = [
        f"- {m.job_id} ({m.experience_name or 'unknown experience'}): {m.reason}" for m in missing
    ]
    writer.text(
        "Missing jobs",
        f"{len(missing)} of {jobs} jobs could not be fetched and are left out "
        "of every batch metric:\n" + "\n".join(lines),
        status=MetricStatus.FAIL_WARN,
    )
