"""Config-defined metrics in a mode: stook.toml's `[metrics_config]`, over what jobs emitted.

[metrics_config]
paths = [".resim/metrics/config.resim.yml"]   # merged by the platform's rules
metrics_set = "core"          # optional: only this set's metrics (default: all of the level)
templates = ".resim/metrics/templates"        # optional (default: beside the first path)
emissions = "logs/emissions.resim.jsonl"      # test mode, optional (default: the inputs'
                                              # logs/emissions.resim.jsonl)
strict = true                 # optional: a failing metric fails the run (exit 4) instead
                              # of being written as an error (default: false)

Relative paths are read from stook.toml's folder. The config is loaded and checked before
any work (a bad one is exit 2 before the first request, or before the user's function):
`TestConfigMetrics.load` in test mode, `ConfigMetrics.load` in batch and report mode.

Test mode evaluates the `type: test` metrics over the test's emissions file, beside what
a `[test]` metrics function writes.

Batch mode evaluates the `type: batch` metrics over the batch's jobs' emissions logs, and
those logs are part of the batch's fetch: listed with each job's other listings and
downloaded beside its metrics, on the run's one bounded client, counted in its traffic,
under its deadline (`BatchFetcher(on_emissions=...)`; a sharded run's driver fetches
them over the jobs it listed, beside the shards). Each job is listed once.

Report mode evaluates the `dashboard` metrics. The platform's dashboard queries read the
rows every job of the report's batches emitted, so there is no smaller input that gives
the same numbers: a report whose config has dashboard metrics lists each of its batches'
jobs and downloads their emissions logs after the report's fetch, on the same client,
using the batches that fetch found. A config (or `metrics_set`) without dashboard metrics
downloads no log at all, in either mode.

Batch mode evaluates the metrics set stook.toml names, else the one the batch was
launched with (its `metricsSetName`), else every batch metric; a batch's set that the
config lacks is exit 2 (`ConfigMetrics.choose_batch_set`, after the fetch, on its client).
Report mode counts only the batches within the dashboard's `day_range` (days back from
the report's end; `ConfigMetrics.day_range`).

Each job's metadata row is filled from what the mode knows: the job (IDs, experience,
statuses), its batch (name, branch), the batch's build (`build_version`,
`build_creation_timestamp`) and the experience (its tags and custom fields), each
looked up once a run, on the run's client. An experience the API no longer has (404)
gives its jobs no tags and no custom fields, said once. Jobs are added in listing order
(batches oldest first), whatever order their downloads finish in, so that the same
inputs give the same bytes.
"""

from __future__ import annotations

import asyncio
import shutil
import time
import uuid
from collections.abc import Awaitable, Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import structlog

from stook.service.api import ApiClient, Batch, Build, Job, NotFoundError
from stook.service.fetch import JobEmissions, fetch_emissions
from stook.service.modes._config import StookConfig
from stook.service.modes._errors import ConfigError
from stook.service.modes._inputs import TestInputs

if TYPE_CHECKING:
    from stook.sdk import MetricsWriter
    from stook.service.metrics_config import EmissionsSet, Evaluation, JobMeta, MetricsConfig

__all__ = [
    "ConfigMetrics",
    "JobRows",
    "MetricsConfigSettings",
    "MetricsConfigSettingsError",
    "TestConfigMetrics",
    "parse_metrics_config",
]

log = structlog.get_logger("stook.metrics_config")

EMISSIONS_NAME = "emissions.resim.jsonl"
Level = Literal["batch", "dashboard"]
_NEVER = datetime.min.replace(tzinfo=UTC)
_KEYS = {"paths", "metrics_set", "templates", "emissions", "strict"}


# --- the [metrics_config] table ---------------------------------------------------------


class MetricsConfigSettingsError(ValueError):
    """The table is malformed; the caller names the file."""


@dataclass(frozen=True, slots=True)
class MetricsConfigSettings:
    paths: tuple[str, ...]
    metrics_set: str | None = None
    templates: str | None = None
    emissions: str | None = None
    strict: bool = False

    def config_paths(self, base: Path | None) -> list[Path]:
        return [_resolve(p, base) for p in self.paths]

    def templates_path(self, base: Path | None) -> Path | None:
        return None if self.templates is None else _resolve(self.templates, base)

    def emissions_path(self, base: Path | None) -> Path | None:
        return None if self.emissions is None else _resolve(self.emissions, base)


def _resolve(path: str, base: Path | None) -> Path:
    given = Path(path)
    return given if given.is_absolute() or base is None else base / given


def parse_metrics_config(table: Mapping[str, Any]) -> MetricsConfigSettings:
    extra = set(table) - _KEYS
    if extra:
        known = ", ".join(sorted(_KEYS))
        raise MetricsConfigSettingsError(f"unknown key {sorted(extra)[0]!r} (known: {known})")
    paths = table.get("paths")
    if isinstance(paths, str):
        paths = [paths]
    if not paths or not isinstance(paths, list) or not all(isinstance(p, str) for p in paths):
        raise MetricsConfigSettingsError("'paths' must be a non-empty list of config files")
    for key in ("metrics_set", "templates", "emissions"):
        if key in table and not isinstance(table[key], str):
            raise MetricsConfigSettingsError(f"{key!r} must be a string")
    if not isinstance(table.get("strict", False), bool):
        raise MetricsConfigSettingsError("'strict' must be true or false")
    return MetricsConfigSettings(
        paths=tuple(paths),
        metrics_set=table.get("metrics_set"),
        templates=table.get("templates"),
        emissions=table.get("emissions"),
        strict=table.get("strict", False),
    )


# --- test mode ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class TestConfigMetrics:
    """The loaded config and where the test's emissions are; built before any work, so
    that a bad config is exit 2 before the user's function runs."""

    config: MetricsConfig
    emissions: Path
    metrics_set: str | None
    strict: bool = False

    @classmethod
    def load(
        cls, settings: MetricsConfigSettings, base: Path | None, inputs: TestInputs
    ) -> TestConfigMetrics:
        from stook.service.metrics_config import load_config

        config = load_config(settings.config_paths(base), settings.templates_path(base))
        config.metrics_for("test", settings.metrics_set)  # an unknown set: exit 2 now
        emissions = settings.emissions_path(base) or inputs.logs_dir / EMISSIONS_NAME
        return cls(config, emissions, settings.metrics_set, settings.strict)

    def write_into(self, writer: MetricsWriter, outputs: Path) -> None:
        """Evaluate into `writer`; attached files (images) are copied into `outputs`."""
        from stook.service.metrics_config import EmissionsError, EmissionsSet, JobMeta, evaluate

        emissions = EmissionsSet(self.config)
        found = self.emissions.is_file()
        if not found:
            # As on the platform: a test that emitted nothing has no rows.
            log.warning("no emissions file; config metrics see no rows", path=str(self.emissions))
        emissions.add_job(JobMeta(job_id=str(writer.job_id)), self.emissions if found else None)
        result = evaluate(
            self.config,
            emissions.tables(),
            writer,
            level="test",
            metrics_set=self.metrics_set,
            strict=self.strict,
            attached=lambda name: (self.emissions.parent / name).is_file(),
        )
        _say_failures(result)
        for name in result.files:
            source = self.emissions.parent / name
            if not source.is_file():
                raise EmissionsError(f"attached file {name!r} is not beside {self.emissions}")
            shutil.copyfile(source, outputs / name)
        log.info("config metrics evaluated", written=len(result.written), hidden=len(result.hidden))


def _say_failures(result: Evaluation) -> None:
    """Each metric written as an error, said once (with `strict`, the first one raised)."""
    for failure in result.failed:
        log.warning("config metric written as an error", metric=failure.metric, error=str(failure))


# --- batch and report mode ------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class ConfigMetrics:
    """A batch run's `batch` metrics or a report run's `dashboard` metrics, loaded and
    checked before the first request; `wanted` says whether the run needs any emissions."""

    config: MetricsConfig
    metrics_set: str | None
    level: Level
    strict: bool = False
    # Report mode: how many days back from the report's end its dashboard covers (None:
    # every batch of the report).
    day_range: int | None = None
    source: str = "stook.toml"

    @classmethod
    def load(cls, config: StookConfig, level: Level) -> ConfigMetrics | None:
        """None when stook.toml has no `[metrics_config]`; a bad config raises
        MetricsConfigError (exit 2), an unknown `metrics_set` ConfigError (exit 2)."""
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
                f"{config.source}: [metrics_config] metrics_set {chosen!r} is not a metrics "
                f"set of the config (known: {known})"
            )
        days = _day_range(loaded, chosen, config.source) if level == "dashboard" else None
        return cls(loaded, chosen, level, settings.strict, days, config.source)

    @property
    def wanted(self) -> bool:
        """Whether the level has metrics to evaluate: without any, no log is downloaded."""
        return bool(self.config.metrics_for(self.level, self.metrics_set))

    def rows(self, api: ApiClient, project_id: uuid.UUID) -> JobRows:
        """Where the run's jobs' emissions go, on the run's client (its lookups too)."""
        return JobRows(self.config, api, project_id, metrics_set=self.metrics_set)

    async def choose_batch_set(self, rows: JobRows, batch_id: uuid.UUID) -> None:
        """Batch mode, once its fetch is done: without `[metrics_config] metrics_set`, the
        set the batch was launched with (its `metricsSetName`; the batch as the rows
        looked it up, else asked for once). A set the config lacks is ConfigError."""
        if self.metrics_set is not None:
            return
        batch = await rows.batch(batch_id)
        chosen = batch.metrics_set_name
        if chosen is None:
            return
        if chosen not in self.config.metrics_sets:
            known = ", ".join(sorted(self.config.metrics_sets)) or "none"
            raise ConfigError(
                f"batch {batch_id} was launched with metrics set {chosen!r}, which the "
                f"config of {self.source} [metrics_config] lacks (known: {known}); name "
                "one with [metrics_config] metrics_set"
            )
        log.info("config metrics: the batch's own metrics set", metrics_set=chosen)
        rows.metrics_set = chosen

    def write(self, rows: JobRows | None, writer: MetricsWriter) -> None:
        """Evaluate the level's metrics over the rows into `writer` (none: nothing)."""
        if rows is None:
            return
        from stook.service.metrics_config import evaluate

        started = time.perf_counter()
        result = evaluate(
            self.config,
            rows.emissions.tables(),
            writer,
            level=self.level,
            metrics_set=rows.metrics_set,
            strict=self.strict,
        )
        _say_failures(result)
        log.info(
            "config metrics written",
            level=self.level,
            jobs=rows.jobs,
            jobs_with_emissions=rows.with_log,
            metrics=len(result.written),
            hidden=len(result.hidden),
            # The rows' check and load, and the queries: after the fetch, on this CPU.
            seconds=round(time.perf_counter() - started, 3),
        )

    async def fetch_report_rows(
        self,
        api: ApiClient,
        project_id: uuid.UUID,
        batches: Sequence[Batch],
        end: datetime | None = None,
    ) -> JobRows:
        """Report mode: every job of the report's `batches` (as its fetch found them) with
        its emissions, listed and downloaded on `api`; with a `day_range`, only those of
        the batches created within that many days before `end` (the report's end)."""
        if self.day_range is not None and end is not None:
            since = end - timedelta(days=self.day_range)
            kept = [
                b for b in batches if b.creation_timestamp is None or b.creation_timestamp >= since
            ]
            log.info(
                "config metrics: the dashboard's day range",
                day_range=self.day_range,
                since=since.isoformat(),
                batches=len(kept),
                left_out=len(batches) - len(kept),
            )
            batches = kept
        # Oldest first (the API lists newest first); by ID among equal times.
        ordered = sorted(batches, key=lambda b: (b.creation_timestamp or _NEVER, str(b.batch_id)))
        listings = await asyncio.gather(
            *(_all_jobs(api, project_id, batch.batch_id) for batch in ordered)
        )
        listed = [(b, job) for b, jobs in zip(ordered, listings, strict=True) for job in jobs]
        rows = self.rows(api, project_id)
        try:
            await fetch_emissions(
                api,
                project_id,
                list(enumerate(listed)),
                ids_of=lambda item: (item[1][0].batch_id, item[1][1].job_id),
                on_job=lambda item, payload: rows.add(
                    JobEmissions(item[0], item[1][0].batch_id, item[1][1], payload),
                    batch=item[1][0],
                ),
            )
        finally:
            await rows.aclose()
        return rows


def _day_range(config: MetricsConfig, chosen: str | None, source: str) -> int | None:
    """The days a report's dashboard metrics cover: the `day_range` of the dashboards that
    show `chosen` (without a set: of every dashboard); None when none gives one (every
    batch of the report counts). Two different ranges are refused before the first
    request: which one the report stands for cannot be told."""
    shown = [d for d in config.dashboards.values() if chosen is None or d.metrics_set == chosen]
    ranged = sorted((d.day_range, d.name, d.metrics_set) for d in shown if d.day_range is not None)
    if len({days for days, _, _ in ranged}) > 1:
        named = " and ".join(f"{name!r} ({days} days)" for days, name, _ in ranged)
        which = f"metrics set {chosen!r}" if chosen is not None else "the dashboard metrics"
        sets = {metrics_set for _, _, metrics_set in ranged}
        hint = (
            "; name one's metrics set with [metrics_config] metrics_set"
            if chosen is None and len(sets) == len(ranged)
            else ""
        )
        raise ConfigError(
            f"{source}: [metrics_config]: dashboards {named} show {which} over different "
            f"day ranges, so which one the report stands for cannot be told{hint}"
        )
    return ranged[0][0] if ranged else None


async def _all_jobs(api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID) -> list[Job]:
    return [job async for job in api.list_jobs(project_id, batch_id)]


_K = TypeVar("_K", bound=Hashable)
_V = TypeVar("_V")


class _Once:
    """Each key's lookup run once, as a task of its own shielded from the jobs waiting for
    it (one job cancelled must not cancel what the others wait on)."""

    def __init__(self) -> None:
        self._tasks: dict[Hashable, asyncio.Task[Any]] = {}

    async def get(self, key: _K, look_up: Callable[[_K], Awaitable[_V]]) -> _V:
        task = self._tasks.get(key)
        if task is None:

            async def run() -> _V:
                return await look_up(key)

            task = self._tasks[key] = asyncio.create_task(run())
        result: _V = await asyncio.shield(task)
        return result

    async def aclose(self) -> None:
        pending = [task for task in self._tasks.values() if not task.done()]
        for task in pending:
            task.cancel()
        await asyncio.gather(*pending, return_exceptions=True)
        for task in self._tasks.values():  # a failure nobody awaited is no "never retrieved"
            if task.done() and not task.cancelled():
                task.exception()


class JobRows:
    """The emissions of a run's jobs with their metadata rows, added in listing order.

    `add` takes each job's emissions as its download finishes; a job that finished early
    waits (its bytes only) for those listed before it. What is still waiting at `aclose`
    (after a job that could not be fetched: a missing job) is added in order then.
    """

    def __init__(
        self,
        config: MetricsConfig,
        api: ApiClient,
        project_id: uuid.UUID,
        *,
        metrics_set: str | None = None,
    ) -> None:
        from stook.service.metrics_config import EmissionsSet

        self.emissions: EmissionsSet = EmissionsSet(config)
        self.jobs = 0
        self.with_log = 0
        self.metrics_set = metrics_set  # what the evaluation runs (None: the whole level)
        self._api = api
        self._project_id = project_id
        self._waiting: dict[int, tuple[JobMeta, bytes | None, str]] = {}
        self._next = 0
        self._batches, self._builds, self._experiences, self._branches = (_Once() for _ in range(4))

    async def batch(self, batch_id: uuid.UUID) -> Batch:
        """The batch, asked for once a run."""
        return await self._batches.get(batch_id, self._get_batch)

    async def add(self, emitted: JobEmissions, *, batch: Batch | None = None) -> None:
        """One job's emissions; `batch`: its batch as listed (else it is asked for once)."""
        if batch is None:
            batch = await self.batch(emitted.batch_id)
        meta = await self._meta(batch, emitted.job)
        name = f"job {emitted.job.job_id} emissions log"
        self._waiting[emitted.index] = (meta, emitted.payload, name)
        while self._next in self._waiting:
            self._add(*self._waiting.pop(self._next))
            self._next += 1

    async def aclose(self) -> None:
        """Add what is still waiting, in listing order; stop the lookups still running."""
        for index in sorted(self._waiting):
            self._add(*self._waiting.pop(index))
        for once in (self._batches, self._builds, self._experiences, self._branches):
            await once.aclose()

    def _add(self, meta: JobMeta, payload: bytes | None, name: str) -> None:
        self.emissions.add_job(meta, payload, name=name)
        self.jobs += 1
        self.with_log += payload is not None

    async def _get_batch(self, batch_id: uuid.UUID) -> Batch:
        return await self._api.get_batch(self._project_id, batch_id)

    async def _build(self, build_id: uuid.UUID) -> Build:
        return await self._api.get_build(self._project_id, build_id)

    async def _experience(self, experience_id: uuid.UUID) -> _ExperienceFacts:
        """The experience's tags and custom fields: both asked for at once."""
        project_id = self._project_id

        async def tag_names() -> tuple[str, ...]:
            found = self._api.list_experience_tags(project_id, experience_id)
            return tuple(sorted([tag.name async for tag in found]))

        listing = asyncio.create_task(tag_names())  # side by side with the experience
        try:
            experience = await self._api.get_experience(project_id, experience_id)
        except BaseException as exc:
            listing.cancel()
            await asyncio.gather(listing, return_exceptions=True)
            if not isinstance(exc, NotFoundError):
                raise
            # The jobs still have their rows, without what only the experience knew.
            log.warning(
                "experience not found; its jobs' metadata rows have no tags and no custom fields",
                experience_id=str(experience_id),
            )
            return _ExperienceFacts()
        tags = await listing
        keys: list[str] = []
        values: list[str] = []
        for custom in experience.fields:
            for value in custom.texts:  # one pair per value: a field of several repeats its key
                keys.append(custom.name)
                values.append(value)
        return _ExperienceFacts(tags, tuple(keys), tuple(values))

    async def _branch_names(self, _: None) -> dict[uuid.UUID, str]:
        return {b.branch_id: b.name async for b in self._api.list_branches(self._project_id)}

    async def _meta(self, batch: Batch, job: Job) -> JobMeta:
        from stook.service.metrics_config import JobMeta

        build_id = job.build_id or batch.build_id
        build = None if build_id is None else await self._builds.get(build_id, self._build)
        branch = None
        if batch.branch_id is not None:
            branch = (await self._branches.get(None, self._branch_names)).get(batch.branch_id)
        facts = _ExperienceFacts()
        if job.experience_id:
            facts = await self._experiences.get(job.experience_id, self._experience)
        return JobMeta(
            job_id=str(job.job_id),
            batch_id=str(batch.batch_id),
            project_id=str(self._project_id),
            experience_id=_text(job.experience_id),
            experience_name=job.experience_name,
            build_id=_text(build_id),
            build_version=None if build is None else build.version,
            batch_name=batch.friendly_name,
            job_status=_text(job.job_status),
            job_conflated_status=_text(job.conflated_status),
            branch=branch,
            tags=facts.tags,
            custom_field_keys=facts.custom_field_keys,
            custom_field_values=facts.custom_field_values,
            build_creation_timestamp=None
            if build is None
            else _naive_utc(build.creation_timestamp),
        )


@dataclass(frozen=True, slots=True)
class _ExperienceFacts:
    """What a job's metadata row holds of its experience."""

    tags: tuple[str, ...] = ()
    custom_field_keys: tuple[str, ...] = ()
    custom_field_values: tuple[str, ...] = ()


def _text(value: object) -> str | None:
    return None if value is None else str(value)


def _naive_utc(moment: datetime | None) -> datetime | None:
    """A time as the metadata column holds it: UTC, without a zone."""
    if moment is None:
        return None
    utc = moment.astimezone(UTC)
    return datetime(utc.year, utc.month, utc.day, utc.hour, utc.minute, utc.second, utc.microsecond)
