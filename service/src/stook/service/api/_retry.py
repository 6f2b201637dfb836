"""Retries through tenacity, the first attempt included: what, how long, and together.

5xx, 429, connection failures, timeouts and cut bodies are retried, for a time
(``retry_for``), with full-jitter pauses that never sleep past it; a ``Retry-After`` is
honoured up to ``max_retry_after``, and a longer one ends the request at once. Until an
origin has answered, a wrong URL is likelier than an outage: a name that does not resolve
ends the request at once, a refused or reset connection gets ``first_contact_for``. Each
:class:`Origin` has a gate: transient failures of ``trip_after`` different requests with no
answer between close it; its requests then wait there while one probe goes out at a time,
and an answer to a request sent since the closure opens it for all.
"""

from __future__ import annotations

import asyncio
import email.utils
import random
import time
from collections.abc import Awaitable, Callable
from typing import Final, TypeVar

import structlog
import tenacity
from yarl import URL

from stook.service.api._config import RetryPolicy
from stook.service.api._errors import (
    ApiStatusError,
    OriginUnavailableError,
    OriginUnreachableError,
    RetriesExhaustedError,
    RetryAfterTooLongError,
    StorageError,
    TransportError,
)
from stook.service.api._redact import redact_text, redact_url
from stook.service.api._transport import TrafficCounts

_log = structlog.get_logger("stook.service.retry")
_T = TypeVar("_T")

RETRYABLE_STATUSES: Final = frozenset({429, *range(500, 600)})
MAX_PROBE_INTERVAL: Final = 2.0  # the run resumes within 2 s of the origin answering again
# With 64 in flight an outage closes the gate at once; a 10 % fault rate almost never does.
TRIP_AFTER: Final = 5


def is_retryable(exc: BaseException) -> bool:
    """Whether asking again could give a different answer."""
    if isinstance(exc, ApiStatusError | StorageError):
        return exc.status in RETRYABLE_STATUSES
    return isinstance(exc, TransportError) and exc.retryable


def describe_failure(exc: BaseException) -> str:
    """A short, redacted reason, for logs and errors."""
    if isinstance(exc, ApiStatusError | StorageError) and exc.status is not None:
        return f"HTTP {exc.status}"
    if isinstance(exc, TransportError):
        return exc.reason
    text = redact_text(str(exc))
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def parse_retry_after(value: str | None, *, now: float | None = None) -> float | None:
    """Seconds to wait from a ``Retry-After`` header (delta seconds or an HTTP date)."""
    if not value:
        return None
    try:
        return max(0.0, float(value))
    except ValueError:
        pass
    try:
        moment = email.utils.parsedate_to_datetime(value.strip())
    except (TypeError, ValueError):
        return None
    if moment.tzinfo is None:
        return None
    return max(0.0, moment.timestamp() - (time.time() if now is None else now))


def _retry_after(exc: BaseException | None) -> float | None:
    value = getattr(exc, "retry_after", None)
    return float(value) if isinstance(value, int | float) else None


class _GateTimeoutError(Exception):
    """The request's budget ran out while it waited at its origin's closed gate."""


class Origin:
    """One origin's health as its requests see it: whether it ever answered, its gate, and
    how many requests are between attempts now (for the progress display). ``setting``
    names where its URL came from (``apiURL``), for a first contact that fails."""

    def __init__(
        self, label: str, policy: RetryPolicy, *, setting: str, trip_after: int = TRIP_AFTER
    ) -> None:
        self.label, self.policy, self.setting = label, policy, setting
        self.answered = False  # ever: after that, failures are outages, not a wrong URL
        self.retrying = 0  # requests between attempts now
        self.url = ""  # scheme://host[:port] of the last failure
        self.last_failure = ""
        self.is_open = True
        self.closures = 0  # a request notes it when sent: was it sent before the closure?
        self._trip_after = trip_after
        self._failing: set[object] = set()  # requests failed since the last answer
        self._until = 0.0
        self._failed_probes = 0
        self._probing = False
        self._changed = asyncio.Event()

    def answer(self, sent_in: int) -> None:
        """An answer to a request sent when `closures` was `sent_in`: it opens the gate,
        unless the request left before the gate closed."""
        self.answered = True
        self._failing.clear()
        if not self.is_open and sent_in == self.closures:
            self.is_open, self._failed_probes, self._probing = True, 0, False
            _log.info("origin answers again; requests resume", origin=self.label)
            self._notify()

    def fail(self, request: object, exc: BaseException, url: URL, probe: bool) -> None:
        """A transient failure of `request`; a probe's, or enough requests', close the gate."""
        self.last_failure = describe_failure(exc)
        self.url = str(url.origin())
        retry_after = _retry_after(exc)
        if retry_after is not None and retry_after > self.policy.max_retry_after:
            retry_after = None  # not honoured: that request ends instead
        if not self.is_open:
            if probe:
                self._failed_probes += 1
                self._probing = False
                self._close_for(self._failed_probes + 1, retry_after)
                self._notify()
            return  # else an echo of the failure that closed it
        self._failing.add(request)
        if len(self._failing) < self._trip_after:
            return
        self._failing.clear()
        self.is_open, self._failed_probes = False, 0
        self.closures += 1
        wait = self._close_for(1, retry_after)
        _log.warning(
            "origin failing; requests wait at its gate",
            origin=self.label,
            url=self.url,
            reason=self.last_failure,
            wait_s=round(wait, 3),
        )

    def probe_finished(self) -> None:
        """The probe ended without news (cancelled, or an error that is no answer)."""
        if self._probing:
            self._probing = False
            self._notify()

    async def enter(self, deadline: float) -> bool:
        """Wait until the gate lets a request through (True for the probe), or raise
        :class:`_GateTimeoutError` at `deadline` (clock time)."""
        clock = self.policy.clock
        while not self.is_open:
            now = clock()
            if now >= deadline:
                raise _GateTimeoutError
            if not self._probing and now >= self._until:
                self._probing = True
                return True
            # Until the backoff ends, or, while a probe is out, until its outcome.
            wake = min(self._until if now < self._until else deadline, deadline)
            changed = asyncio.ensure_future(self._changed.wait())
            timer = asyncio.ensure_future(self.policy.sleep(max(wake - now, 0.0)))
            try:
                await asyncio.wait((changed, timer), return_when=asyncio.FIRST_COMPLETED)
            finally:
                changed.cancel()
                timer.cancel()
        return False

    def unreachable(self, url: URL, reason: str) -> OriginUnreachableError:
        return OriginUnreachableError(
            label=self.label, origin=url.origin(), setting=self.setting, reason=reason
        )

    def backoff(self, attempt: int) -> float:
        """The pause after failed attempt number `attempt` (from 1): full jitter, drawn
        from 0 up to ``initial_backoff`` doubled per attempt, at most ``max_backoff``
        (tenacity's ``wait_random_exponential``, for the gate's probes too)."""
        policy = self.policy
        ceiling = policy.initial_backoff * 2.0 ** min(attempt - 1, 64)
        return random.uniform(0.0, min(ceiling, policy.max_backoff))

    def _close_for(self, attempt: int, retry_after: float | None) -> float:
        wait = max(min(self.backoff(attempt), MAX_PROBE_INTERVAL), retry_after or 0.0)
        self._until = self.policy.clock() + wait
        return wait

    def _notify(self) -> None:
        self._changed.set()
        self._changed = asyncio.Event()


class _Request:
    """One request's attempts: what the origin learns from each, its budget, what ends it.
    Its retries run through tenacity's `AsyncRetrying`, with these methods as its `stop`,
    `wait` and `before_sleep`."""

    __slots__ = ("counted", "error", "last", "origin", "policy", "sent", "started", "stats", "url")

    def __init__(self, origin: Origin, url: URL, stats: TrafficCounts) -> None:
        self.origin, self.policy, self.url, self.stats = origin, origin.policy, url, stats
        self.started = origin.policy.clock()
        self.last: BaseException | None = None
        self.error: Exception | None = None  # what ends it, once tenacity stops
        self.counted = False  # in origin.retrying
        self.sent = 0  # attempts that left (a wait at the gate that timed out is none)

    async def attempt(self, attempt: Callable[[], Awaitable[_T]]) -> _T:
        """One attempt, through the origin's gate; what it says is noted on the origin."""
        origin = self.origin
        probe = False
        if not origin.is_open:
            probe = await origin.enter(self.deadline())
        sent_in = origin.closures
        self.sent += 1
        try:
            result = await attempt()
        except Exception as exc:  # a cancellation is no failure: it ends the request
            self.failed(exc, sent_in, probe)
            raise
        finally:
            if probe:
                origin.probe_finished()
        origin.answer(sent_in)
        return result

    async def retry(self, attempt: Callable[[], Awaitable[_T]], failure: Exception) -> _T:
        """Retry after `failure` (tenacity's first attempt) until an answer, a failure that
        is not retried (raised unchanged) or the end of the budget."""
        retrying = tenacity.AsyncRetrying(
            stop=self.stop,
            wait=self.wait,
            retry=tenacity.retry_if_exception(is_retryable),
            before_sleep=self.before_sleep,
            sleep=self.policy.sleep,
        )
        first: Exception | None = failure
        try:
            async for state in retrying:
                with state:
                    if first is not None:
                        failed, first = first, None
                        raise failed
                    return await self.attempt(attempt)
        except tenacity.RetryError:
            assert self.error is not None  # set by `stop`, which ended the retries
            raise self.error from None
        finally:
            if self.counted:
                self.origin.retrying -= 1
        raise AssertionError("tenacity ended its loop without an outcome")  # never reached

    def first_contact(self) -> bool:
        """The origin never answered and this request failed to connect: the short budget."""
        last, answered = self.last, self.origin.answered
        return (
            not answered and isinstance(last, TransportError) and last.kind in ("connect", "broken")
        )

    def deadline(self) -> float:
        policy = self.policy
        if self.first_contact():
            return self.started + min(policy.retry_for, policy.first_contact_for)
        return self.started + policy.retry_for

    def failed(self, exc: Exception, sent_in: int, probe: bool) -> None:
        """Note `exc`, and tell the origin what it says about it."""
        origin = self.origin
        self.last = exc
        status = exc.status if isinstance(exc, ApiStatusError | StorageError) else None
        if (status is not None and status >= 500) or isinstance(exc, TransportError):
            # The origin failing (a 5xx, no answer), not pacing us (429) or refusing.
            origin.answered = origin.answered or status is not None
            if is_retryable(exc):
                origin.fail(self, exc, self.url, probe)
        elif status is not None:
            origin.answer(sent_in)
        if isinstance(exc, TransportError) and exc.kind == "dns" and not origin.answered:
            # The name does not resolve and never did: no retry can fix a wrong URL.
            raise origin.unreachable(self.url, exc.reason) from None

    def stop(self, state: tenacity.RetryCallState) -> bool:
        policy, attempts = self.policy, state.attempt_number
        retry_after = _retry_after(self.last)
        left = self.deadline() - policy.clock()
        limit = ""
        if policy.max_attempts is not None and attempts >= policy.max_attempts:
            self.error = self.exhausted(attempts, budget_spent=False)
        elif retry_after is not None and retry_after > policy.max_retry_after:
            limit = f"the {policy.max_retry_after:g} s stook waits at most"
        elif left <= 0:
            self.error = self.exhausted(attempts, budget_spent=True)
        elif retry_after is not None and retry_after > left:
            limit = f"the {left:.1f} s left of its {policy.retry_for:g} s [fetch] retry_for"
        if limit:
            status = getattr(self.last, "status", None)
            self.error = RetryAfterTooLongError(
                method="GET", url=self.url, status=status, retry_after=retry_after or 0, limit=limit
            )
        return self.error is not None

    def wait(self, state: tenacity.RetryCallState) -> float:
        """The server's pause first; at a closed gate none (the request waits there, to
        resume with the others); else the backoff. Never past the budget."""
        left = max(0.0, self.deadline() - self.policy.clock())
        retry_after = _retry_after(self.last)
        if retry_after is not None:
            return min(retry_after, self.policy.max_retry_after, left)
        if not self.origin.is_open:
            return 0.0
        return min(self.origin.backoff(state.attempt_number), left)

    def before_sleep(self, state: tenacity.RetryCallState) -> None:
        reason = describe_failure(self.last) if self.last is not None else "unknown"
        self.stats.retries += 1
        if not self.counted:
            self.counted = True
            self.origin.retrying += 1
        # At debug level: the progress display says that requests are being retried.
        _log.debug(
            "retrying request",
            url=redact_url(self.url),
            reason=reason,
            attempt=state.attempt_number,
            wait_s=round(state.upcoming_sleep, 3),
        )

    def exhausted(self, attempts: int, *, budget_spent: bool) -> Exception:
        policy, origin, last = self.policy, self.origin, self.last
        reason = describe_failure(last) if last is not None else origin.last_failure
        if budget_spent and self.first_contact():
            tried = f"{reason}; tried for {policy.first_contact_for:g} s"
            return origin.unreachable(self.url, tried)
        if budget_spent and not origin.is_open:
            # Requests of many kinds fail and none is answered: the origin is down.
            where, retry_for = origin.url or self.url.origin(), policy.retry_for
            return OriginUnavailableError(
                label=origin.label, origin=where, retry_for=retry_for, last_reason=reason
            )
        status = getattr(last, "status", None)
        status = status if isinstance(status, int) else None
        return RetriesExhaustedError(
            method="GET", url=self.url, attempts=attempts, last_reason=reason, last_status=status
        )


async def send(
    attempt: Callable[[], Awaitable[_T]], origin: Origin, *, url: URL, stats: TrafficCounts
) -> _T:
    """Await ``attempt()`` until it succeeds, fails for good (raised unchanged), or its budget
    is spent (:class:`OriginUnavailableError` while the gate is closed, else
    :class:`OriginUnreachableError` or :class:`RetriesExhaustedError`)."""
    request = _Request(origin, url, stats)
    try:
        try:
            # Most requests succeed at once: tenacity is entered with the first failure.
            return await request.attempt(attempt)
        except Exception as failure:
            if not is_retryable(failure):
                raise
            return await request.retry(attempt, failure)
    except _GateTimeoutError:
        # The budget ran out at the gate: the attempt that waited there was never sent.
        raise request.exhausted(request.sent, budget_spent=True) from None
