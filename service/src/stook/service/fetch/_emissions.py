"""Each job's emissions log (EMISSIONS_LOG), downloaded for the config-defined metrics.

A test emits rows to `emissions.resim.jsonl`; the platform keeps it as a job log. Here a
job's EMISSIONS_LOG logs are listed and each downloaded at its presigned URL by the
storage client, through the same bounded, retrying path as the metrics-data blobs
(`fetch_listed`: listed again when the URL has expired). The API token stays on the API
session: storage requests carry none.

In batch mode the logs are part of the batch's fetch (`BatchFetcher(on_emissions=...)`
hands on a `JobEmissions` per job). `fetch_emissions` does the same for jobs listed
elsewhere (a sharded run's driver, a report's batches) with a fixed pool of workers,
handing each job's bytes on as soon as they are complete; a job without an emissions log
hands on None (it emitted no rows).
"""

from __future__ import annotations

import asyncio
import uuid
from collections.abc import Awaitable, Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import TypeVar

import structlog

from stook.service.api import ApiClient, Job, JobLog, LogType
from stook.service.fetch._presigned import fetch_listed

__all__ = ["JobEmissions", "fetch_emissions", "fetch_emissions_log", "workers_for"]

log = structlog.get_logger("stook.fetch")

_Job = TypeVar("_Job")


def workers_for(api: ApiClient, workers: int | None) -> int:
    """How many workers a fetch on `api` runs: as given, else as many as the client lets
    requests out at once (its concurrency), so that each worker has one request in flight
    and none waits for a slot. The fetchers' one default: `[fetch] concurrency` sets both."""
    return int(api.limiter.stats.ceiling) if workers is None else workers


@dataclass(frozen=True, slots=True)
class JobEmissions:
    """One job's emissions as a batch fetch hands them on: the job as listed, its place in
    the listing (the order the config-defined metrics add jobs in, whatever order their
    downloads finish in), and what it emitted (None: no emissions log)."""

    index: int
    batch_id: uuid.UUID
    job: Job
    payload: bytes | None


async def _emission_logs(
    api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID, job_id: uuid.UUID
) -> list[JobLog]:
    """The job's EMISSIONS_LOG logs, in a stable order (by path, name, ID)."""
    logs = [
        found
        async for found in api.list_job_logs(
            project_id, batch_id, job_id, log_type=LogType.EMISSIONS_LOG
        )
        # Filtered here too: a server that ignores the filter must not feed other logs in.
        if found.log_type == LogType.EMISSIONS_LOG
    ]
    return sorted(logs, key=lambda f: (f.file_path, f.file_name, f.log_id))


async def fetch_emissions_log(
    api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID, job_id: uuid.UUID
) -> bytes | None:
    """What the job emitted, as one emissions file's bytes; None when it has no emissions
    log. Several EMISSIONS_LOG logs (a test that emitted from sub-processes) are joined,
    line-wise, in path order.

    Raises the API layer's errors (ApiError) when the listing or a download fails for good.
    """
    logs = await _emission_logs(api, project_id, batch_id, job_id)
    if not logs:
        return None
    parts: list[bytes] = []
    for item in logs:
        payload, _ = await fetch_listed(
            api.storage,
            item,
            url_of=lambda i: i.log_output_location,
            id_of=lambda i: i.log_id,
            relist=lambda: _emission_logs(api, project_id, batch_id, job_id),
            source=f"job {job_id} emissions log",
        )
        if payload:
            parts.append(payload if payload.endswith(b"\n") else payload + b"\n")
    return b"".join(parts)


async def fetch_emissions(
    api: ApiClient,
    project_id: uuid.UUID,
    jobs: Iterable[_Job],
    *,
    ids_of: Callable[[_Job], tuple[uuid.UUID, uuid.UUID]],
    on_job: Callable[[_Job, bytes | None], Awaitable[None] | None],
    workers: int | None = None,
) -> int:
    """Every job's emissions (see `fetch_emissions_log`), `workers` jobs at a time, each
    handed to `on_job` (awaited when it returns an awaitable) as soon as it is complete.
    `ids_of` gives a job's (batch ID, job ID). Returns how many jobs had an emissions log.

    The first job that fails for good fails the whole fetch: its error is raised once the
    other workers are stopped.
    """
    workers = workers_for(api, workers)
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    queue: Iterator[_Job] = iter(jobs)
    with_log = 0

    async def worker() -> None:
        nonlocal with_log
        for job in queue:  # shared: each job is taken by one worker
            batch_id, job_id = ids_of(job)
            payload = await fetch_emissions_log(api, project_id, batch_id, job_id)
            if payload is not None:
                with_log += 1
            handed = on_job(job, payload)
            if handed is not None:
                await handed

    # Not a TaskGroup: its ExceptionGroup would hide the one error the caller maps to an
    # exit code.
    tasks = [asyncio.create_task(worker()) for _ in range(workers)]
    try:
        await asyncio.gather(*tasks)
    finally:
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
    log.debug("emissions fetched", jobs_with_log=with_log)
    return with_log
