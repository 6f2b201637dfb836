"""The streaming fetch core of batch mode: every job of a batch, as a JobRecord, bounded.

Jobs are listed page by page into a bounded queue; a fixed pool of workers takes
each job as soon as its page arrives, lists its metrics (scalars come with the
listing, so they cost no download), downloads only the metrics data the aggregations'
`Needs` name, and hands the record to `on_job`. At most `workers + queue size` jobs are
in memory at once, whatever the batch size.
"""

from __future__ import annotations

import asyncio
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import structlog

from stook.sdk import ReadError, read_metrics_data
from stook.sdk.aggregations import UNKNOWN_STATUS, JobRecord, Needs
from stook.service.api import (
    ApiClient,
    ApiError,
    ApiMetric,
    ApiMetricsData,
    AuthError,
    Job,
    OriginUnavailableError,
)
from stook.service.fetch._presigned import fetch_listed
from stook.service.fetch._scalars import is_scalar, read_scalars

# polars comes with the first series decoded, after the first requests are out.
if TYPE_CHECKING:
    import polars as pl

log = structlog.get_logger("stook.fetch")


class InvalidDataError(ReadError):
    """A job's metrics data could not be decoded (exit code 4)."""


@dataclass(frozen=True, slots=True)
class MissingJob:
    job_id: uuid.UUID
    experience_name: str
    reason: str


@dataclass(slots=True)
class FetchOutcome:
    """What a fetch saw: counts, names for config checks, and the jobs it could not fetch."""

    jobs_listed: int = 0
    # The batch's job count as the listing's `total` says (None until a page carries it),
    # and the jobs listed once the listing is complete: the progress bar's fixed total.
    jobs_total: int | None = None
    jobs_done: int = 0
    jobs_with_metrics: int = 0
    missing: list[MissingJob] = field(default_factory=list)
    scalar_names: set[str] = field(default_factory=set)
    data_names: set[str] = field(default_factory=set)
    unnamed_data: int = 0  # metrics data listed without a name: no plan can ask for it
    started: float = field(default_factory=time.monotonic)
    seconds: float = 0.0


ProgressCallback = Callable[[FetchOutcome], None]


class BatchFetcher:
    """Fetches one batch's jobs through an open ApiClient."""

    def __init__(
        self,
        api: ApiClient,
        project_id: uuid.UUID,
        batch_id: uuid.UUID,
        needs: Needs,
        *,
        workers: int = 64,
        on_progress: ProgressCallback | None = None,
    ) -> None:
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers}")
        self._api = api
        self._project_id = project_id
        self._batch_id = batch_id
        self._needs = needs
        self._workers = workers
        self._on_progress = on_progress
        self.outcome = FetchOutcome()

    async def run(self, on_job: Callable[[JobRecord], None]) -> FetchOutcome:
        """Fetch every job and call `on_job` with each record, in completion order."""
        queue: asyncio.Queue[Job | None] = asyncio.Queue(maxsize=2 * self._workers)
        try:
            async with asyncio.TaskGroup() as group:
                group.create_task(self._list_jobs(queue))
                for _ in range(self._workers):
                    group.create_task(self._work(queue, on_job))
        except ExceptionGroup as group_error:
            # The first failure is the cause; the rest are its echoes in sibling tasks.
            raise group_error.exceptions[0] from None
        self.outcome.seconds = time.monotonic() - self.outcome.started
        return self.outcome

    async def _list_jobs(self, queue: asyncio.Queue[Job | None]) -> None:
        outcome = self.outcome

        def total_is(total: int) -> None:
            outcome.jobs_total = total

        async for job in self._api.list_jobs(self._project_id, self._batch_id, on_total=total_is):
            outcome.jobs_listed += 1
            if self._on_progress is not None:
                self._on_progress(outcome)
            await queue.put(job)
        outcome.jobs_total = outcome.jobs_listed  # what the complete listing proved
        # Workers stop on None, sent only after a complete listing. On any failure the task
        # group cancels the workers itself; waiting here to put None into a full queue that
        # nobody drains any more would hang the run.
        for _ in range(self._workers):
            await queue.put(None)

    async def _work(
        self, queue: asyncio.Queue[Job | None], on_job: Callable[[JobRecord], None]
    ) -> None:
        while (job := await queue.get()) is not None:
            try:
                record = await self._fetch_job(job)
            except (AuthError, OriginUnavailableError):
                raise
            except ApiError as exc:
                self.outcome.missing.append(
                    MissingJob(job.job_id, job.experience_name or "", str(exc))
                )
                log.warning("job unavailable", job_id=str(job.job_id), reason=str(exc))
            else:
                on_job(record)
                self.outcome.jobs_done += 1
            if self._on_progress is not None:
                self._on_progress(self.outcome)

    async def _fetch_job(self, job: Job) -> JobRecord:
        data_items: list[ApiMetricsData] = []
        if self._needs.data:
            metrics, data_items = await asyncio.gather(
                self._list_metrics(job), self._list_data(job)
            )
        else:
            metrics = await self._list_metrics(job)
        if metrics:
            self.outcome.jobs_with_metrics += 1
        scalars = await read_scalars(
            self._api.storage,
            metrics,
            self._needs.wants_scalar,
            source=f"job {job.job_id}",
            relist=lambda: self._list_metrics(job),
        )
        # Listed is enough: a name the job has is no typo, even when its value is absent.
        self.outcome.scalar_names.update(m.name for m in metrics if is_scalar(m))
        unnamed = sum(not d.name for d in data_items)
        if unnamed:
            self.outcome.unnamed_data += unnamed
            log.debug("unnamed metrics data skipped", job_id=str(job.job_id), count=unnamed)
        self.outcome.data_names.update(d.name for d in data_items if d.name)
        wanted = [d for d in data_items if d.name in self._needs.data and d.is_standard]
        if len(wanted) == 1:
            # The common plan (one series per job) needs no task to gather.
            series = {wanted[0].name: await self._download(job, wanted[0])}
        else:
            downloads = [self._download(job, d) for d in wanted]
            values = await asyncio.gather(*downloads)
            series = dict(zip((d.name for d in wanted), values, strict=True))
        return JobRecord(
            job_id=job.job_id,
            conflated_status=str(job.conflated_status or UNKNOWN_STATUS),
            experience_name=job.experience_name or "",
            experience_id=job.experience_id,
            scalars=scalars,
            series=series,
            metric_statuses=[str(m.status) for m in metrics],
        )

    async def _list_metrics(self, job: Job) -> list[ApiMetric]:
        return [
            m
            async for m in self._api.list_job_metrics(self._project_id, self._batch_id, job.job_id)
        ]

    async def _list_data(self, job: Job) -> list[ApiMetricsData]:
        return [
            d
            async for d in self._api.list_job_metrics_data(
                self._project_id, self._batch_id, job.job_id
            )
        ]

    async def _download(self, job: Job, item: ApiMetricsData) -> pl.Series:
        source = f"job {job.job_id} / metrics data {item.name!r}"
        payload, _ = await fetch_listed(
            self._api.storage,
            item,
            url_of=lambda d: d.metrics_data_url,
            id_of=lambda d: d.data_id,
            relist=lambda: self._list_data(job),
            source=source,
        )
        if payload is None:
            raise InvalidDataError(f"could not read MetricsData from {source}: it has no URL")
        return decode_values(payload, source=source)


def decode_values(payload: bytes, *, source: str) -> pl.Series:
    """The values of a serialized MetricsData: its series, or all categories appended."""
    try:
        view = read_metrics_data(payload, source=source)
        if view.per_category:
            return view.frame().get_column("value").alias(view.name)
        return view.series()
    except ReadError as exc:
        raise InvalidDataError(str(exc)) from None
