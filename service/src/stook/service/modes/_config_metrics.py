"""Config-defined metrics in batch and report mode: each job's emissions, into the engine.

With `[metrics_config] paths = [...]` in stook.toml, a batch run also evaluates the
config's `type: batch` metrics, and a report run its `dashboard` metrics, over what the
jobs emitted (their EMISSIONS_LOG, see stook.service.fetch). The config is loaded and
checked before the first request (`config_metrics_step`); the step itself runs once the
fetch is done, writing into the run's MetricsWriter beside the aggregations' metrics.

Each job's metadata row is filled from what the mode knows: the job (IDs, experience,
statuses), its batch (name, branch), the batch's build (`build_version`) and the
experience's tags. Jobs are handed to the engine in listing order, whatever order their
downloads finish in, so that the same inputs give the same bytes.
"""

from __future__ import annotations

import asyncio
import uuid
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Literal

import structlog

from stook.service.api import ApiClient, Batch, Job, RetryPolicy
from stook.service.fetch import fetch_deadline, fetch_emissions
from stook.service.modes._config import ConfigError, FetchSettings, StookConfig
from stook.service.modes._inputs import ApiAccess
from stook.service.modes._open_api import Traffic, open_api

if TYPE_CHECKING:
    from stook.sdk import MetricsWriter
    from stook.service.metrics_config import EmissionsSet, JobMeta, MetricsConfig

__all__ = ["ConfigMetricsStep", "config_metrics_step", "write_config_metrics"]

log = structlog.get_logger("stook.metrics_config")

Level = Literal["batch", "dashboard"]
_NEVER = datetime.min.replace(tzinfo=UTC)
#: What the pipeline runs once the fetch is done, before it writes the output: the
#: metrics into the writer, fetched with the run's `[fetch]` settings (and retry policy).
ConfigMetricsStep = Callable[
    ["MetricsWriter", FetchSettings, "RetryPolicy | None"], Awaitable[None]
]


@dataclass(frozen=True, slots=True)
class _Scope:
    """Whose jobs a run evaluates: one batch (batch mode) or a report's (report mode)."""

    level: Level
    batch_id: uuid.UUID | None = None
    report_id: uuid.UUID | None = None


def config_metrics_step(
    config: StookConfig,
    access: ApiAccess,
    *,
    batch_id: uuid.UUID | None = None,
    report_id: uuid.UUID | None = None,
) -> ConfigMetricsStep | None:
    """The step that writes the config-defined metrics of one batch (`batch_id`: its
    `batch` metrics) or one report (`report_id`: its `dashboard` metrics); None when
    stook.toml has no `[metrics_config]`.

    The config is loaded and checked here, before any request: a bad one raises
    MetricsConfigError (exit 2) and the run sends nothing.
    """
    settings = config.metrics_config
    if settings is None:
        return None
    # The engine (DuckDB, sqlglot, polars) only for the runs that use it.
    from stook.service.metrics_config import load_config

    # Relative paths are read from stook.toml's folder.
    base = config.file.parent if config.file is not None else None
    loaded = load_config(settings.config_paths(base), templates=settings.templates_path(base))
    chosen = settings.metrics_set
    if chosen is not None and chosen not in loaded.metrics_sets:
        # Found now, not after the fetch: the set is only looked up by the evaluation.
        known = ", ".join(sorted(loaded.metrics_sets)) or "none"
        raise ConfigError(
            f"{config.source}: [metrics_config] metrics_set {chosen!r} is not a metrics set "
            f"of the config (known: {known})"
        )
    scope = (
        _Scope("batch", batch_id=batch_id) if batch_id else _Scope("dashboard", report_id=report_id)
    )

    async def step(writer: MetricsWriter, fetch: FetchSettings, retry: RetryPolicy | None) -> None:
        await _write(
            writer, loaded, settings.metrics_set, scope, access, fetch, retry, settings.strict
        )

    return step


async def write_config_metrics(
    step: ConfigMetricsStep | None,
    writer: MetricsWriter,
    settings: FetchSettings,
    retry: RetryPolicy | None,
    *,
    started: float,
) -> None:
    """Run `step` (when there is one) into `writer`: its downloads are part of the fetch,
    under the run's `[fetch] deadline` (counted from `started`, the event loop's clock)."""
    if step is None:
        return
    async with fetch_deadline(
        settings.deadline, started=started, progress=lambda: "the jobs' emissions logs"
    ):
        await step(writer, settings, retry)


async def _write(
    writer: MetricsWriter,
    loaded: MetricsConfig,
    metrics_set: str | None,
    scope: _Scope,
    access: ApiAccess,
    settings: FetchSettings,
    retry: RetryPolicy | None,
    strict: bool,
) -> None:
    from stook.service.metrics_config import EmissionsSet, evaluate

    emissions = EmissionsSet(loaded)
    log.info("config metrics: fetching the jobs' emissions logs", level=scope.level)
    async with open_api(access, settings, retry) as api:
        jobs = await _jobs_of(api, access.project_id, scope)
        with_log = await _add_in_order(
            api, access.project_id, jobs, emissions, settings.concurrency
        )
        traffic = Traffic.of(api)  # its own client's: not in the run's final counts
    result = evaluate(
        loaded,
        emissions.tables(),
        writer,
        level=scope.level,
        metrics_set=metrics_set,
        strict=strict,
    )
    for failure in result.failed:
        log.warning("config metric written as an error", metric=failure.metric, error=str(failure))
    log.info(
        "config metrics written",
        level=scope.level,
        jobs=len(jobs),
        jobs_with_emissions=with_log,
        metrics=len(result.written),
        hidden=len(result.hidden),
        requests=traffic.requests,
        retries=traffic.retries,
        received_bytes=traffic.bytes_received,
    )


async def _add_in_order(
    api: ApiClient,
    project_id: uuid.UUID,
    jobs: Sequence[_ListedJob],
    emissions: EmissionsSet,
    workers: int,
) -> int:
    """Download every job's emissions, adding each to `emissions` in `jobs`' order: a job
    whose download finished early waits for those listed before it (so that at most the
    downloads in flight, and the ones waiting, are held at once)."""
    waiting: dict[int, bytes | None] = {}
    added = 0

    def arrived(job: _ListedJob, body: bytes | None) -> None:
        nonlocal added
        waiting[job.index] = body
        while added in waiting:
            listed = jobs[added]
            emissions.add_job(
                listed.meta, waiting.pop(added), name=f"job {listed.job_id} emissions log"
            )
            added += 1

    return await fetch_emissions(
        api,
        project_id,
        jobs,
        ids_of=lambda job: (job.batch_id, job.job_id),
        on_job=arrived,
        workers=workers,
    )


@dataclass(frozen=True, slots=True)
class _ListedJob:
    index: int  # in listing order, across the scope's batches
    batch_id: uuid.UUID
    job_id: uuid.UUID
    meta: JobMeta


async def _jobs_of(api: ApiClient, project_id: uuid.UUID, scope: _Scope) -> list[_ListedJob]:
    """Every job of the scope with its metadata row, batches oldest first, jobs in
    listing order."""
    if scope.batch_id is not None:
        batches = [await api.get_batch(project_id, scope.batch_id)]
    else:
        assert scope.report_id is not None
        # The report fetch's module, with report mode's search: not imported by batch runs.
        from stook.service.fetch import search_for

        report = await api.get_report(project_id, scope.report_id)
        found = [b async for b in api.list_batches(project_id, search=search_for(report))]
        # Oldest first (the API lists newest first); by ID among equal times.
        batches = sorted(found, key=lambda b: (b.creation_timestamp or _NEVER, str(b.batch_id)))
    listings = await asyncio.gather(
        *(_all_jobs(api, project_id, batch.batch_id) for batch in batches)
    )
    listed = [(batch, job) for batch, jobs in zip(batches, listings, strict=True) for job in jobs]
    known = await _Known.ask(api, project_id, listed)
    return [
        _ListedJob(index, batch.batch_id, job.job_id, known.meta(project_id, batch, job))
        for index, (batch, job) in enumerate(listed)
    ]


async def _all_jobs(api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID) -> list[Job]:
    return [job async for job in api.list_jobs(project_id, batch_id)]


@dataclass(frozen=True, slots=True)
class _Known:
    """What the metadata rows take from beyond the jobs: builds' versions, branches' names
    and experiences' tags, each asked for once a run, all at once."""

    versions: dict[uuid.UUID, str | None]
    branches: dict[uuid.UUID, str]
    tags: dict[uuid.UUID, tuple[str, ...]]

    @classmethod
    async def ask(
        cls, api: ApiClient, project_id: uuid.UUID, listed: Sequence[tuple[Batch, Job]]
    ) -> _Known:
        builds = sorted({b for batch, job in listed if (b := _build_of(batch, job)) is not None})
        experiences = sorted({job.experience_id for _, job in listed if job.experience_id})

        async def version(build_id: uuid.UUID) -> str | None:
            return (await api.get_build(project_id, build_id)).version

        async def tags(experience_id: uuid.UUID) -> tuple[str, ...]:
            found = api.list_experience_tags(project_id, experience_id)
            return tuple(sorted([tag.name async for tag in found]))

        async def branches() -> dict[uuid.UUID, str]:
            if not listed:
                return {}
            return {b.branch_id: b.name async for b in api.list_branches(project_id)}

        # Gathered: the client's limiter bounds the requests in flight.
        versions, tag_names, names = await asyncio.gather(
            asyncio.gather(*map(version, builds)),
            asyncio.gather(*map(tags, experiences)),
            branches(),
        )
        return cls(
            dict(zip(builds, versions, strict=True)),
            names,
            dict(zip(experiences, tag_names, strict=True)),
        )

    def meta(self, project_id: uuid.UUID, batch: Batch, job: Job) -> JobMeta:
        from stook.service.metrics_config import JobMeta

        build_id = _build_of(batch, job)
        return JobMeta(
            job_id=str(job.job_id),
            batch_id=str(batch.batch_id),
            project_id=str(project_id),
            experience_id=_text(job.experience_id),
            experience_name=job.experience_name,
            build_id=_text(build_id),
            build_version=None if build_id is None else self.versions[build_id],
            batch_name=batch.friendly_name,
            job_status=_text(job.job_status),
            job_conflated_status=_text(job.conflated_status),
            branch=None if batch.branch_id is None else self.branches.get(batch.branch_id),
            tags=self.tags.get(job.experience_id, ()) if job.experience_id else (),
        )


def _build_of(batch: Batch, job: Job) -> uuid.UUID | None:
    return job.build_id or batch.build_id


def _text(value: object) -> str | None:
    return None if value is None else str(value)
