"""The one pipeline of batch and report mode: open the API, fetch, fold, check, write.

A mode supplies what differs (:class:`Mode`): its aggregations, its fetcher, how far a run
got, the names it checks and the texts it writes before the aggregations. The steps and
their order are here, once: the client configured from ``[fetch]``, the deadline, the
progress display, every record folded into every aggregation as it arrives, the name checks
after the fetch, the missing-jobs rule, then the aggregations' metrics and one atomic
write of ``metrics.binproto``.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, Protocol, TypeVar

import structlog

from stook.sdk import MetricStatus
from stook.sdk.aggregations import Aggregation, Needs
from stook.service.api import ApiClient, ApiError, RetryPolicy
from stook.service.fetch import MissingJob, fetch_deadline
from stook.service.modes._config import FetchSettings
from stook.service.modes._config_metrics import ConfigMetricsStep, write_config_metrics
from stook.service.modes._inputs import ApiAccess
from stook.service.modes._open_api import HasTraffic, Traffic, open_api
from stook.service.modes._progress import NoProgress, Progress, Snapshot

if TYPE_CHECKING:
    # The writer (and protobuf with it) is imported once the fetch is done: see run_pipeline.
    from stook.sdk import MetricsWriter

log = structlog.get_logger("stook.pipeline")

OUTPUT_NAME = "metrics.binproto"
# The shortest time between two progress snapshots (the last one is always shown).
_SHOW_EVERY_S = 0.05

_R = TypeVar("_R")  # what the fetcher hands over: a job's record, or a batch's
_O = TypeVar("_O")  # what the fetcher saw: counts, names, missing jobs
_R_co = TypeVar("_R_co", covariant=True)
_O_co = TypeVar("_O_co", covariant=True)


class MissingJobsError(ApiError):
    """More jobs stayed unavailable than --allow-missing-jobs allows (exit code 3)."""


class Fetcher(Protocol[_R_co, _O_co]):
    """Fetches records and hands each to `on_record` as it is complete."""

    @property
    def outcome(self) -> _O_co:
        """What the fetch has seen so far (complete once `run` returns)."""
        ...

    async def run(self, on_record: Callable[[_R_co], None], /) -> _O_co: ...


class Mode(Protocol[_R, _O]):
    """The pieces of a run that batch and report mode do differently."""

    @property
    def kind(self) -> str:
        """ "batch" or "report": names the run in log events."""
        ...

    @property
    def output_id(self) -> uuid.UUID:
        """The ID the output's metrics are written under."""
        ...

    @property
    def aggregations(self) -> Sequence[Aggregation[_R]]: ...

    def fetcher(
        self, api: ApiClient, needs: Needs, on_progress: Callable[[_O], None]
    ) -> Fetcher[_R, _O]: ...

    def progress(self, outcome: _O) -> Snapshot:
        """Jobs (and batches) done, listed and in all so far, for the progress display."""
        ...

    def how_far(self, outcome: _O, folded: int) -> str:
        """How far the fetch got, for the line a deadline ends the run with."""
        ...

    def counts(self, outcome: _O) -> dict[str, int]:
        """What the final summary event counts."""
        ...

    def missing(self, outcome: _O) -> tuple[list[MissingJob], int]:
        """The jobs that could not be fetched, and how many jobs there were."""
        ...

    def check(self, needs: Needs, outcome: _O) -> None:
        """Refuse names in the config that the fetched data proves wrong (ConfigError)."""
        ...

    def preface(self, writer: MetricsWriter, outcome: _O) -> None:
        """What the output says before the aggregations' metrics."""
        ...

    @property
    def config_metrics(self) -> ConfigMetricsStep | None:
        """The config-defined metrics ([metrics_config]), written after the aggregations'."""
        ...


@dataclass(frozen=True, slots=True)
class RunResult(HasTraffic, Generic[_O]):
    """What a batch or report run wrote, and what its fetch saw."""

    kind: str
    output: Path
    outcome: _O
    metrics_written: list[str]
    status: MetricStatus
    traffic: Traffic
    counts: dict[str, int]
    seconds: float


def needs_of(aggregations: Sequence[Aggregation[Any]]) -> Needs:
    """Everything the aggregations read, so that the fetch downloads no more than that."""
    needs = Needs()
    for aggregation in aggregations:
        needs = needs | aggregation.needs()
    return needs


@dataclass(frozen=True, slots=True)
class FetchRun(Generic[_R, _O]):
    """What a fetch-and-fold step is given: the mode, what to fetch and how, and when the run
    started (the event loop's clock, for the deadline)."""

    mode: Mode[_R, _O]
    needs: Needs
    access: ApiAccess
    settings: FetchSettings
    retry: RetryPolicy | None
    progress: Progress
    started: float


class FetchStep(Protocol):
    """The fetch-and-fold step of the pipeline: every record folded into the mode's
    aggregations, and what the fetch saw. `fetch_here` does it in this process; the
    engines of modes/_engine.py split it into shards folded elsewhere and merged here."""

    async def __call__(self, run: FetchRun[_R, _O], /) -> tuple[_O, Traffic]: ...


async def run_pipeline(
    mode: Mode[_R, _O],
    access: ApiAccess,
    settings: FetchSettings,
    outputs_dir: Path,
    *,
    allow_missing_jobs: float = 0.0,
    retry: RetryPolicy | None = None,
    progress: Progress | None = None,
    fetch: FetchStep | None = None,
) -> RunResult[_O]:
    """Fetch, fold, check and write one run of `mode`; raises the typed errors of each step.

    `fetch` is the fetch-and-fold step (default: `fetch_here`, in this process).
    """
    started = asyncio.get_running_loop().time()
    needs = needs_of(mode.aggregations)
    step: FetchStep = fetch or fetch_here
    outcome, traffic = await step(
        FetchRun(mode, needs, access, settings, retry, progress or NoProgress(), started)
    )

    mode.check(needs, outcome)
    # Imported here, not with this module: `stook run` sends its first request sooner
    # without the writer's modules and protobuf, which nothing needs before the output.
    from stook.sdk import MetricsWriter

    writer = MetricsWriter(mode.output_id, deterministic=True)
    missing, jobs = mode.missing(outcome)
    write_missing_jobs(writer, missing, jobs, allow_missing_jobs)
    mode.preface(writer, outcome)
    for aggregation in mode.aggregations:
        aggregation.finish(writer)
    await write_config_metrics(mode.config_metrics, writer, settings, retry, started=started)
    output = writer.write(outputs_dir / OUTPUT_NAME)
    return RunResult(
        kind=mode.kind,
        output=output,
        outcome=outcome,
        metrics_written=[m.name for m in writer.metrics],
        status=writer.status,
        traffic=traffic,
        counts=mode.counts(outcome),
        seconds=asyncio.get_running_loop().time() - started,
    )


async def fetch_here(run: FetchRun[_R, _O]) -> tuple[_O, Traffic]:
    """The fetch and fold in this process: every record folded as it arrives."""
    mode, settings = run.mode, run.settings
    folded = 0
    # Bound once: the same aggregations fold every record.
    updates = [aggregation.update for aggregation in mode.aggregations]

    def fold(record: _R) -> None:
        nonlocal folded
        folded += 1
        for update in updates:
            update(record)

    log.info(
        f"{mode.kind} fetch starting",
        **{f"{mode.kind}_id": str(mode.output_id)},
        concurrency=settings.concurrency,
        data=sorted(run.needs.data),
    )
    async with open_api(run.access, settings, run.retry) as api:
        shown = run.progress
        clock = asyncio.get_running_loop().time
        last_shown = -_SHOW_EVERY_S

        def report(outcome: _O, *, final: bool = False) -> None:
            # Called as each job is listed and done; a display needs a few a second (the
            # bar redraws 4 times a second, events come every 10 s), and a snapshot per
            # call cost ~1 % of the client's CPU at 0 ms latency.
            nonlocal last_shown
            now = clock()
            if now - last_shown < _SHOW_EVERY_S and not final:
                return
            last_shown = now
            show_progress(shown, mode.progress(outcome), Traffic.of(api))

        fetcher = mode.fetcher(api, run.needs, report)
        # Shown each second too, so that the counters (and the progress events off a
        # terminal) go on while no job completes: retries in an outage, a slow page.
        ticker = asyncio.create_task(tick(lambda: report(fetcher.outcome)))
        try:
            async with fetch_deadline(
                settings.deadline,
                started=run.started,
                progress=lambda: mode.how_far(fetcher.outcome, folded),
            ):
                outcome = await fetcher.run(fold)
            report(outcome, final=True)  # the display ends on the complete counts
        finally:
            ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await ticker
            shown.close()
        return outcome, Traffic.of(api)


def show_progress(shown: Progress, snapshot: Snapshot, traffic: Traffic) -> None:
    """One progress update: how far the fetch got, with the traffic's counters."""
    shown.update(
        dataclasses.replace(
            snapshot,
            requests=traffic.requests,
            retries=traffic.retries,
            bytes_received=traffic.bytes_received,
            retrying=traffic.retrying,
        )
    )


async def tick(show: Callable[[], None], every: float = 1.0) -> None:
    while True:
        await asyncio.sleep(every)
        show()


def write_missing_jobs(
    writer: MetricsWriter, missing: list[MissingJob], jobs: int, allowed: float
) -> None:
    """Fail naming the first missing job, or, within the allowed share, say which are missing."""
    if not missing:
        return
    # In job-ID order, whatever order the jobs failed in: the output does not depend on
    # timing, nor on how the jobs were split among processes (modes/_engine.py).
    missing = sorted(missing, key=lambda m: m.job_id)
    share = len(missing) / max(jobs, 1)
    first = missing[0]
    if share > allowed:
        more = f" and {len(missing) - 1} more" if len(missing) > 1 else ""
        # A summary: each job's reason was said once already, in its "unavailable" warning.
        raise MissingJobsError(
            f"job {first.job_id}{more} could not be fetched (see the warnings above); "
            f"{len(missing)} of {jobs} jobs missing, allowed share {allowed:g}"
        )
    lines = [
        f"- {m.job_id} ({m.experience_name or 'unknown experience'}): {m.reason}" for m in missing
    ]
    writer.text(
        "Missing jobs",
        f"{len(missing)} of {jobs} jobs could not be fetched and are left out "
        "of every batch metric:\n" + "\n".join(lines),
        status=MetricStatus.FAIL_WARN,
    )
