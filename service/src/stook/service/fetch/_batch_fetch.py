"""The streaming fetch core of batch mode: every job of a batch, as a JobRecord, bounded.

Jobs are listed page by page into a bounded queue, by one of the workers whenever the
queue runs low; a fixed pool of workers takes each job as soon as its page arrives, lists
its metrics (scalars come with the listing, so they cost no download), downloads only
what the aggregations' `Needs` name (metrics data, job metrics with their data, events,
experience tags; see _job_blobs and the end of this module), and hands the record to `on_job`. At
most `workers + queue size` jobs are in memory at once, whatever the batch size.

A job's events and its experience's tags (`job_event`, `ExperienceTags`) are at the end.
"""

from __future__ import annotations

import asyncio
import functools
import inspect
import time
import uuid
from collections import deque
from collections.abc import AsyncIterator, Awaitable, Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Generic, TypeVar

import structlog

from stook.sdk.aggregations import UNKNOWN_STATUS, JobEvent, JobRecord, Needs
from stook.service.api import (
    ApiClient,
    ApiError,
    ApiMetric,
    ApiMetricsData,
    AuthError,
    Job,
    JobEventListing,
    OriginUnavailableError,
)
from stook.service.fetch._emissions import JobEmissions, fetch_emissions_log, workers_for
from stook.service.fetch._scalars import is_scalar, read_scalars

if TYPE_CHECKING:
    from stook.service.fetch._job_blobs import JobBlobs

__all__ = ["BatchFetcher", "FetchOutcome", "MissingJob", "OnEmissions", "OnJob"]

log = structlog.get_logger("stook.fetch")


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
    metric_names: set[str] = field(default_factory=set)  # every named job metric listed
    data_names: set[str] = field(default_factory=set)
    unnamed_data: int = 0  # metrics data listed without a name: no plan can ask for it
    started: float = field(default_factory=time.monotonic)
    seconds: float = 0.0


ProgressCallback = Callable[[FetchOutcome], None]
_Listed = tuple[int, Job]  # a job and its place in the listing
#: What receives each record: a function, or a coroutine function (awaited: back-pressure).
OnJob = Callable[[JobRecord], None] | Callable[[JobRecord], Awaitable[None]]
#: What receives each job's emissions log when the plan has config-defined metrics.
OnEmissions = Callable[[JobEmissions], Awaitable[None]]


class BatchFetcher:
    """Fetches one batch's jobs through an open ApiClient."""

    def __init__(
        self,
        api: ApiClient,
        project_id: uuid.UUID,
        batch_id: uuid.UUID,
        needs: Needs,
        *,
        workers: int | None = None,
        on_progress: ProgressCallback | None = None,
        jobs: Sequence[Job] | None = None,
        on_emissions: OnEmissions | None = None,
    ) -> None:
        """`jobs`: fetch these (a shard of the batch, listed elsewhere) instead of listing.

        `on_emissions`: the plan has config-defined metrics, so each job's emissions log is
        listed with its other listings and downloaded beside its metrics, on this client,
        and handed (`JobEmissions`, with the job's place in the listing) to `on_emissions`
        once the job's record is handed on. A job whose log fails for good is a missing
        job, as one whose metrics do."""
        workers = workers_for(api, workers)
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers}")
        self._api = api
        self._project_id = project_id
        self._batch_id = batch_id
        self._needs = needs
        self._workers = workers
        self._on_progress = on_progress
        self._tags = ExperienceTags(api, project_id)
        self._jobs = jobs
        self._on_emissions = on_emissions
        self.outcome = FetchOutcome()

    async def run(self, on_job: OnJob) -> FetchOutcome:
        """Fetch every job and call `on_job` with each record, in completion order.

        When `on_job` returns an awaitable it is awaited before that worker takes its next
        job: a slow consumer slows the fetch instead of piling records up.
        """
        queue: _JobQueue[_Listed] = _JobQueue(room=2 * self._workers, low=self._workers)
        try:
            await self._run(queue, on_job)
        except ExceptionGroup as group_error:
            # The first failure is the cause; the rest are its echoes in sibling tasks.
            raise group_error.exceptions[0] from None
        finally:
            await self._tags.aclose()
        self.outcome.seconds = time.monotonic() - self.outcome.started
        return self.outcome

    async def _run(self, queue: _JobQueue[_Listed], on_job: OnJob) -> None:
        async with asyncio.TaskGroup() as group:
            # The lister is one of the workers: `workers` tasks send requests, one at a time
            # each, so that none waits for a slot of the concurrency bound (as many as the
            # workers). A lister of its own was one task more than the slots: while it
            # listed a page, every request a worker sent next waited for a slot (a future,
            # a wake-up and a resumption through every frame: ~520 a run at 0 ms).
            group.create_task(self._list_jobs(queue, on_job))
            for _ in range(self._workers - 1):
                group.create_task(self._work(queue, on_job))

    async def _list_jobs(self, queue: _JobQueue[_Listed], on_job: OnJob) -> None:
        outcome = self.outcome

        def total_is(total: int) -> None:
            outcome.jobs_total = total

        # Not held in a variable: a cancelled run must drop the listing with the frame.
        async for job in (
            self._api.list_jobs(self._project_id, self._batch_id, on_total=total_is)
            if self._jobs is None
            else _given(self._jobs)
        ):
            outcome.jobs_listed += 1
            if self._on_progress is not None:
                self._on_progress(outcome)
            if queue.put((outcome.jobs_listed - 1, job)):
                # Full: work as the others do until it is down to `low`, then list on.
                await self._work(queue, on_job, while_plenty=True)
        outcome.jobs_total = outcome.jobs_listed  # what the complete listing proved
        # Workers stop once the queue is empty, told only after a complete listing. On any
        # failure the task group cancels the workers itself.
        queue.close()
        await self._work(queue, on_job)

    async def _work(
        self, queue: _JobQueue[_Listed], on_job: OnJob, *, while_plenty: bool = False
    ) -> None:
        """Fetch jobs until the listing is complete and taken; with `while_plenty` (the
        lister), only while the queue holds more than its `low`."""
        while True:
            if while_plenty and not queue.plenty():
                return
            taken = queue.take()
            if taken is None:
                if await queue.more():
                    continue
                return
            index, job = taken
            try:
                record = await self._fetch_job(job)
                emitted = None
                if self._on_emissions is not None:
                    emitted = await self._fetch_emissions(index, job)
            except (AuthError, OriginUnavailableError):
                raise
            except ApiError as exc:
                self.outcome.missing.append(
                    MissingJob(job.job_id, job.experience_name or "", exc.summary)
                )
                log.warning("job unavailable", job_id=str(job.job_id), reason=str(exc))
            else:
                handled = on_job(record)
                if handled is not None and inspect.isawaitable(handled):
                    await handled
                if emitted is not None and self._on_emissions is not None:
                    await self._on_emissions(emitted)
                self.outcome.jobs_done += 1
            if self._on_progress is not None:
                self._on_progress(self.outcome)

    async def _fetch_job(self, job: Job) -> JobRecord:
        needs = self._needs
        wants_blobs = bool(needs.data or needs.metrics) or needs.every_metric
        # A job's listings one after another, not side by side: each of the `workers`
        # then has one request in flight, as many as the concurrency bound lets out (the
        # workers are as many as the bound). Side by side, nearly every request queued
        # for a slot (2,805 of 2,976 at 0 ms, concurrency 64) and the job needed a task:
        # a future, a wake-up and a resumption through every frame, for no more requests
        # in flight.
        metrics = await self._list_metrics(job)
        data_items = await self._list_data(job) if wants_blobs else []
        data_names = [d.name for d in data_items if d.name]
        unnamed = len(data_items) - len(data_names)
        events: tuple[JobEvent, ...] = tuple(await self._list_events(job)) if needs.events else ()
        tags: tuple[str, ...] = (
            await self._tags.of(job.experience_id) if needs.experience_tags else ()
        )
        outcome = self.outcome
        source = f"job {job.job_id}"  # how errors and logs name the job
        if metrics:
            outcome.jobs_with_metrics += 1
        scalars = await read_scalars(
            self._api.storage,
            metrics,
            needs.wants_scalar,
            source=source,
            relist=lambda: self._list_metrics(job),
        )
        # Listed is enough: a name the job has is no typo, even when its value is absent.
        outcome.scalar_names.update([m.name for m in metrics if is_scalar(m)])
        outcome.metric_names.update([m.name for m in metrics if m.name])
        if unnamed:
            outcome.unnamed_data += unnamed
            log.debug("unnamed metrics data skipped", job_id=str(job.job_id), count=unnamed)
        outcome.data_names.update(data_names)
        blobs = None
        if wants_blobs:
            blobs = await _job_blobs()(
                self._api.storage,
                job.job_id,
                needs,
                metrics=metrics,
                data=data_items,
                relist_metrics=lambda: self._list_metrics(job),
                relist_data=lambda: self._list_data(job),
                source=source,
            ).fetch()
        return JobRecord(
            job_id=job.job_id,
            conflated_status=str(job.conflated_status or UNKNOWN_STATUS),
            experience_name=job.experience_name or "",
            experience_id=job.experience_id,
            scalars=scalars,
            series=blobs.series if blobs is not None else {},
            metric_statuses=[str(m.status) for m in metrics],
            data=blobs.data if blobs is not None else {},
            job_metrics=blobs.job_metrics if blobs is not None else None,
            parameters=job.parameters,
            events=events,
            experience_tags=tags,
        )

    async def _fetch_emissions(self, index: int, job: Job) -> JobEmissions:
        payload = await fetch_emissions_log(self._api, self._project_id, self._batch_id, job.job_id)
        return JobEmissions(index, self._batch_id, job, payload)

    def _list_metrics(self, job: Job) -> Awaitable[list[ApiMetric]]:
        return self._api.list_job_metrics(self._project_id, self._batch_id, job.job_id)

    def _list_data(self, job: Job) -> Awaitable[list[ApiMetricsData]]:
        return self._api.list_job_metrics_data(self._project_id, self._batch_id, job.job_id)

    async def _list_events(self, job: Job) -> list[JobEvent]:
        listed = await self._api.list_job_events(self._project_id, self._batch_id, job.job_id)
        return [job_event(e) for e in listed]


_T = TypeVar("_T")


class _JobQueue(Generic[_T]):
    """The jobs listed and not taken yet, from the lister to the workers, at most `room`.

    Not an asyncio.Queue: once that was full, each job a worker took woke the lister to
    put one more (a future, a wake-up and a resumption through the listing's generators,
    per job), and each take was a coroutine of its own. Here the lister, itself a worker,
    fills the queue and then works until only `low` jobs are left (see `plenty`), and a
    worker takes a job without a coroutine; only a worker that finds the queue empty waits.
    """

    __slots__ = ("_closed", "_jobs", "_low", "_room", "_takers")

    def __init__(self, *, room: int, low: int) -> None:
        self._jobs: deque[_T] = deque()
        self._room = room
        self._low = low
        self._closed = False  # the listing is complete: no job will be added
        self._takers: deque[asyncio.Future[None]] = deque()  # workers waiting for a job

    def put(self, job: _T) -> bool:
        """Add a job; whether the queue is full now (then list no more while `plenty`)."""
        self._jobs.append(job)
        if self._takers:
            self._wake_taker()
        return len(self._jobs) >= self._room

    def plenty(self) -> bool:
        """Whether the queue holds more than `low` jobs."""
        return len(self._jobs) > self._low

    def take(self) -> _T | None:
        """The next job, or None when there is none now (see `more`)."""
        jobs = self._jobs
        return jobs.popleft() if jobs else None

    async def more(self) -> bool:
        """Wait for a job to take (True), or for the complete listing to have been taken
        (False). Call it when `take` found none."""
        while not self._jobs:
            if self._closed:
                return False
            taker = asyncio.get_running_loop().create_future()
            self._takers.append(taker)
            try:
                await taker
            except BaseException:
                # Woken for a job, then cancelled: another worker may take it.
                if taker.done() and not taker.cancelled():
                    self._wake_taker()
                raise
        return True

    def close(self) -> None:
        """The listing is complete: workers that find the queue empty stop."""
        self._closed = True
        while self._takers:
            taker = self._takers.popleft()
            if not taker.done():
                taker.set_result(None)

    def _wake_taker(self) -> None:
        takers = self._takers
        while takers:
            taker = takers.popleft()
            if not taker.done():
                taker.set_result(None)
                return


@functools.cache
def _job_blobs() -> type[JobBlobs]:
    """JobBlobs, imported by the first job that has blobs, not with this module: the SDK's
    reader and protobuf are not needed before `stook run`'s first request, and a run that
    downloads no blob never imports them. Remembered: an import statement runs importlib's
    checks every time (~8,000 instructions a job)."""
    from stook.service.fetch._job_blobs import JobBlobs

    return JobBlobs


async def _given(jobs: Sequence[Job]) -> AsyncIterator[Job]:
    for job in jobs:
        yield job


# --- a job's events and its experience's tags ------------------------------------------------

# A job's events and its experience's tags, for plans that ask for them.
#
# Events cost one listing per job (`Needs.events`). Tags belong to the experience, not the
# job: they are listed once per experience (`Needs.experience_tags`), and every job of that
# experience, running at the same time or later, shares that one request.


def job_event(listed: JobEventListing) -> JobEvent:
    """An event as aggregations read it: statuses and timestamp types as the API spells them."""
    return JobEvent(
        event_id=listed.event_id,
        name=listed.name,
        status=str(listed.status),
        timestamp=listed.timestamp,
        timestamp_type=str(listed.timestamp_type or ""),
        description=listed.description,
        tags=listed.tags,
        metric_ids=listed.metric_ids,
    )


class ExperienceTags:
    """The sorted tag names of each experience, listed once per experience.

    Each experience's listing is a task of its own, shielded from the jobs waiting for it:
    one job being cancelled must not cancel the listing the others wait on. A listing that
    failed fails every job of that experience alike (no request storm). `aclose` cancels
    listings nobody waits for any more.
    """

    def __init__(self, api: ApiClient, project_id: uuid.UUID) -> None:
        self._api = api
        self._project_id = project_id
        self._listings: dict[uuid.UUID, asyncio.Task[tuple[str, ...]]] = {}

    async def of(self, experience_id: uuid.UUID | None) -> tuple[str, ...]:
        if experience_id is None:
            return ()
        listing = self._listings.get(experience_id)
        if listing is None:
            listing = asyncio.create_task(self._list(experience_id))
            self._listings[experience_id] = listing
        return await asyncio.shield(listing)

    async def _list(self, experience_id: uuid.UUID) -> tuple[str, ...]:
        names = [
            tag.name
            async for tag in self._api.list_experience_tags(self._project_id, experience_id)
            if tag.name
        ]
        return tuple(sorted(names))

    async def aclose(self) -> None:
        pending = [task for task in self._listings.values() if not task.done()]
        for task in pending:
            task.cancel()
        if pending:
            await asyncio.gather(*pending, return_exceptions=True)
        # A failed listing whose jobs all went away would be logged as never retrieved.
        for task in self._listings.values():
            if task.done() and not task.cancelled():
                task.exception()
