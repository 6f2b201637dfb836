"""A run's fetch, assembled in one place: the client, the fetcher, the fold, the deadline.

Every fetch of stook's runs goes through `fetch_records`: it opens the run's API client
from `[fetch]` (`open_api`, the only place a run's client is configured), makes the
fetcher on it (a `BatchFetcher`, `ReportFetcher` or the batch's with its baseline beside
it), hands each record it completes to `on_record`, runs what the run fetches after it on
the same client (`then`: report mode's emissions logs), honours `[fetch] deadline`, and
says what the client's traffic was (`Traffic`). Its callers differ only in what they wrap
around it:

    batch and report mode  fold_here      every record folded into the aggregations,
                                          progress shown while it runs
    a shard (a worker)     _shards        its piece folded, progress sent to the driver
                                          (the deadline is the driver's)
    the library            _library       every record handed to the caller's loop
    the probe              open_api       one client per level (stook.bench)

A sharded run's driver (`_engine`) opens its client here too, for the listing it splits
and what it fetches beside the shards.

The rest is what both modes do around the fetch: what to fetch (`needs_of`), the
missing-jobs rule (`check_missing`, one rule whether the allowance is a share of the jobs
or a number of them), and the write (`write_output`).

The outputs folder is checked before the first request (`check_outputs_folder`, at the
end), so that a run that cannot write says so before it fetches.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import os
import tempfile
import uuid
from collections.abc import AsyncIterator, Awaitable, Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

import structlog

from stook.sdk import MetricStatus, MetricsWriter
from stook.sdk.aggregations import Aggregation, Needs
from stook.service.api import (
    ApiClient,
    ConcurrencyLimit,
    LimitStats,
    RetryPolicy,
    body_cap_mb,
)
from stook.service.fetch import DeadlineReachedError, MissingJob
from stook.service.modes._config import FetchSettings
from stook.service.modes._errors import MissingJobsError, OutputsError
from stook.service.modes._inputs import ApiAccess
from stook.service.modes._progress import FetchProgress, Progress

__all__ = [
    "OUTPUT_NAME",
    "FetchRun",
    "Fetcher",
    "MissingJobsError",
    "RunResult",
    "Traffic",
    "check_missing",
    "fetch_records",
    "fold_here",
    "needs_of",
    "open_api",
    "write_missing_jobs",
    "write_output",
]

log = structlog.get_logger("stook.run")

OUTPUT_NAME = "metrics.binproto"
# The shortest time between two progress snapshots (the last one is always shown).
_SHOW_EVERY_S = 0.05

_R = TypeVar("_R")  # what the fetcher hands over: a job's record, or a batch's
_O = TypeVar("_O")  # what the fetcher saw: counts, names, missing jobs
_R_co = TypeVar("_R_co", covariant=True)
_O_co = TypeVar("_O_co", covariant=True)


# --- the client and its traffic ------------------------------------------------------------


@contextlib.asynccontextmanager
async def open_api(
    access: ApiAccess, settings: FetchSettings, retry: RetryPolicy | None = None
) -> AsyncIterator[ApiClient]:
    """An ApiClient configured from `[fetch]`; `retry` overrides its retry policy (tests)."""
    policy = retry or RetryPolicy(retry_for=settings.retry_for, request_timeout=settings.timeout)
    async with ApiClient(
        access.api_url,
        access.token,
        concurrency=settings.concurrency,
        retry=policy,
        page_size=settings.page_size,
        adaptive=settings.adaptive,
        body_cap=body_cap_mb(settings.max_api_body_mb, "max_api_body_mb"),
        storage_body_cap=body_cap_mb(settings.max_body_mb, "max_body_mb"),
    ) as api:
        yield api


@dataclass(frozen=True, slots=True)
class Traffic:
    """Requests, retries and bytes of a client, API and storage together, and its limiters.

    The limiters are the client's own (``ApiClient.limiters``), not copies: taking a
    Traffic after every job costs nothing, and ``limit_stats`` reads what they did when
    asked, at the end of a run what they did in all.
    """

    requests: int = 0
    retries: int = 0
    bytes_received: int = 0
    # Requests being retried now: the origins and their last failure ("" when none).
    retrying: str = ""
    limiters: Mapping[str, ConcurrencyLimit] = field(default_factory=dict, compare=False)

    @classmethod
    def of(cls, api: ApiClient) -> Traffic:
        return cls(
            requests=api.stats.requests + api.storage.stats.requests,
            retries=api.stats.retries + api.storage.stats.retries,
            bytes_received=api.stats.bytes_received + api.storage.stats.bytes_received,
            retrying="; ".join(
                f"{origin.label} at {origin.url}: {origin.last_failure}"
                for origin in (api.origin, api.storage.origin)
                if origin.retrying
            ),
            limiters=api.limiters,
        )

    def __add__(self, other: Traffic) -> Traffic:
        """Two clients' traffic together (a sharded run's shards and its driver); the
        limiters are the right-hand one's, the client still open."""
        return Traffic(
            requests=self.requests + other.requests,
            retries=self.retries + other.retries,
            bytes_received=self.bytes_received + other.bytes_received,
            retrying=other.retrying or self.retrying,
            limiters=other.limiters or self.limiters,
        )

    @property
    def limit_stats(self) -> dict[str, LimitStats]:
        """What each limiter did, by name ("shared", and "api" and "storage" when adaptive)."""
        return {name: limiter.stats for name, limiter in self.limiters.items()}


# --- the fetch ------------------------------------------------------------------------------


@contextlib.asynccontextmanager
async def fetch_deadline(
    seconds: float | None, *, started: float, progress: Callable[[], str]
) -> AsyncIterator[None]:
    """`[fetch] deadline`: cancel the body `seconds` after `started` (the event loop's
    clock); None: no limit. For platforms that kill a job after a while: without it a run
    facing a slow or failing API takes as long as the retry budgets allow; with it, the
    fetch stops at the deadline and the run exits 3 with one line saying how far it got
    (``progress()``, e.g. "1,204 of 5,000 jobs"), before the platform's own timeout kills
    it without a word."""
    if seconds is None:
        yield
        return
    timeout = asyncio.timeout_at(started + seconds)
    try:
        async with timeout:
            yield
    except TimeoutError:
        if not timeout.expired():
            raise  # a timeout of something inside, not ours
        raise DeadlineReachedError(
            f"deadline of {seconds:g} s ([fetch] deadline) reached after {progress()}"
        ) from None


class Fetcher(Protocol[_R_co, _O_co]):
    """`BatchFetcher`, `ReportFetcher` (or the batch's with its baseline): hands each
    record to `on_record` as it is complete."""

    @property
    def outcome(self) -> _O_co:
        """What the fetch has seen so far (complete once `run` returns)."""
        ...

    async def run(self, on_record: Callable[[_R_co], Any], /) -> _O_co: ...


#: What a caller wraps around the running fetch (its progress), given the fetcher and
#: the client: entered once the fetcher is made, left once the fetch is done.
Watch = Callable[[Fetcher[Any, Any], ApiClient], contextlib.AbstractAsyncContextManager[None]]


async def fetch_records(
    access: ApiAccess,
    settings: FetchSettings,
    fetcher_for: Callable[[ApiClient], Fetcher[_R, _O]],
    on_record: Callable[[_R], Any],
    *,
    retry: RetryPolicy | None = None,
    started: float | None = None,
    how_far: Callable[[_O], str] = lambda _: "the fetch",
    then: Callable[[ApiClient, _O], Awaitable[None]] | None = None,
    watch: Watch | None = None,
) -> tuple[_O, Traffic]:
    """Open the run's client, make its fetcher, hand each record to `on_record`, then run
    `then` on the same client; the fetcher's outcome and the client's traffic.

    `[fetch] deadline` counts from `started` (the event loop's clock; None: no deadline
    here, a shard's is its driver's) and ends the fetch with DeadlineReachedError saying
    `how_far(outcome)`."""
    async with open_api(access, settings, retry) as api:
        fetcher = fetcher_for(api)
        watching = watch(fetcher, api) if watch is not None else contextlib.nullcontext()
        async with (
            watching,
            fetch_deadline(
                None if started is None else settings.deadline,
                started=started or 0.0,
                progress=lambda: how_far(fetcher.outcome),
            ),
        ):
            outcome = await fetcher.run(on_record)
            if then is not None:
                await then(api, outcome)
        return outcome, Traffic.of(api)


@dataclass(frozen=True, slots=True)
class RunResult(Generic[_O]):
    """What a batch or report run wrote, and what its fetch saw."""

    kind: str
    output: Path
    outcome: _O
    metrics_written: list[str]
    status: MetricStatus
    traffic: Traffic
    counts: dict[str, int]
    seconds: float

    @property
    def requests(self) -> int:
        return self.traffic.requests

    @property
    def retries(self) -> int:
        return self.traffic.retries

    @property
    def bytes_received(self) -> int:
        return self.traffic.bytes_received


def needs_of(aggregations: Sequence[Aggregation[Any]]) -> Needs:
    """Everything the aggregations read, so that the fetch downloads no more than that."""
    needs = Needs()
    for aggregation in aggregations:
        needs = needs | aggregation.needs()
    return needs


@dataclass(frozen=True, slots=True)
class FetchRun(Generic[_O]):
    """What a mode's fetch and fold is given: the aggregations, what to fetch and how, how
    to show progress, and when the run started (the event loop's clock, for the deadline)."""

    kind: str  # "batch" or "report": names the run in log events
    output_id: uuid.UUID
    aggregations: Sequence[Aggregation[Any]]
    needs: Needs
    access: ApiAccess
    settings: FetchSettings
    retry: RetryPolicy | None
    progress: Progress
    progress_of: Callable[[_O], FetchProgress]  # jobs (and batches) done, listed and in all
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
    """A mode's fetch and fold in this process: every record folded as it arrives, the
    progress shown while it runs.

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
    clock = asyncio.get_running_loop().time
    last_shown = -_SHOW_EVERY_S
    opened: ApiClient | None = None  # the run's client, once open

    def report(outcome: _O, *, final: bool = False) -> None:
        # Called as each job is listed and done; a display needs a few a second (the bar
        # redraws 4 times a second, events come every 10 s), and a snapshot per call cost
        # ~1 % of the client's CPU at 0 ms latency.
        nonlocal last_shown
        if run.check is not None:
            run.check(outcome)
        now = clock()
        if now - last_shown < _SHOW_EVERY_S and not final:
            return
        last_shown = now
        traffic = Traffic() if opened is None else Traffic.of(opened)
        show_progress(run.progress, run.progress_of(outcome), traffic)

    def make(api: ApiClient) -> Fetcher[Any, _O]:
        nonlocal opened
        opened = api
        return fetcher_for(api, report)

    @contextlib.asynccontextmanager
    async def shown(fetcher: Fetcher[Any, _O], _: ApiClient) -> AsyncIterator[None]:
        # Shown each second too, so that the counters (and the progress events off a
        # terminal) go on while no job completes: retries in an outage, a slow page.
        ticker = asyncio.create_task(tick(lambda: report(fetcher.outcome)))
        try:
            yield
            report(fetcher.outcome, final=True)  # the display ends on the complete counts
        finally:
            ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await ticker
            run.progress.close()

    return await fetch_records(
        run.access,
        run.settings,
        make,
        fold,
        retry=run.retry,
        started=run.started,
        how_far=lambda outcome: run.how_far(outcome, folded),
        then=run.then,
        watch=shown,
    )


def show_progress(shown: Progress, snapshot: FetchProgress, traffic: Traffic) -> None:
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


# --- the missing-jobs rule and the write ---------------------------------------------------


def check_missing(
    missing: list[MissingJob],
    jobs: int,
    *,
    allowed_share: float | None = None,
    allowed_jobs: int | None = None,
    what: str = "",
) -> list[MissingJob]:
    """The missing jobs in job-ID order, or MissingJobsError naming the first when more
    are missing than allowed: a share of the jobs (`--allow-missing-jobs`) or a number of
    them (the library's `allow_missing`). `what` names the batch or report in the error."""
    # In job-ID order, whatever order the jobs failed in: the output does not depend on
    # timing, nor on how the jobs were split among processes (modes/_engine.py).
    ordered = sorted(missing, key=lambda m: m.job_id)
    if allowed_share is not None:
        too_many = len(ordered) / max(jobs, 1) > allowed_share
        allowance = f"allowed share {allowed_share:g}"
    else:
        too_many = len(ordered) > (allowed_jobs or 0)
        allowance = f"allow_missing={allowed_jobs or 0}"
    if not ordered or not too_many:
        return ordered
    first = ordered[0]
    more = f" and {len(ordered) - 1} more" if len(ordered) > 1 else ""
    of = f" of {what}" if what else ""
    # A summary: each job's reason was said once already, in its "unavailable" warning.
    raise MissingJobsError(
        f"job {first.job_id}{more}{of} could not be fetched (see the warnings above); "
        f"{len(ordered)} of {jobs} jobs missing, {allowance}"
    )


def write_missing_jobs(
    writer: MetricsWriter, missing: list[MissingJob], jobs: int, allowed: float
) -> None:
    """Fail naming the first missing job, or, within the allowed share, say which are missing."""
    missing = check_missing(missing, jobs, allowed_share=allowed)
    if not missing:
        return
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


# --- the outputs folder, checked before the first request ------------------------------------

# The outputs folder, checked before the first request.
#
# A run that cannot write its output should say so at once, not after an hour of fetching.
# The check is a real write: permission bits, ownership, ACLs, read-only mounts and
# container user mappings all have their say, which reading the mode bits would not.

# Not the output's own temporary-file prefix, so a clean-up of those never meets a probe.
_PROBE_PREFIX = ".stook-write-probe-"


def check_outputs_folder(folder: Path) -> None:
    """Create `folder` if need be, then create and remove a file in it; else OutputsError."""
    who = f"user id {os.geteuid()}"
    shown = str(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputsError(f"outputs folder {shown!r} exists but is not a folder") from None
    except OSError as exc:
        raise OutputsError(
            f"outputs folder {shown!r} cannot be created by {who} ({_reason(exc)}): "
            f"create it writable for {who}, or run as a user who may (see deploy/README.md)"
        ) from None
    try:
        fd, probe = tempfile.mkstemp(prefix=_PROBE_PREFIX, dir=folder)
    except OSError as exc:
        raise OutputsError(
            f"outputs folder {shown!r} is not writable by {who} ({_reason(exc)}): "
            f"give {who} write access to it, or run as a user who has it "
            "(see deploy/README.md)"
        ) from None
    os.close(fd)
    with contextlib.suppress(FileNotFoundError):
        os.unlink(probe)


def _reason(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__
