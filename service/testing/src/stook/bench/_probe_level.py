"""One level of `stook bench --probe`: `concurrency` workers visiting for a bounded time.

Each level has a client of its own, configured from `[fetch]` as a run's is (`open_api`)
but with the level's concurrency and a fixed bound (the adaptive pace would hide what
the server does at that concurrency). Its workers send one request at a time each, as a
run's do, until the level's time is up or its request budget spent; every request is
timed, API and storage apart, and the clients' counters say what the answers were.
"""

from __future__ import annotations

import asyncio
import dataclasses
import math
import time
from collections.abc import Awaitable, Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, TypeVar

from stook.bench._probe_plan import Origin, ProbePlan, Timer
from stook.service.api import ApiClient, ApiError, AuthError, RetryPolicy, TrafficCounts
from stook.service.modes import open_api

__all__ = ["LevelResult", "OriginResult", "percentile", "run_level"]

_T = TypeVar("_T")


def percentile(sorted_values: list[float], share: float) -> float | None:
    """The nearest-rank percentile of values sorted ascending; None for no values."""
    if not sorted_values:
        return None
    # Rounded first: 0.07 * 100 is 7.000000000000001 in floating point, not rank 8.
    rank = max(1, math.ceil(round(share * len(sorted_values), 9)))
    return sorted_values[min(rank, len(sorted_values)) - 1]


@dataclass(frozen=True, slots=True)
class OriginResult:
    """What one origin (API or storage) answered at one level."""

    requests: int  # HTTP requests sent, retries included
    answered: int  # calls answered in the end (their latency is in the percentiles)
    p50_ms: float | None
    p95_ms: float | None
    p99_ms: float | None
    throttled: int  # 429 answers
    server_errors: int  # 5xx answers
    retries: int
    failed: int  # calls that failed in the end (after the retries they were allowed)

    @classmethod
    def of(cls, seconds: list[float], stats: TrafficCounts, failed: int) -> OriginResult:
        ms = sorted(s * 1000 for s in seconds)
        return cls(
            requests=stats.requests,
            answered=len(ms),
            p50_ms=_rounded(percentile(ms, 0.50)),
            p95_ms=_rounded(percentile(ms, 0.95)),
            p99_ms=_rounded(percentile(ms, 0.99)),
            throttled=stats.statuses[429],
            server_errors=sum(n for status, n in stats.statuses.items() if status >= 500),
            retries=stats.retries,
            failed=failed,
        )


@dataclass(frozen=True, slots=True)
class LevelResult:
    """One level: its throughput and latency, API and storage together and apart."""

    concurrency: int
    seconds: float
    requests_per_s: float  # calls answered per second, both origins
    p50_ms: float | None
    p95_ms: float | None
    p99_ms: float | None
    throttled: int  # 429 answers, both origins
    errors: int  # 5xx answers plus calls that failed in the end, both origins
    retries: int
    requests: int  # HTTP requests sent, both origins
    api: OriginResult
    storage: OriginResult

    @property
    def error_rate(self) -> float:
        return self.errors / self.requests if self.requests else 0.0

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(slots=True)
class _Budget:
    """The level's requests and its end; a worker stops when either runs out.

    Requests as the client counts them (`sent`): a listing's every page and every retry.
    A call begun under the limit may take it over by the pages and retries it needs."""

    max_requests: int
    ends_at: float
    sent: Callable[[], int]

    def take(self) -> bool:
        return self.sent() < self.max_requests and time.monotonic() < self.ends_at


class _BudgetSpentError(Exception):
    """The level's budget is spent: the worker that meets it stops."""


@dataclass(slots=True)
class _Recorder:
    budget: _Budget
    seconds: dict[Origin, list[float]] = field(default_factory=lambda: {"api": [], "storage": []})
    failed: dict[Origin, int] = field(default_factory=lambda: {"api": 0, "storage": 0})

    async def timed(self, origin: Origin, call: Callable[[], Awaitable[_T]]) -> _T | None:
        if not self.budget.take():
            raise _BudgetSpentError
        started = time.perf_counter()
        try:
            result = await call()
        except AuthError:
            raise  # the token is refused: no level can measure anything
        except ApiError:
            self.failed[origin] += 1  # counted, and the visit goes on without it
            return None
        self.seconds[origin].append(time.perf_counter() - started)
        return result


async def run_level(
    plan: ProbePlan, concurrency: int, *, seconds: float, max_requests: int
) -> LevelResult:
    """Run one level; ends after `seconds` at the latest, in-flight requests cancelled."""
    settings = dataclasses.replace(plan.config.fetch, concurrency=concurrency, adaptive=False)
    # A retry may not outlast the level: what it waits for is part of the level's time.
    retry = RetryPolicy(
        retry_for=min(settings.retry_for, seconds), request_timeout=settings.timeout
    )
    visits = plan.visits()
    async with open_api(plan.access, settings, retry=retry) as api:

        def sent() -> int:
            return api.stats.requests + api.storage.stats.requests

        recorder = _Recorder(_Budget(max_requests, time.monotonic() + seconds, sent))
        timed: Timer = recorder.timed
        started = time.monotonic()
        try:
            async with asyncio.timeout(seconds), asyncio.TaskGroup() as group:
                for _ in range(concurrency):
                    group.create_task(_work(api, timed, visits))
        except TimeoutError:
            pass  # the level's time is up: requests still in flight are not counted
        except ExceptionGroup as failed:
            raise failed.exceptions[0] from None  # the first cause; the rest are echoes
        elapsed = max(time.monotonic() - started, 1e-9)
        api_stats, storage_stats = api.stats, api.storage.stats
    return _result(concurrency, elapsed, recorder, api_stats, storage_stats)


async def _work(
    api: ApiClient, timed: Timer, visits: Iterator[Callable[[ApiClient, Timer], Awaitable[None]]]
) -> None:
    try:
        for visit in visits:  # the workers share the iterator: each unit visited once a turn
            await visit(api, timed)
    except _BudgetSpentError:
        return


def _result(
    concurrency: int,
    elapsed: float,
    recorder: _Recorder,
    api_stats: TrafficCounts,
    storage_stats: TrafficCounts,
) -> LevelResult:
    api = OriginResult.of(recorder.seconds["api"], api_stats, recorder.failed["api"])
    storage = OriginResult.of(
        recorder.seconds["storage"], storage_stats, recorder.failed["storage"]
    )
    every = sorted(s * 1000 for s in recorder.seconds["api"] + recorder.seconds["storage"])
    return LevelResult(
        concurrency=concurrency,
        seconds=round(elapsed, 3),
        requests_per_s=round(len(every) / elapsed, 1),
        p50_ms=_rounded(percentile(every, 0.50)),
        p95_ms=_rounded(percentile(every, 0.95)),
        p99_ms=_rounded(percentile(every, 0.99)),
        throttled=api.throttled + storage.throttled,
        errors=api.server_errors + storage.server_errors + api.failed + storage.failed,
        retries=api.retries + storage.retries,
        requests=api.requests + storage.requests,
        api=api,
        storage=storage,
    )


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 2)
