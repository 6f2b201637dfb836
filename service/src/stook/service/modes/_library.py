"""stook as a library: a batch's jobs or a report's batches, fetched the way `stook run` does.

`fetch_batch` and `fetch_report` are async iterators on the same bounded, retrying fetch
cores as batch and report mode (`BatchFetcher`, `ReportFetcher`); `fetch_batch_frame` is
the synchronous one-call version, a polars DataFrame with one row per job. Each takes
where the batch is as the platform gives it (its inputs folder, or one of its config
files) or as access keywords (`api_url`, `token`, `project_id`, `batch_id`/`report_id`),
and the `[fetch]` settings as keywords, checked before the first request.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import uuid
from collections.abc import AsyncGenerator, Awaitable, Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import structlog

from stook.sdk.aggregations import BatchRecord, JobRecord, Needs
from stook.service.fetch import (
    BatchFetcher,
    MissingJob,
    ReportFetcher,
)
from stook.service.modes._config import FetchSettings, parse
from stook.service.modes._errors import InputsError
from stook.service.modes._event_loop import run_on_event_loop
from stook.service.modes._inputs import (
    BATCH_CONFIG,
    REPORT_CONFIG,
    ApiAccess,
    BatchInputs,
    ReportInputs,
    detect,
)
from stook.service.modes._logging import configure_logging
from stook.service.modes._pipeline import check_missing, fetch_records

if TYPE_CHECKING:
    import polars as pl

__all__ = ["fetch_batch", "fetch_batch_frame", "fetch_report"]

log = structlog.get_logger("stook.library")

Source = str | os.PathLike[str] | ApiAccess | None
# Columns every frame has, before the scalars; a scalar or series may not take these names.
_JOB_COLUMNS = ("job_id", "experience_name", "experience_id", "conflated_status")
_PARAMETER_PREFIX = "parameters."


def _default_logging() -> None:
    """structlog left unconfigured prints every debug line of the fetch to stdout, unredacted
    by stook's processors; a program that did not configure it gets stook's own set-up,
    warnings and errors only, on stderr."""
    if not structlog.is_configured():
        configure_logging(level="warning")


def _settings(**given: Any) -> FetchSettings:
    """`[fetch]` settings from keywords, checked as stook.toml's are (ConfigError, exit 2)."""
    table = {key: value for key, value in given.items() if value is not None}
    return parse({"fetch": table}, source="fetch settings").fetch


def _access(
    source: Source,
    api_url: str | None,
    token: str | None,
    project_id: uuid.UUID | str | None,
) -> tuple[ApiAccess | None, BatchInputs | ReportInputs | None]:
    """Access and (when the platform's files gave them) the inputs, from `source`."""
    if source is not None and (api_url is not None or token is not None):
        raise InputsError("give either a source or api_url and token, not both")
    if isinstance(source, ApiAccess):
        return source, None
    project = _uuid("project_id", project_id) if project_id is not None else None
    if source is not None:
        inputs = _platform_inputs(Path(source), project)
        return inputs.access, inputs
    if api_url is None or token is None or project is None:
        lacking = [
            name
            for name, value in (("api_url", api_url), ("token", token), ("project_id", project))
            if value is None
        ]
        raise InputsError(
            "say where the batch is: an inputs folder or config file, an ApiAccess, or "
            f"api_url, token and project_id (missing: {', '.join(lacking)})"
        )
    return ApiAccess(api_url=api_url.rstrip("/"), token=token, project_id=project), None


def _platform_inputs(path: Path, project_id: uuid.UUID | None) -> BatchInputs | ReportInputs:
    if path.is_dir():
        found = detect(path, project_id=project_id)
        if isinstance(found, BatchInputs | ReportInputs):
            return found
        raise InputsError(
            f"inputs folder {str(path)!r} has neither {BATCH_CONFIG} nor {REPORT_CONFIG}"
        )
    if not path.is_file():
        raise InputsError(f"{str(path)!r} is neither an inputs folder nor a config file")
    # One config file, read as the platform's folder would be: under its own name, so that
    # its errors name it. A file named otherwise counts as what its keys say it is.
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        doc = None
    name = path.name
    if name not in (BATCH_CONFIG, REPORT_CONFIG):
        name = REPORT_CONFIG if isinstance(doc, dict) and "reportID" in doc else BATCH_CONFIG
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / name).write_bytes(path.read_bytes())
        found = detect(Path(tmp), project_id=project_id)
    assert isinstance(found, BatchInputs | ReportInputs)
    return found


def _uuid(what: str, value: uuid.UUID | str) -> uuid.UUID:
    if isinstance(value, uuid.UUID):
        return value
    try:
        return uuid.UUID(str(value))
    except ValueError:
        raise InputsError(f"{what} is not a UUID: {str(value)[:40]!r}") from None


def _batch_target(
    source: Source,
    api_url: str | None,
    token: str | None,
    project_id: uuid.UUID | str | None,
    batch_id: uuid.UUID | str | None,
) -> tuple[ApiAccess, uuid.UUID]:
    access, inputs = _access(source, api_url, token, project_id)
    assert access is not None
    if batch_id is not None:
        return access, _uuid("batch_id", batch_id)
    if isinstance(inputs, BatchInputs):
        return access, inputs.batch_id
    if isinstance(inputs, ReportInputs):
        raise InputsError(f"{REPORT_CONFIG} names a report, not a batch: use fetch_report")
    raise InputsError("batch_id is required with explicit access")


def _report_target(
    source: Source,
    api_url: str | None,
    token: str | None,
    project_id: uuid.UUID | str | None,
    report_id: uuid.UUID | str | None,
) -> tuple[ApiAccess, uuid.UUID]:
    access, inputs = _access(source, api_url, token, project_id)
    assert access is not None
    if report_id is not None:
        return access, _uuid("report_id", report_id)
    if isinstance(inputs, ReportInputs):
        return access, inputs.report_id
    if isinstance(inputs, BatchInputs):
        raise InputsError(f"{BATCH_CONFIG} names a batch, not a report: use fetch_batch")
    raise InputsError("report_id is required with explicit access")


@dataclass(frozen=True, slots=True)
class _Handover:
    """Where a fetch hands its records to the iterator: `put` waits while the buffer is
    full (back-pressure); `put_nowait` is for callbacks that cannot wait (report mode,
    whose batches are few and small; its buffer is unbounded)."""

    queue: asyncio.Queue[tuple[bool, Any]]

    async def put(self, record: Any) -> None:
        await self.queue.put((True, record))

    def put_nowait(self, record: Any) -> None:
        self.queue.put_nowait((True, record))


async def _stream(
    run: Callable[[_Handover], Awaitable[None]], buffer: int
) -> AsyncGenerator[Any, None]:
    """The records `run` hands over, as an async iterator.

    `run` runs in a task of its own, handing each record into a queue of `buffer` records
    (0: unbounded). Leaving early (break, an exception in the loop, `aclose`) cancels that
    task, which closes the client and its sessions before this generator is done.
    """
    queue: asyncio.Queue[tuple[bool, Any]] = asyncio.Queue(maxsize=buffer)
    done = object()

    async def produce() -> None:
        try:
            await run(_Handover(queue))
        except Exception as exc:  # handed to the consumer, raised there
            await queue.put((False, exc))
            return
        await queue.put((False, done))

    producer = asyncio.create_task(produce())
    try:
        while True:
            ok, item = await queue.get()
            if ok:
                yield item
                continue
            if item is done:
                return
            raise item
    finally:
        if not producer.done():
            producer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await producer


def _left_out(missing: list[MissingJob], total: int, allowed: int, what: str) -> None:
    """The library's missing-jobs rule: at most `allowed` jobs, each said as left out."""
    for job in check_missing(missing, total, allowed_jobs=allowed, what=what):
        log.warning("job left out", job_id=str(job.job_id), reason=job.reason)


def fetch_batch(
    source: Source = None,
    *,
    needs: Needs = Needs(),  # noqa: B008 - frozen, so one shared default is safe
    api_url: str | None = None,
    token: str | None = None,
    project_id: uuid.UUID | str | None = None,
    batch_id: uuid.UUID | str | None = None,
    concurrency: int | None = None,
    retry_for: float | None = None,
    timeout: float | None = None,
    deadline: float | None = None,
    page_size: int | None = None,
    adaptive: bool | None = None,
    allow_missing: int = 0,
) -> AsyncGenerator[JobRecord, None]:
    """Every job of a batch as a `JobRecord`, in the order they complete.

    `source` is the platform's inputs folder, its ``batch_metrics_config.json``, or an
    `ApiAccess`; or leave it out and give `api_url`, `token`, `project_id` and
    `batch_id`. `needs` says what to download beyond the job listing and its scalars
    (`Needs(data=..., metrics=..., every_metric=..., events=..., experience_tags=...)`).
    The fetch settings are `[fetch]`'s, same defaults. A job whose fetch fails after
    retries is left out with a warning while at most `allow_missing` jobs are; beyond
    that the iterator raises `MissingJobsError` at its end. Settings and inputs are
    checked here, before any request (`ConfigError`, `InputsError`); the API's failures
    are stook's `ApiError`s, storage's `StorageError`s, undecodable data `InvalidDataError`.

    Break out of the loop at any time: the fetch stops and its client closes (at once
    under ``contextlib.aclosing``, else when the iterator is collected).
    """
    settings = _settings(
        concurrency=concurrency,
        retry_for=retry_for,
        timeout=timeout,
        deadline=deadline,
        page_size=page_size,
        adaptive=adaptive,
    )
    access, batch = _batch_target(source, api_url, token, project_id, batch_id)
    _default_logging()

    async def run(hand_over: _Handover) -> None:
        outcome, _ = await fetch_records(
            access,
            settings,
            lambda api: BatchFetcher(api, access.project_id, batch, needs),
            hand_over.put,
            started=asyncio.get_running_loop().time(),
            how_far=lambda o: f"{o.jobs_done:,} of {o.jobs_listed:,} jobs",
        )
        _left_out(outcome.missing, outcome.jobs_listed, allow_missing, f"batch {batch}")

    return _stream(run, settings.concurrency)


def fetch_report(
    source: Source = None,
    *,
    needs: Needs = Needs(),  # noqa: B008 - frozen, so one shared default is safe
    api_url: str | None = None,
    token: str | None = None,
    project_id: uuid.UUID | str | None = None,
    report_id: uuid.UUID | str | None = None,
    concurrency: int | None = None,
    retry_for: float | None = None,
    timeout: float | None = None,
    deadline: float | None = None,
    page_size: int | None = None,
    adaptive: bool | None = None,
    allow_missing: int = 0,
) -> AsyncGenerator[BatchRecord, None]:
    """Every batch of a report as a `BatchRecord`, each once all of its jobs are in.

    As `fetch_batch`, with ``report_config.json`` or `report_id`. `Needs(job_metrics=True)`
    adds each batch's jobs' scalar metrics (one request per job).
    """
    settings = _settings(
        concurrency=concurrency,
        retry_for=retry_for,
        timeout=timeout,
        deadline=deadline,
        page_size=page_size,
        adaptive=adaptive,
    )
    access, report = _report_target(source, api_url, token, project_id, report_id)
    _default_logging()

    async def run(hand_over: _Handover) -> None:
        outcome, _ = await fetch_records(
            access,
            settings,
            lambda api: ReportFetcher(api, access.project_id, report, needs),
            hand_over.put_nowait,
            started=asyncio.get_running_loop().time(),
            how_far=lambda o: f"{o.jobs:,} jobs of {o.batches:,} batches",
        )
        _left_out(outcome.missing, outcome.jobs, allow_missing, f"report {report}")

    return _stream(run, 0)


def fetch_batch_frame(
    source: Source = None,
    *,
    series: Iterable[str] = (),
    parameters: bool = True,
    needs: Needs = Needs(),  # noqa: B008 - frozen, so one shared default is safe
    **fetch: Any,
) -> pl.DataFrame:
    """A batch as a polars DataFrame, one row per job, sorted by job ID.

    Columns: ``job_id``, ``experience_name``, ``experience_id`` (String),
    ``conflated_status``; with `parameters`, one String column ``parameters.<name>`` per
    job parameter (null where a job lacks it); one Float64 column per SCALAR metric
    (null where a job lacks it), by metric name, sorted; and for each name in `series`
    a List(Float64) column of that plain double metrics data (null where a job lacks it).
    Takes `fetch_batch`'s arguments; runs its own event loop (call it from synchronous
    code; inside a running loop, use `fetch_batch`).
    """
    wanted = tuple(dict.fromkeys(series))
    clash = sorted(set(wanted) & set(_JOB_COLUMNS))
    if clash:
        raise ValueError(f"series {clash[0]!r} has the name of a job column")
    stream_needs = needs | Needs(data=frozenset(wanted), every_scalar=True)
    stream = fetch_batch(source, needs=stream_needs, **fetch)

    async def collect() -> list[JobRecord]:
        async with contextlib.aclosing(stream) as records:
            return [record async for record in records]

    return _frame(run_on_event_loop(collect()), wanted, parameters=parameters)


def _frame(records: list[JobRecord], series: tuple[str, ...], *, parameters: bool) -> pl.DataFrame:
    import polars as pl

    records.sort(key=lambda r: str(r.job_id))
    scalar_names = sorted({name for r in records for name in r.scalars})
    parameter_names = sorted({name for r in records for name in r.parameters}) if parameters else []
    clash = sorted(set(scalar_names) & (set(series) | set(_JOB_COLUMNS)))
    if clash:
        raise ValueError(f"scalar metric {clash[0]!r} and a series or job column share a name")
    columns: dict[str, pl.Series] = {
        "job_id": pl.Series([str(r.job_id) for r in records], dtype=pl.String),
        "experience_name": pl.Series([r.experience_name for r in records], dtype=pl.String),
        "experience_id": pl.Series(
            [str(r.experience_id) if r.experience_id else None for r in records], dtype=pl.String
        ),
        "conflated_status": pl.Series([r.conflated_status for r in records], dtype=pl.String),
    }
    for name in parameter_names:
        columns[_PARAMETER_PREFIX + name] = pl.Series(
            [r.parameters.get(name) for r in records], dtype=pl.String
        )
    for name in scalar_names:
        columns[name] = pl.Series(
            [s.value if (s := r.scalars.get(name)) else None for r in records], dtype=pl.Float64
        )
    for name in series:
        columns[name] = pl.Series(
            [_values(r.series.get(name)) for r in records], dtype=pl.List(pl.Float64)
        )
    return pl.DataFrame(columns)


def _values(series: pl.Series | None) -> list[float] | None:
    return None if series is None else series.to_list()
