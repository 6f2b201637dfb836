"""What the driver of a sharded run does per mode: list what is split, make the shards, and
add each shard's outcome to the run's.

Batch mode splits the batch's jobs, listed here; report mode the report's batches, found
here. The listing is the run's (`jobs_listed`, the report's window); the shards' outcomes
add what they fetched: jobs done, names seen, jobs missing.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from stook.sdk.aggregations import Aggregation, Needs
from stook.service.api import ApiClient, Batch, Job, Report
from stook.service.fetch import FetchOutcome, ReportFetcher, ReportOutcome
from stook.service.modes._baseline import fetch_baseline, set_directions
from stook.service.modes._batch import BatchMode
from stook.service.modes._pipeline import FetchRun
from stook.service.modes._report import ReportMode
from stook.service.modes._shards import BatchShard, ReportShard

__all__ = ["BatchPlan", "ReportPlan", "plan_for"]


def plan_for(mode: object, kind: str) -> BatchPlan | ReportPlan:
    """The plan of `mode`'s run."""
    if isinstance(mode, BatchMode):
        return BatchPlan(mode)
    if isinstance(mode, ReportMode):
        return ReportPlan(mode)
    raise TypeError(f"no sharded run for {type(mode).__name__}")


@dataclass(slots=True)
class BatchPlan:
    """The batch's jobs are sharded; with `[batch.baseline]` the baseline's jobs are
    fetched here, on the driver, beside the shards: the comparison needs only their
    listed scalars (one request a job), and its candidate side comes from the shards'
    states like every other aggregation's."""

    mode: BatchMode
    outcome: FetchOutcome = None  # type: ignore[assignment]  # set in __post_init__
    _baseline: asyncio.Task[None] | None = None

    def __post_init__(self) -> None:
        self.outcome = FetchOutcome()

    async def listing(self, api: ApiClient, on_progress: Callable[[], None]) -> list[Job]:
        inputs, outcome = self.mode.inputs, self.outcome
        comparison, settings = self.mode.comparison, self.mode.config.baseline
        if comparison is not None and settings is not None:
            self._baseline = asyncio.create_task(
                fetch_baseline(
                    api,
                    inputs.access.project_id,
                    inputs.batch_id,
                    comparison,
                    settings,
                    workers=self.mode.config.fetch.concurrency,
                )
            )

        def total_is(total: int) -> None:
            outcome.jobs_total = total

        jobs = []
        async for job in api.list_jobs(
            inputs.access.project_id, inputs.batch_id, on_total=total_is
        ):
            jobs.append(job)
            outcome.jobs_listed += 1
            on_progress()
        outcome.jobs_total = outcome.jobs_listed
        return jobs

    def shard(
        self, run: FetchRun[Any, Any], index: int, items: list[Job], states: list[Aggregation[Any]]
    ) -> BatchShard:
        return BatchShard(
            index,
            run.access,
            run.settings,
            run.retry,
            run.needs,
            states,
            self.mode.inputs.batch_id,
            items,
        )

    def add(self, part: FetchOutcome | ReportOutcome) -> None:
        if not isinstance(part, FetchOutcome):
            raise TypeError(f"a batch shard's outcome is a FetchOutcome, not {type(part).__name__}")
        outcome = self.outcome
        outcome.jobs_done += part.jobs_done
        outcome.jobs_with_metrics += part.jobs_with_metrics
        outcome.missing.extend(part.missing)
        outcome.scalar_names |= part.scalar_names
        outcome.metric_names |= part.metric_names
        outcome.data_names |= part.data_names
        outcome.unnamed_data += part.unnamed_data

    async def finish(self, api: ApiClient) -> None:
        """Every shard is merged: the baseline's side too, then the comparison's directions."""
        comparison, inputs = self.mode.comparison, self.mode.inputs
        if self._baseline is None or comparison is None:
            return
        await self._baseline
        await set_directions(api, inputs.access.project_id, inputs.batch_id, comparison)

    def abort(self) -> None:
        if self._baseline is not None:
            self._baseline.cancel()

    def complete(self) -> None:
        """Every shard is in (the listing already fixed the job count)."""
        self.outcome.seconds = time.monotonic() - self.outcome.started


@dataclass(slots=True)
class ReportPlan:
    mode: ReportMode
    outcome: ReportOutcome = None  # type: ignore[assignment]  # set in __post_init__
    _report: Report | None = None

    def __post_init__(self) -> None:
        self.outcome = ReportOutcome()

    async def listing(self, api: ApiClient, on_progress: Callable[[], None]) -> list[Batch]:
        inputs = self.mode.inputs
        finder = ReportFetcher(api, inputs.access.project_id, inputs.report_id, Needs())
        report, batches = await finder.find_batches()
        self._report = report
        outcome = self.outcome
        outcome.report = report
        outcome.batches = len(batches)
        totals = [b.total_jobs for b in batches]
        outcome.jobs_total = None if None in totals else sum(t or 0 for t in totals)
        if batches:
            outcome.first = batches[0].creation_timestamp
            outcome.last = batches[-1].creation_timestamp
        on_progress()
        return batches

    def shard(
        self,
        run: FetchRun[Any, Any],
        index: int,
        items: list[Batch],
        states: list[Aggregation[Any]],
    ) -> ReportShard:
        if self._report is None:
            raise RuntimeError("shards are made after the report's batches are found")
        inputs = self.mode.inputs
        return ReportShard(
            index,
            run.access,
            run.settings,
            run.retry,
            run.needs,
            states,
            inputs.report_id,
            self.mode.config.report.use_summaries,
            self._report,
            items,
        )

    def add(self, part: FetchOutcome | ReportOutcome) -> None:
        if not isinstance(part, ReportOutcome):
            raise TypeError(
                f"a report shard's outcome is a ReportOutcome, not {type(part).__name__}"
            )
        outcome = self.outcome
        outcome.jobs += part.jobs
        outcome.batches_done += part.batches_done
        outcome.jobs_done += part.jobs_done
        outcome.jobs_with_metrics += part.jobs_with_metrics
        outcome.batches_summarised += part.batches_summarised
        outcome.missing.extend(part.missing)
        outcome.job_scalar_names |= part.job_scalar_names

    async def finish(self, api: ApiClient) -> None:
        """Nothing is fetched on the driver after the shards."""

    def abort(self) -> None:
        """Nothing runs on the driver beside the shards."""

    def complete(self) -> None:
        """Every shard is in: the job count is what the batches' listings proved."""
        self.outcome.jobs_total = self.outcome.jobs
        self.outcome.seconds = time.monotonic() - self.outcome.started
