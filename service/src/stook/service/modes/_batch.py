"""Batch mode: every job of one batch, folded into the batch aggregations, written once."""

from __future__ import annotations

import asyncio
import dataclasses
import difflib
import uuid
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from stook.sdk import MetricStatus, MetricsWriter
from stook.sdk.aggregations import (
    BatchAggregation,
    BatchSummaryWriter,
    Needs,
    default_batch_aggregations,
)
from stook.service.api import ApiClient, RetryPolicy
from stook.service.fetch import BatchFetcher, FetchOutcome
from stook.service.modes._baseline import ComparedFetcher
from stook.service.modes._config import EngineSettings, StookConfig
from stook.service.modes._config_metrics import ConfigMetrics, JobRows
from stook.service.modes._errors import ConfigError
from stook.service.modes._inputs import BatchInputs
from stook.service.modes._pipeline import (
    FetchRun,
    RunResult,
    fold_here,
    needs_of,
    write_missing_jobs,
    write_output,
)
from stook.service.modes._progress import FetchProgress, NoProgress, Progress

if TYPE_CHECKING:
    from stook.sdk.aggregations.baseline import BaselineComparison

BatchResult = RunResult[FetchOutcome]


@dataclass(slots=True)
class BatchAggregations:
    """A batch run's aggregations: the defaults, the config's, and, when configured, the
    baseline comparison and the batch's summary (both among `all` too)."""

    all: list[BatchAggregation] = field(default_factory=list)
    comparison: BaselineComparison | None = None
    summary: BatchSummaryWriter | None = None


def batch_aggregations(config: StookConfig) -> BatchAggregations:
    found = BatchAggregations(default_batch_aggregations() if config.batch_defaults else [])
    found.all += config.batch_aggregations()
    if config.baseline is not None:
        found.comparison = config.baseline.comparison()
        found.all.append(found.comparison)
    if config.summary:
        found.summary = BatchSummaryWriter()  # for later reports ([output] summary)
        found.all.append(found.summary)
    return found


async def run_batch(
    inputs: BatchInputs,
    config: StookConfig,
    outputs_dir: Path,
    *,
    allow_missing_jobs: float = 0.0,
    retry: RetryPolicy | None = None,
    progress: Progress | None = None,
    engine: EngineSettings | None = None,
) -> BatchResult:
    """Fetch every job of the batch, fold it into the aggregations, write the output.

    `engine` is where the fetch and fold runs (default: the config's `[engine]`)."""
    started = asyncio.get_running_loop().time()
    aggregations = batch_aggregations(config)
    # [metrics_config]: its config loaded and checked now, before the first request.
    config_metrics = ConfigMetrics.load(config, "batch")
    if config_metrics is not None and not config_metrics.wanted:
        config_metrics = None  # no batch metrics: no emissions log is downloaded
    needs = needs_of(aggregations.all)
    run = FetchRun(
        kind="batch",
        output_id=inputs.batch_id,
        aggregations=aggregations.all,
        needs=needs,
        access=inputs.access,
        settings=config.fetch,
        retry=retry,
        progress=progress or NoProgress(),
        progress_of=batch_progress,
        how_far=lambda outcome, _folded: batch_progress(outcome).of_total(),
        started=started,
        check=_FirstJobsNames(needs, config.source),
    )
    engine = engine or config.engine
    rows: JobRows | None
    if engine.kind == "local":
        fetch = _LocalFetch(inputs, config, needs, aggregations.comparison, config_metrics)
        run = dataclasses.replace(
            run, then=_batch_set_chooser(config_metrics, lambda: fetch.rows, inputs.batch_id)
        )
        try:
            outcome, traffic = await fold_here(run, fetch.fetcher)
        finally:
            await fetch.aclose()
        rows = fetch.rows
    else:
        # The sharded engine (worker processes or Ray) comes with the runs that use it.
        from stook.service.modes._engine import BatchPlan, fold_sharded

        plan = BatchPlan(inputs, config, aggregations.comparison, config_metrics)
        run = dataclasses.replace(
            run, then=_batch_set_chooser(config_metrics, lambda: plan.rows, inputs.batch_id)
        )
        outcome, traffic = await fold_sharded(run, plan, engine, config.file)
        rows = plan.rows

    check_names(needs, outcome, config.source)
    writer = MetricsWriter(inputs.batch_id, deterministic=True)
    write_missing_jobs(writer, outcome.missing, outcome.jobs_listed, allow_missing_jobs)
    if aggregations.summary is not None and outcome.missing:
        # A summary without some jobs would make reports wrong; they list this batch.
        aggregations.summary.skip(f"{len(outcome.missing)} jobs' metrics could not be read")
    if outcome.jobs_listed == 0:
        writer.text(
            "Batch summary",
            "The batch has no jobs, so there is nothing to aggregate.",
            status=MetricStatus.NOT_APPLICABLE,
        )
        writer.override_status(MetricStatus.NOT_APPLICABLE)
    if config_metrics is not None:
        config_metrics.write(rows, writer)
    output = write_output(writer, aggregations.all, outputs_dir)
    return RunResult(
        kind="batch",
        output=output,
        outcome=outcome,
        metrics_written=[m.name for m in writer.metrics],
        status=writer.status,
        traffic=traffic,
        counts={"jobs": outcome.jobs_listed, "jobs_missing": len(outcome.missing)},
        seconds=asyncio.get_running_loop().time() - started,
    )


def _batch_set_chooser(
    config_metrics: ConfigMetrics | None,
    rows_of: Callable[[], JobRows | None],
    batch_id: uuid.UUID,
) -> Callable[[ApiClient, FetchOutcome], Awaitable[None]] | None:
    """What the run does once its fetch is done, on its client: with config metrics and
    no `[metrics_config] metrics_set`, take the batch's own set (ConfigMetrics)."""
    if config_metrics is None:
        return None

    async def choose(_api: ApiClient, _outcome: FetchOutcome) -> None:
        rows = rows_of()
        if config_metrics is not None and rows is not None:
            await config_metrics.choose_batch_set(rows, batch_id)

    return choose


class _LocalFetch:
    """The batch's fetcher on the run's client, with the baseline's beside it when there is
    a comparison; with config-defined metrics, the jobs' emissions logs (`rows`) too."""

    def __init__(
        self,
        inputs: BatchInputs,
        config: StookConfig,
        needs: Needs,
        comparison: BaselineComparison | None,
        config_metrics: ConfigMetrics | None,
    ) -> None:
        self._inputs, self._config, self._needs = inputs, config, needs
        self._comparison, self._config_metrics = comparison, config_metrics
        self.rows: JobRows | None = None

    def fetcher(
        self, api: ApiClient, on_progress: Callable[[FetchOutcome], None]
    ) -> BatchFetcher | ComparedFetcher:
        project_id, batch_id = self._inputs.access.project_id, self._inputs.batch_id
        if self._config_metrics is not None:
            self.rows = self._config_metrics.rows(api, project_id)
        on_emissions = None if self.rows is None else self.rows.add
        comparison, baseline = self._comparison, self._config.baseline
        if comparison is not None and baseline is not None:
            return ComparedFetcher(
                api,
                project_id,
                batch_id,
                self._needs,
                comparison,
                baseline,
                on_progress=on_progress,
                on_emissions=on_emissions,
            )
        return BatchFetcher(
            api,
            project_id,
            batch_id,
            self._needs,
            on_progress=on_progress,
            on_emissions=on_emissions,
        )

    async def aclose(self) -> None:
        """The rows still waiting added in order, their lookups stopped (fetch or not)."""
        if self.rows is not None:
            await self.rows.aclose()


def batch_progress(outcome: FetchOutcome) -> FetchProgress:
    """Jobs done, listed and in all so far, for the progress display."""
    return FetchProgress(
        jobs_done=outcome.jobs_done + len(outcome.missing),
        jobs_listed=outcome.jobs_listed,
        jobs_total=outcome.jobs_total,
    )


#: How many jobs with metrics the early name check waits for (`_FirstJobsNames`).
FIRST_JOBS = 100


class _FirstJobsNames:
    """A misspelt name found while the batch is fetched, not after it: once the first
    `FIRST_JOBS` jobs with metrics are listed, a name the config wants that none of them
    has, and that is close to one they have, ends the run with its suggestion. (A name
    with no close match, or a rare one, is checked once the whole batch is in.)"""

    def __init__(self, needs: Needs, source: str) -> None:
        self._needs, self._source = needs, source
        self._checked = False

    def __call__(self, outcome: FetchOutcome) -> None:
        if self._checked or outcome.jobs_with_metrics < FIRST_JOBS:
            return
        self._checked = True
        check_names(self._needs, outcome, self._source, suggested_only=True)


def check_names(
    needs: Needs, outcome: FetchOutcome, source: str, *, suggested_only: bool = False
) -> None:
    """A name in the config that no job has is a typo, not an empty result: say so.

    `suggested_only`: only a name close to one the jobs have (the early check)."""
    if outcome.jobs_with_metrics == 0:
        return  # an empty batch, or one whose jobs all failed, proves nothing about names
    for kind, wanted, seen in (
        ("scalar metric", needs.scalars, outcome.scalar_names),
        ("metrics data", needs.data, outcome.data_names),
        ("job metric", needs.metrics, outcome.metric_names),
    ):
        for name in sorted(wanted - seen):
            close = difflib.get_close_matches(name, sorted(seen), n=1)
            if suggested_only and not close:
                continue
            hint = f"; did you mean {close[0]!r}?" if close else ""
            which = (
                f"none of the first {outcome.jobs_with_metrics:,} jobs"
                if suggested_only
                else "no job in the batch"
            )
            raise ConfigError(f"{source}: {which} has a {kind} named {name!r}{hint}")
