"""Batch mode: every job of one batch, folded into the batch aggregations (see _pipeline)."""

from __future__ import annotations

import difflib
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from stook.sdk import MetricStatus
from stook.sdk.aggregations import default_batch_aggregations
from stook.service.api import ApiClient, RetryPolicy
from stook.service.fetch import BatchFetcher, FetchOutcome, MissingJob
from stook.service.modes._config import ConfigError, StookConfig
from stook.service.modes._inputs import BatchInputs
from stook.service.modes._pipeline import RunResult, run_pipeline
from stook.service.modes._progress import Progress, Snapshot

if TYPE_CHECKING:
    from stook.sdk import MetricsWriter

    # The baseline comparison and the summary are imported by the runs that have them.
    from stook.sdk.aggregations import (
        BaselineComparison,
        BatchAggregation,
        BatchSummaryWriter,
        Needs,
    )
    from stook.service.modes._baseline import ComparedFetcher
    from stook.service.modes._config_metrics import ConfigMetricsStep

BatchResult = RunResult[FetchOutcome]


def aggregations_for(config: StookConfig) -> list[BatchAggregation]:
    defaults = default_batch_aggregations() if config.batch_defaults else []
    return defaults + config.batch_aggregations()


def check_names(needs: Needs, outcome: FetchOutcome, source: str) -> None:
    """A name in the config that no job has is a typo, not an empty result: say so."""
    if outcome.jobs_with_metrics == 0:
        return  # an empty batch, or one whose jobs all failed, proves nothing about names
    for kind, wanted, seen in (
        ("scalar metric", needs.scalars, outcome.scalar_names),
        ("metrics data", needs.data, outcome.data_names),
        ("job metric", needs.metrics, outcome.metric_names),
    ):
        for name in sorted(wanted - seen):
            close = difflib.get_close_matches(name, sorted(seen), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ConfigError(f"{source}: no job in the batch has a {kind} named {name!r}{hint}")


@dataclass(slots=True)
class BatchMode:
    """The batch-mode pieces of the pipeline."""

    inputs: BatchInputs
    config: StookConfig
    aggregations: list[BatchAggregation] = field(init=False)
    kind: str = "batch"
    # [batch.baseline]'s comparison, also among the aggregations; None without one.
    comparison: BaselineComparison | None = field(init=False, default=None)
    # The batch's summary for later reports ([output] summary); None when off.
    summary: BatchSummaryWriter | None = field(init=False, default=None)
    # The config-defined batch metrics ([metrics_config]); None without.
    config_metrics: ConfigMetricsStep | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        self.aggregations = aggregations_for(self.config)
        if self.config.baseline is not None:
            self.comparison = self.config.baseline.comparison()
            self.aggregations.append(self.comparison)
        if self.config.summary:
            from stook.sdk.aggregations import BatchSummaryWriter

            self.summary = BatchSummaryWriter()
            self.aggregations.append(self.summary)
        if self.config.metrics_config is not None:
            # Its config loaded and checked now, before the first request.
            from stook.service.modes._config_metrics import config_metrics_step

            self.config_metrics = config_metrics_step(
                self.config, self.inputs.access, batch_id=self.inputs.batch_id
            )

    @property
    def output_id(self) -> uuid.UUID:
        return self.inputs.batch_id

    def fetcher(
        self, api: ApiClient, needs: Needs, on_progress: Callable[[FetchOutcome], None]
    ) -> BatchFetcher | ComparedFetcher:
        if self.comparison is not None and self.config.baseline is not None:
            # The baseline's search and its failure directions: for the runs that have one.
            from stook.service.modes._baseline import ComparedFetcher

            return ComparedFetcher(
                api,
                self.inputs.access.project_id,
                self.inputs.batch_id,
                needs,
                self.comparison,
                self.config.baseline,
                workers=self.config.fetch.concurrency,
                on_progress=on_progress,
            )
        return BatchFetcher(
            api,
            self.inputs.access.project_id,
            self.inputs.batch_id,
            needs,
            workers=self.config.fetch.concurrency,
            on_progress=on_progress,
        )

    def progress(self, outcome: FetchOutcome) -> Snapshot:
        return Snapshot(
            jobs_done=outcome.jobs_done + len(outcome.missing),
            jobs_listed=outcome.jobs_listed,
            jobs_total=outcome.jobs_total,
        )

    def how_far(self, outcome: FetchOutcome, folded: int) -> str:
        return self.progress(outcome).of_total()

    def counts(self, outcome: FetchOutcome) -> dict[str, int]:
        return {"jobs": outcome.jobs_listed, "jobs_missing": len(outcome.missing)}

    def missing(self, outcome: FetchOutcome) -> tuple[list[MissingJob], int]:
        return outcome.missing, outcome.jobs_listed

    def check(self, needs: Needs, outcome: FetchOutcome) -> None:
        check_names(needs, outcome, self.config.source)

    def preface(self, writer: MetricsWriter, outcome: FetchOutcome) -> None:
        if self.summary is not None and outcome.missing:
            # A summary without some jobs would make reports wrong; they list this batch.
            self.summary.skip(f"{len(outcome.missing)} jobs' metrics could not be read")
        if outcome.jobs_listed == 0:
            writer.text(
                "Batch summary",
                "The batch has no jobs, so there is nothing to aggregate.",
                status=MetricStatus.NOT_APPLICABLE,
            )
            writer.override_status(MetricStatus.NOT_APPLICABLE)


async def run_batch(
    inputs: BatchInputs,
    config: StookConfig,
    outputs_dir: Path,
    *,
    allow_missing_jobs: float = 0.0,
    retry: RetryPolicy | None = None,
    progress: Progress | None = None,
) -> BatchResult:
    """Fetch every job of the batch, fold it into the aggregations, write the output."""
    return await run_pipeline(
        BatchMode(inputs, config),
        inputs.access,
        config.fetch,
        outputs_dir,
        allow_missing_jobs=allow_missing_jobs,
        retry=retry,
        progress=progress,
    )
