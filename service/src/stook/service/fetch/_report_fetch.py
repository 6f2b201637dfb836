"""The fetch core of report mode: the report, its batches, and per batch its metrics and jobs.

The report's batches are found with the platform's `search` filter and sorted by
creation time. Batches are listed a few at a time; when the plan asks for job
metrics, every job of a listed batch goes into one bounded queue that a fixed pool
of workers drains, so requests stay within the client's bound and memory within
`workers + queue size` jobs, however long the report. A batch is handed to
`on_batch` as a `BatchRecord` once all of its jobs are in.

A batch's stook summary (`read_summary`, at the end) replaces its job listings where
the batch has one.
"""

from __future__ import annotations

import asyncio
import dataclasses
import time
import uuid
from collections import Counter
from collections.abc import AsyncIterator, Awaitable, Callable, Mapping
from dataclasses import dataclass, field
from datetime import datetime
from typing import TypeVar

import structlog

from stook.sdk import ReadError, read_metrics_data
from stook.sdk.aggregations import (
    SUMMARY_DATA_NAME,
    UNKNOWN_STATUS,
    BatchRecord,
    ColumnarSummary,
    JobColumns,
    JobSummary,
    Needs,
    Scalar,
    SummaryError,
    SummaryVersionError,
    summary_columns_from_data,
)
from stook.service.api import (
    ApiClient,
    ApiError,
    ApiMetric,
    ApiMetricsData,
    AuthError,
    Batch,
    Job,
    NotFoundError,
    OriginUnavailableError,
    Report,
)
from stook.service.fetch._batch_fetch import MissingJob
from stook.service.fetch._emissions import workers_for
from stook.service.fetch._errors import ReportNotFoundError
from stook.service.fetch._presigned import fetch_listed
from stook.service.fetch._scalars import read_scalar_values, read_scalars

log = structlog.get_logger("stook.report")
_T = TypeVar("_T")

# Batches whose job and metric lists are fetched at once; their jobs share the workers.
_BATCHES_IN_FLIGHT = 4


@dataclass(slots=True)
class ReportOutcome:
    report: Report | None = None
    batches: int = 0
    jobs: int = 0
    # For the progress display: batches handed over, jobs whose part is done (metrics
    # fetched, or listed when the plan reads no job metrics), and the report's job count
    # (the batches' `totalJobs` until their listings prove it; None while one is unknown).
    batches_done: int = 0
    jobs_done: int = 0
    jobs_total: int | None = None
    jobs_with_metrics: int = 0
    # Batches read from their stook summary (one listing and one download each).
    batches_summarised: int = 0
    missing: list[MissingJob] = field(default_factory=list)
    job_scalar_names: set[str] = field(default_factory=set)
    first: datetime | None = None
    last: datetime | None = None
    # The report's batches as found, oldest first (for what reads them after the fetch).
    found_batches: list[Batch] = field(default_factory=list)
    started: float = field(default_factory=time.monotonic)
    seconds: float = 0.0


def search_for(report: Report) -> str:
    """The platform's batch filter for a report (see resim-api.md)."""
    clauses = [
        f'test_suite_id = "{report.test_suite_id}"',
        f'branch_id = "{report.branch_id}"',
        f'created_at > "{report.start_timestamp.isoformat()}"',
        f'created_at < "{report.end_timestamp.isoformat()}"',
    ]
    if report.respect_revision_boundary:
        clauses.append(f"test_suite_revision = {report.test_suite_revision}")
    return " AND ".join(clauses)


@dataclass(frozen=True, slots=True)
class JobScalars:
    """A job's metric listing as report mode reads it: each SCALAR's (value, unit) by name
    (the last of a name wins), every named SCALAR's name, and each metric's status as its
    text."""

    values: dict[str, tuple[float, str]]
    names: list[str]
    statuses: list[str]


@dataclass(slots=True)
class _PendingBatch:
    """A batch whose jobs' metrics are still coming in."""

    batch: Batch
    scalars: dict[str, Scalar]
    metric_statuses: list[str]
    jobs: list[JobSummary]
    remaining: int
    listed: bool = False
    # Job metric statuses as listed, as strings (counted once the batch is in).
    job_statuses: list[str] = field(default_factory=list)
    # Per job: its scalars, (value, unit) by name, as a summary has them (made into the
    # batch's columns when it is done).
    job_values: dict[uuid.UUID, Mapping[str, tuple[float, str]]] = field(default_factory=dict)
    # A batch read from its summary comes with its columns.
    columns: JobColumns | None = None


class ReportFetcher:
    def __init__(
        self,
        api: ApiClient,
        project_id: uuid.UUID,
        report_id: uuid.UUID,
        needs: Needs,
        *,
        workers: int | None = None,
        on_progress: Callable[[ReportOutcome], None] | None = None,
        use_summaries: bool = True,
        batches: tuple[Report, list[Batch]] | None = None,
    ) -> None:
        self._api = api
        self._given = batches
        self._use_summaries = use_summaries
        self._project_id = project_id
        self._report_id = report_id
        self._needs = needs
        self._workers = workers  # None: the client's concurrency, found when the run starts
        self._on_progress = on_progress
        self.outcome = ReportOutcome()

    async def find_batches(self) -> tuple[Report, list[Batch]]:
        """The report and its batches, oldest first."""
        try:
            report = await self._api.get_report(self._project_id, self._report_id)
        except NotFoundError:
            raise ReportNotFoundError(
                f"report {self._report_id} does not exist in project {self._project_id} (HTTP 404)"
            ) from None
        batches = [
            b async for b in self._api.list_batches(self._project_id, search=search_for(report))
        ]
        batches.sort(key=lambda b: (b.creation_timestamp or report.start_timestamp, b.batch_id))
        return report, batches

    async def run(self, on_batch: Callable[[BatchRecord], None]) -> ReportOutcome:
        # A shard of the report (batches found elsewhere) is given them; a whole run finds them.
        report, batches = self._given or await self.find_batches()
        self.outcome.report = report
        self.outcome.batches = len(batches)
        self.outcome.found_batches = batches
        totals = [b.total_jobs for b in batches]
        self.outcome.jobs_total = None if None in totals else sum(t or 0 for t in totals)
        self._announce()
        if batches:
            self.outcome.first = batches[0].creation_timestamp
            self.outcome.last = batches[-1].creation_timestamp
        log.info("report batches found", report_id=str(self._report_id), batches=len(batches))

        pool = workers_for(self._api, self._workers)
        queue: asyncio.Queue[tuple[_PendingBatch, Job] | None] = asyncio.Queue(maxsize=2 * pool)
        gate = asyncio.Semaphore(_BATCHES_IN_FLIGHT)
        workers = pool if self._needs.job_metrics else 0
        try:
            async with asyncio.TaskGroup() as group:
                for _ in range(workers):
                    group.create_task(self._work(queue, on_batch))
                lister = group.create_task(self._list_all(batches, gate, queue, on_batch))
                await lister
                self.outcome.jobs_total = self.outcome.jobs  # every batch's jobs are listed
                # Reached only after a complete listing. Should a worker fail meanwhile, the
                # group cancels this body too, so a put into a full queue cannot hang here.
                for _ in range(workers):
                    await queue.put(None)
        except ExceptionGroup as group_error:
            raise group_error.exceptions[0] from None
        self.outcome.seconds = time.monotonic() - self.outcome.started
        return self.outcome

    async def _list_all(
        self,
        batches: list[Batch],
        gate: asyncio.Semaphore,
        queue: asyncio.Queue[tuple[_PendingBatch, Job] | None],
        on_batch: Callable[[BatchRecord], None],
    ) -> None:
        async def one(batch: Batch) -> None:
            async with gate:
                await self._list_batch(batch, queue, on_batch)

        async with asyncio.TaskGroup() as group:
            for batch in batches:
                group.create_task(one(batch))

    async def _list_batch(
        self,
        batch: Batch,
        queue: asyncio.Queue[tuple[_PendingBatch, Job] | None],
        on_batch: Callable[[BatchRecord], None],
    ) -> None:
        if self._use_summaries:
            metrics, summary = await asyncio.gather(
                _collect(self._api.list_batch_metrics(self._project_id, batch.batch_id)),
                read_summary(self._api, self._project_id, batch.batch_id),
            )
            if summary is not None:
                await self._from_summary(batch, metrics, summary, on_batch)
                return
            jobs = await _collect(self._jobs_of(batch))
        else:
            metrics, jobs = await asyncio.gather(
                _collect(self._api.list_batch_metrics(self._project_id, batch.batch_id)),
                _collect(self._jobs_of(batch)),
            )
        self.outcome.jobs += len(jobs)
        if self.outcome.jobs_total is not None:
            # The listing is the truth where it and the batch's totalJobs differ.
            self.outcome.jobs_total += len(jobs) - (batch.total_jobs or 0)
        if not self._needs.job_metrics:
            self.outcome.jobs_done += len(jobs)
        pending = _PendingBatch(
            batch=batch,
            scalars=await self._batch_scalars(batch, metrics),
            metric_statuses=[str(m.status) for m in metrics],
            jobs=[
                JobSummary(
                    j.job_id,
                    j.experience_name or "",
                    str(j.conflated_status or UNKNOWN_STATUS),
                    j.experience_id,
                )
                for j in jobs
            ],
            remaining=len(jobs) if self._needs.job_metrics else 0,
        )
        if self._needs.job_metrics:
            for job in jobs:
                await queue.put((pending, job))
        pending.listed = True
        if pending.remaining == 0:
            self._finish(pending, on_batch)

    async def _batch_scalars(self, batch: Batch, metrics: list[ApiMetric]) -> dict[str, Scalar]:
        return await read_scalars(
            self._api.storage,
            metrics,
            self._needs.wants_scalar,
            source=f"batch {batch.batch_id}",
            relist=lambda: _collect(self._api.list_batch_metrics(self._project_id, batch.batch_id)),
        )

    async def _from_summary(
        self,
        batch: Batch,
        metrics: list[ApiMetric],
        summary: ColumnarSummary,
        on_batch: Callable[[BatchRecord], None],
    ) -> None:
        """The batch as its summary has it: what the job listings would have given."""
        columns = summary.columns
        count = len(columns)
        self.outcome.jobs += count
        self.outcome.jobs_done += count
        self.outcome.batches_summarised += 1
        if self.outcome.jobs_total is not None:
            self.outcome.jobs_total += count - (batch.total_jobs or 0)
        if self._needs.job_metrics:
            self.outcome.jobs_with_metrics += summary.jobs_with_metrics
            self.outcome.job_scalar_names.update(columns.scalars)
        else:
            # As the listings: no job's metrics read.
            columns = dataclasses.replace(columns, scalars={}, metric_statuses={})
        pending = _PendingBatch(
            batch=batch,
            scalars=await self._batch_scalars(batch, metrics),
            metric_statuses=[str(m.status) for m in metrics],
            jobs=[],
            remaining=0,
            listed=True,
            columns=columns,
        )
        self._finish(pending, on_batch)

    async def _work(
        self,
        queue: asyncio.Queue[tuple[_PendingBatch, Job] | None],
        on_batch: Callable[[BatchRecord], None],
    ) -> None:
        while (item := await queue.get()) is not None:
            pending, job = item
            try:
                listed = await self._job_scalars(pending.batch, job)
            except (AuthError, OriginUnavailableError):
                raise
            except ApiError as exc:
                self.outcome.missing.append(
                    MissingJob(job.job_id, job.experience_name or "", exc.summary)
                )
                log.warning("job metrics unavailable", job_id=str(job.job_id), reason=str(exc))
            else:
                if listed.statuses:  # one per metric listed
                    self.outcome.jobs_with_metrics += 1
                # Listed is enough for a name: a name a job has is no typo, even when its
                # value is absent.
                self.outcome.job_scalar_names.update(listed.names)
                pending.job_statuses += listed.statuses
                pending.job_values[job.job_id] = listed.values
            pending.remaining -= 1
            self.outcome.jobs_done += 1
            if pending.remaining == 0 and pending.listed:
                self._finish(pending, on_batch)
            else:
                self._announce()

    def _jobs_of(self, batch: Batch) -> AsyncIterator[Job]:
        # The batch's totalJobs bounds a listing whose pages do not say their total.
        return self._api.list_jobs(self._project_id, batch.batch_id, expected=batch.total_jobs)

    async def _job_scalars(self, batch: Batch, job: Job) -> JobScalars:
        """The job's metric listing as the batch's columns need it, with null values read
        from their messages when an aggregation reads them."""

        def listing() -> Awaitable[list[ApiMetric]]:
            return self._api.list_job_metrics(self._project_id, batch.batch_id, job.job_id)

        metrics = await listing()
        names: set[str] = set()
        values = await read_scalar_values(
            self._api.storage,
            metrics,
            self._needs.wants_scalar,
            names=names,
            source=lambda: f"job {job.job_id}",
            relist=listing,
        )
        return JobScalars(values, list(names), [str(m.status) for m in metrics])

    def _finish(self, pending: _PendingBatch, on_batch: Callable[[BatchRecord], None]) -> None:
        batch = pending.batch
        created = batch.creation_timestamp
        if created is None:
            raise ApiError(f"batch {batch.batch_id} has no creationTimestamp to place it in time")
        # In job-ID order, so that the record does not depend on the order job listings
        # returned in; a metric's unit is its first job's.
        columns = pending.columns or JobColumns.build(
            pending.jobs,
            [pending.job_values.get(j.job_id, {}) for j in pending.jobs],
            Counter(pending.job_statuses),
        )
        on_batch(
            BatchRecord.with_columns(
                batch.batch_id,
                batch.friendly_name or str(batch.batch_id)[:8],
                created,
                columns,
                conflated_status=str(batch.conflated_status or ""),
                scalars=pending.scalars,
                metric_statuses=sorted(pending.metric_statuses),
                build_id=batch.build_id,
            )
        )
        self.outcome.batches_done += 1
        self._announce()

    def _announce(self) -> None:
        if self._on_progress is not None:
            self._on_progress(self.outcome)


async def _collect(items: AsyncIterator[_T]) -> list[_T]:
    return [item async for item in items]


# --- a batch's stook summary -----------------------------------------------------------------

# A batch's stook summary, when its batch metrics build wrote one: one listing, one download.
#
# Batch mode writes the summary (`BatchSummaryWriter`) as batch metrics data named
# `SUMMARY_DATA_NAME`. Report mode reads it instead of listing the batch's jobs and every
# job's metrics. Anything short of a summary this code can read in full (none listed, no
# URL, a newer layout, bytes that are not a summary) returns None with the reason logged,
# and the report lists that batch's jobs as before: a wrong number is never an option.


async def read_summary(
    api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID
) -> ColumnarSummary | None:
    """The batch's summary, as columns, or None when it has none that this code can read."""
    listed = await _list(api, project_id, batch_id)
    found = [d for d in listed if d.name == SUMMARY_DATA_NAME and d.is_standard]
    if not found:
        log.debug("batch has no stook summary; listing its jobs", batch_id=str(batch_id))
        return None
    source = f"batch {batch_id} / {SUMMARY_DATA_NAME}"
    payload, _ = await fetch_listed(
        api.storage,
        found[0],
        url_of=lambda d: d.metrics_data_url,
        id_of=lambda d: d.data_id,
        relist=lambda: _list(api, project_id, batch_id),
        source=source,
    )
    if payload is None:
        log.warning("batch summary has no URL; listing the batch's jobs", batch_id=str(batch_id))
        return None
    try:
        return summary_columns_from_data(read_metrics_data(payload, source=source))
    except SummaryVersionError as exc:
        log.warning(
            "batch summary written by a newer stook; listing the batch's jobs",
            batch_id=str(batch_id),
            reason=str(exc),
        )
    except (SummaryError, ReadError) as exc:
        log.warning(
            "batch summary unreadable; listing the batch's jobs",
            batch_id=str(batch_id),
            reason=str(exc),
        )
    return None


async def _list(api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID) -> list[ApiMetricsData]:
    return [d async for d in api.list_batch_metrics_data(project_id, batch_id)]
