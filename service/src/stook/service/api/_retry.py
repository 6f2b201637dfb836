"""Retries: which failures, how long, and how requests to a failing origin wait together.

Every request's attempts run through :func:`send` on tenacity, the first one included.

* What is retried: 5xx and 429 answers, connection failures, timeouts, bodies cut short.
  Any other 4xx, and a failure another attempt cannot fix, ends the request at once.
* How long: a budget in time, ``retry_for`` (120 s), not a count of attempts, so an API
  down for a minute costs the run a minute. Pauses grow exponentially with full jitter
  from ``initial_backoff`` to ``max_backoff`` and never sleep past the budget. A
  ``Retry-After`` is honoured up to ``max_retry_after``; a longer one, or one past the
  budget, ends the request at once with an error naming it.
* First contact: until an origin has answered once, a wrong URL is more likely than an
  outage. A host name that does not resolve ends the request at once, and a connection
  refused or reset gets ``first_contact_for`` (10 s), not the whole ``retry_for``; both
  end in :class:`OriginUnreachableError`, naming the setting the URL came from.
* Together: each :class:`Origin` (the API, object storage) has a gate. Transient failures
  of ``trip_after`` different requests with no answer between them close it for a backoff
  (full jitter, at most ``MAX_PROBE_INTERVAL``, at least what a ``Retry-After`` asked for);
  requests then wait at it instead of sending, one probe goes out when the backoff ends,
  and any answer to a request sent since it closed opens it and wakes them all. One
  request failing again and again (a job whose listing always answers 500) does not.

The gate is plain state on one event loop, changed only between awaits: no lock is held
across a network call. Tests inject ``sleep``, ``clock`` and ``backoff`` in the policy.
"""

from __future__ import annotations

import asyncio
import email.utils
import enum
import sys
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Final, TypeVar

from tenacity import (
    DoSleep,
    RetryCallState,
    RetryError,
    Retrying,
    retry_if_exception,
    wait_random_exponential,
)
from tenacity.wait import wait_base
from yarl import URL

from stook.service.api._errors import (
    ApiStatusError,
    OriginUnavailableError,
    OriginUnreachableError,
    RetriesExhaustedError,
    RetryAfterTooLongError,
    StorageError,
    TransportError,
)
from stook.service.api._logging import get_logger
from stook.service.api._redact import redact_text, redact_url
from stook.service.api._transport import TransferStats

__all__ = [
    "RETRYABLE_STATUSES",
    "Origin",
    "RetryPolicy",
    "describe_failure",
    "is_retryable",
    "parse_retry_after",
    "send",
]

_log = get_logger("stook.service.retry")
_T = TypeVar("_T")

RETRYABLE_STATUSES: Final = frozenset({429}) | frozenset(range(500, 600))
# The longest pause between two probes of a closed gate: the run resumes within two
# seconds of the origin answering again.
MAX_PROBE_INTERVAL: Final = 2.0
# Requests failing with no answer between them that close the gate: with 64 in flight an
# outage reaches it at once; a 10 % fault rate almost never does.
TRIP_AFTER: Final = 5


@dataclass(frozen=True, slots=True)
class RetryPolicy:
    """How long and how patiently to retry one request.

    ``backoff``, ``sleep`` and ``clock`` let tests run without waiting: a ``backoff`` of
    ``tenacity.wait_none()`` never pauses, a recording ``sleep`` shows which pauses were
    asked for, and a ``clock`` that advances with it spends the budget at once.
    ``max_attempts`` caps attempts for such tests; runs are bounded by time alone.
    """

    retry_for: float = 120.0
    first_contact_for: float = 10.0
    initial_backoff: float = 0.2
    max_backoff: float = 10.0
    max_retry_after: float = 60.0
    request_timeout: float = 30.0
    max_attempts: int | None = None
    backoff: wait_base | None = None
    sleep: Callable[[float], Awaitable[None]] = asyncio.sleep
    clock: Callable[[], float] = time.monotonic

    def __post_init__(self) -> None:
        for name in ("retry_for", "first_contact_for", "request_timeout"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.max_attempts is not None and self.max_attempts < 1:
            raise ValueError(f"max_attempts must be at least 1, got {self.max_attempts}")
        if self.max_retry_after < 0:
            raise ValueError(f"max_retry_after cannot be negative, got {self.max_retry_after}")

    def backoff_wait(self) -> wait_base:
        """The pause before a retry when the server named none: full-jitter exponential."""
        if self.backoff is not None:
            return self.backoff
        return wait_random_exponential(multiplier=self.initial_backoff, max=self.max_backoff)


def is_retryable(exc: BaseException) -> bool:
    """Whether asking again could give a different answer."""
    if isinstance(exc, ApiStatusError | StorageError):
        return exc.status in RETRYABLE_STATUSES
    return isinstance(exc, TransportError) and exc.retryable


_RETRYABLE: Final = retry_if_exception(is_retryable)


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
        return max(0.0, float(value.strip()))
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


def _is_answer(exc: BaseException) -> bool:
    """An HTTP status: the origin is there, though it refused (404, 429, 503...)."""
    return isinstance(exc, ApiStatusError | StorageError) and exc.status is not None


class _Passage(enum.Enum):
    OPEN = "open"  # the gate was open: an ordinary request
    PROBE = "probe"  # the gate was closed; this request tests whether the origin is back
    TIMED_OUT = "timed out"  # the request's budget ran out while it waited


class Origin:
    """One origin's health as its requests see it: whether it ever answered, its gate, and
    whether requests are being retried now (for the progress display).

    ``setting`` names where its URL came from (``apiURL``), for a first contact that fails.
    """

    def __init__(
        self, label: str, policy: RetryPolicy, *, setting: str, trip_after: int = TRIP_AFTER
    ) -> None:
        self.label = label
        self.policy = policy
        self.backoff = policy.backoff_wait()
        self.setting = setting
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
        # One for all of the origin's requests: its loop (`iter`) runs without an await,
        # so they take turns on it; what is each request's is in its RetryCallState.
        self.tenacity = Retrying(
            stop=_stop, wait=_wait, retry=_RETRYABLE, before_sleep=_before_sleep
        )
        self.tenacity.begin()

    def answer(self, sent_in: int) -> None:
        """An answer (any but a transient failure) to a request sent when `closures` was
        `sent_in`: it opens the gate, unless the request left before the gate closed."""
        self.answered = True
        self._failing.clear()
        if not self.is_open and sent_in == self.closures:
            self.is_open = True
            self._failed_probes = 0
            self._probing = False
            _log.info("origin answers again; requests resume", origin=self.label)
            self._notify()

    def fail(self, request: object, exc: BaseException, url: URL, probe: bool) -> None:
        """A transient failure of `request`: a probe's, or those of enough requests with no
        answer between them, close the gate."""
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
        self.is_open = False
        self.closures += 1
        self._failed_probes = 0
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

    async def enter(self, deadline: float) -> _Passage:
        """Wait until the gate lets a request through, or until `deadline` (clock time)."""
        clock = self.policy.clock
        while not self.is_open:
            now = clock()
            if now >= deadline:
                return _Passage.TIMED_OUT
            if not self._probing and now >= self._until:
                self._probing = True
                return _Passage.PROBE
            # Until the backoff ends, or, while a probe is out, until its outcome.
            wake = min(self._until if now < self._until else deadline, deadline)
            changed = asyncio.ensure_future(self._changed.wait())
            timer = asyncio.ensure_future(self.policy.sleep(max(wake - now, 0.0)))
            try:
                await asyncio.wait((changed, timer), return_when=asyncio.FIRST_COMPLETED)
            finally:
                changed.cancel()
                timer.cancel()
        return _Passage.OPEN

    def _close_for(self, attempt: int, retry_after: float | None) -> float:
        state = RetryCallState(Retrying(), None, (), {})
        state.attempt_number = attempt
        wait = min(self.backoff(state), MAX_PROBE_INTERVAL)
        if retry_after is not None:
            wait = max(wait, retry_after)
        self._until = self.policy.clock() + wait
        return wait

    def _notify(self) -> None:
        self._changed.set()
        self._changed = asyncio.Event()


class _GateTimeoutError(Exception):
    """The request's budget ran out while it waited at its origin's closed gate."""


class _GiveUp(enum.Enum):
    ATTEMPTS = "attempts"
    BUDGET = "budget"
    RETRY_AFTER_CAP = "Retry-After above the cap"
    RETRY_AFTER_BUDGET = "Retry-After beyond the budget"


class _Request:
    """One request's attempts: its budget, tenacity's stop and wait, and what ends it."""

    def __init__(self, origin: Origin, url: URL, stats: TransferStats) -> None:
        self.origin = origin
        self.policy = origin.policy
        self.url = url
        self.stats = stats
        self.started = self.policy.clock()
        self.last: BaseException | None = None
        self.why: _GiveUp | None = None
        self.left_at_stop = 0.0
        self.counted = False  # in origin.retrying

    def first_contact(self) -> bool:
        """Whether the origin never answered and this request failed to connect: the
        short budget, not the whole `retry_for`."""
        last = self.last
        return (
            not self.origin.answered
            and isinstance(last, TransportError)
            and last.kind in ("connect", "broken")
        )

    def deadline(self) -> float:
        policy = self.policy
        budget = policy.retry_for
        if self.first_contact():
            budget = min(budget, policy.first_contact_for)
        return self.started + budget

    async def attempt(self, send: Callable[[], Awaitable[_T]]) -> _T:
        origin = self.origin
        passage = _Passage.OPEN
        if not origin.is_open:
            passage = await origin.enter(self.deadline())
            if passage is _Passage.TIMED_OUT:
                raise _GateTimeoutError
        sent_in = origin.closures
        try:
            result = await send()
        except Exception as exc:
            self.last = exc
            status = getattr(exc, "status", None) if _is_answer(exc) else None
            if (status is not None and status >= 500) or isinstance(exc, TransportError):
                # The origin failing (a 5xx, no answer), not pacing us (429) or refusing.
                origin.answered = origin.answered or status is not None
                if is_retryable(exc):
                    origin.fail(self, exc, self.url, passage is _Passage.PROBE)
            elif status is not None:
                origin.answer(sent_in)
            if isinstance(exc, TransportError) and exc.kind == "dns" and not origin.answered:
                # The name does not resolve and never did: no retry can fix a wrong URL.
                raise self.unreachable(exc.reason) from None
            raise
        else:
            origin.answer(sent_in)
            return result
        finally:
            if passage is _Passage.PROBE:
                origin.probe_finished()

    def stop(self, state: RetryCallState) -> bool:
        policy = self.policy
        retry_after = _retry_after(self.last)
        left = self.left_at_stop = self.deadline() - policy.clock()
        if policy.max_attempts is not None and state.attempt_number >= policy.max_attempts:
            self.why = _GiveUp.ATTEMPTS
        elif retry_after is not None and retry_after > policy.max_retry_after:
            self.why = _GiveUp.RETRY_AFTER_CAP
        elif left <= 0:
            self.why = _GiveUp.BUDGET
        elif retry_after is not None and retry_after > left:
            self.why = _GiveUp.RETRY_AFTER_BUDGET
        return self.why is not None

    def wait(self, state: RetryCallState) -> float:
        """The server's pause first; at a closed gate none (the request waits there, to
        resume with the others); else the backoff. Never past the budget."""
        left = max(0.0, self.deadline() - self.policy.clock())
        retry_after = _retry_after(self.last)
        if retry_after is not None:
            return min(retry_after, self.policy.max_retry_after, left)
        if not self.origin.is_open:
            return 0.0
        return min(self.origin.backoff(state), left)

    def before_sleep(self, state: RetryCallState) -> None:
        reason = describe_failure(self.last) if self.last is not None else "unknown"
        self.stats.retries += 1
        self.stats.retry_reasons[reason.split(":", 1)[0]] += 1
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

    def unreachable(self, reason: str) -> OriginUnreachableError:
        origin = self.origin
        return OriginUnreachableError(
            label=origin.label,
            origin=self.url.origin(),
            setting=origin.setting,
            reason=reason,
        )

    def give_up(self, attempts: int) -> Exception:
        """The error that ends a request whose retries stopped."""
        policy, origin, last = self.policy, self.origin, self.last
        retry_after = _retry_after(last)
        status = getattr(last, "status", None)
        if self.why is _GiveUp.RETRY_AFTER_CAP and retry_after is not None:
            limit = f"the {policy.max_retry_after:g} s stook waits at most"
        elif self.why is _GiveUp.RETRY_AFTER_BUDGET and retry_after is not None:
            limit = (
                f"the {max(self.left_at_stop, 0.0):.1f} s left of its "
                f"{policy.retry_for:g} s [fetch] retry_for"
            )
        else:
            limit = ""
        if limit:
            return RetryAfterTooLongError(
                method="GET",
                url=self.url,
                status=status,
                retry_after=retry_after or 0.0,
                limit=limit,
            )
        reason = describe_failure(last) if last is not None else origin.last_failure
        if self.first_contact() and self.why is _GiveUp.BUDGET:
            return self.unreachable(f"{reason}; tried for {policy.first_contact_for:g} s")
        if self.why is _GiveUp.BUDGET and not origin.is_open:
            # Requests of many kinds fail and none is answered: the origin is down.
            return OriginUnavailableError(
                label=origin.label,
                origin=origin.url or self.url.origin(),
                retry_for=policy.retry_for,
                last_reason=reason,
            )
        return RetriesExhaustedError(
            method="GET",
            url=self.url,
            attempts=attempts,
            last_reason=reason,
            last_status=status if isinstance(status, int) else None,
        )


def _stop(state: RetryCallState) -> bool:
    return bool(state.args[0].stop(state))


def _wait(state: RetryCallState) -> float:
    return float(state.args[0].wait(state))


def _before_sleep(state: RetryCallState) -> None:
    state.args[0].before_sleep(state)


async def send(
    attempt: Callable[[], Awaitable[_T]], origin: Origin, *, url: URL, stats: TransferStats
) -> _T:
    """Await ``attempt()`` until it succeeds, fails for good, or its budget is spent.

    A failure that is not transient propagates unchanged. A spent budget raises
    :class:`OriginUnavailableError` while the origin's gate is closed (the origin is down,
    not just this request), :class:`OriginUnreachableError` when the origin never
    answered, else :class:`RetriesExhaustedError`; a ``Retry-After`` that cannot be
    honoured raises :class:`RetryAfterTooLongError` at once.
    """
    request = _Request(origin, url, stats)
    retrying = origin.tenacity
    # Each attempt's failure goes to tenacity, which says whether to retry, whether to
    # stop and how long to wait: the loop of AsyncRetrying.__call__, on tenacity's
    # synchronous core. AsyncRetrying would also wrap each step in a coroutine on every
    # attempt, and its bookkeeping of a success hands the result back unchanged: together
    # 80 µs a request at 0 ms latency, a third of the client's CPU.
    state: RetryCallState | None = None  # the call's, made with its first failure
    try:
        while True:
            try:
                return await request.attempt(attempt)
            except Exception:  # a cancellation is no failure: it ends the request as it is
                if state is None:
                    state = RetryCallState(retrying, fn=None, args=(request,), kwargs={})
                state.set_exception(sys.exc_info())  # type: ignore[arg-type]
            # Raises the failure when it is not retried, RetryError when retries stop.
            do = retrying.iter(state)
            assert isinstance(do, DoSleep)
            state.prepare_for_next_attempt()
            await request.policy.sleep(do)
    except _GateTimeoutError:
        request.why = _GiveUp.BUDGET
        sent = state.attempt_number - 1 if state is not None else 0  # the last one was not
        raise request.give_up(sent) from None
    except RetryError as exhausted:
        raise request.give_up(exhausted.last_attempt.attempt_number) from None
    finally:
        if request.counted:
            origin.retrying -= 1
