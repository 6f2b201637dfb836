"""The steps batch and report mode share: what to fetch, the fetch and fold, the write.

Each mode's run (`run_batch` in _batch.py, `run_report` in _report.py) reads top to
bottom: build its aggregations, fetch every record and fold it into them (`fold_here` in
this process, or `fold_sharded` in modes/_engine.py), check the names the config gave,
then write ``metrics.binproto`` once (`write_output`).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import uuid
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

import structlog

from stook.sdk import MetricStatus, MetricsWriter
from stook.sdk.aggregations import Aggregation, Needs
from stook.service.api import ApiClient, ApiError, RetryPolicy
from stook.service.fetch import MissingJob, fetch_deadline
from stook.service.modes._config import FetchSettings
from stook.service.modes._inputs import ApiAccess
from stook.service.modes._open_api import HasTraffic, Traffic, open_api
from stook.service.modes._progress import Progress, Snapshot

log = structlog.get_logger("stook.run")

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
    """`BatchFetcher` or `ReportFetcher`: hands each record to `on_record` as it is
    complete."""

    @property
    def outcome(self) -> _O_co:
        """What the fetch has seen so far (complete once `run` returns)."""
        ...

    async def run(self, on_record: Callable[[_R_co], None], /) -> _O_co: ...


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
class FetchRun(Generic[_O]):
    """What a run's fetch and fold is given: the aggregations, what to fetch and how, how
    to show progress, and when the run started (the event loop's clock, for the deadline)."""

    kind: str  # "batch" or "report": names the run in log events
    output_id: uuid.UUID
    aggregations: Sequence[Aggregation[Any]]
    needs: Needs
    access: ApiAccess
    settings: FetchSettings
    retry: RetryPolicy | None
    progress: Progress
    snapshot_of: Callable[[_O], Snapshot]  # jobs (and batches) done, listed and in all
    how_far: Callable[[_O, int], str]  # the line a deadline ends the run with
    started: float
    # What the run fetches once the fold is done, on the same client, within the deadline.
    then: Callable[[ApiClient, _O], Awaitable[None]] | None = None
    # Called with the outcome as each job is listed and done; raising ends the run (a
    # misspelt name found by the first jobs' listings).
    check: Callable[[_O], None] | None = None


async def fold_here(
    run: FetchRun[_O], fetcher_for: Callable[[ApiClient, Callable[[_O], None]], Fetcher[Any, _O]]
) -> tuple[_O, Traffic]:
    """The fetch and fold in this process: every record folded as it arrives.

    `fetcher_for(api, on_progress)` makes the mode's fetcher."""
    folded = 0
    # Bound once: the same aggregations fold every record.
    updates = [aggregation.update for aggregation in run.aggregations]

    def fold(record: Any) -> None:
        nonlocal folded
        folded += 1
        for update in updates:
            update(record)

    log.info(
        f"{run.kind} fetch starting",
        **{f"{run.kind}_id": str(run.output_id)},
        concurrency=run.settings.concurrency,
        data=sorted(run.needs.data),
    )
    async with open_api(run.access, run.settings, run.retry) as api:
        clock = asyncio.get_running_loop().time
        last_shown = -_SHOW_EVERY_S

        def report(outcome: _O, *, final: bool = False) -> None:
            # Called as each job is listed and done; a display needs a few a second (the
            # bar redraws 4 times a second, events come every 10 s), and a snapshot per
            # call cost ~1 % of the client's CPU at 0 ms latency.
            nonlocal last_shown
            if run.check is not None:
                run.check(outcome)
            now = clock()
            if now - last_shown < _SHOW_EVERY_S and not final:
                return
            last_shown = now
            show_progress(run.progress, run.snapshot_of(outcome), Traffic.of(api))

        fetcher = fetcher_for(api, report)
        # Shown each second too, so that the counters (and the progress events off a
        # terminal) go on while no job completes: retries in an outage, a slow page.
        ticker = asyncio.create_task(tick(lambda: report(fetcher.outcome)))
        try:
            async with fetch_deadline(
                run.settings.deadline,
                started=run.started,
                progress=lambda: run.how_far(fetcher.outcome, folded),
            ):
                outcome = await fetcher.run(fold)
                if run.then is not None:
                    await run.then(api, outcome)
            report(outcome, final=True)  # the display ends on the complete counts
        finally:
            ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await ticker
            run.progress.close()
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


def write_output(
    writer: MetricsWriter, aggregations: Sequence[Aggregation[Any]], outputs_dir: Path
) -> Path:
    """The aggregations' metrics after what `writer` holds, written atomically."""
    for aggregation in aggregations:
        aggregation.finish(writer)
    return writer.write(outputs_dir / OUTPUT_NAME)
