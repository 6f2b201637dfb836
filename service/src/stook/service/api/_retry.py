"""When and how long to retry a request, built on tenacity.

What is transient: 5xx and 429 answers (honouring ``Retry-After``), connection resets and
refusals, timeouts, and bodies cut short. What is not: every other 4xx — asking again with
the same token or ID gets the same answer — and anything that is not a transport problem.

How long: each request has a budget in time, ``retry_for`` (120 s by default), not a count
of attempts, so an API that is down for a minute costs the run a minute, not the run. The
pauses between attempts grow exponentially with full jitter from ``initial_backoff`` up to
``max_backoff``, and are cut short rather than sleep past the budget. A ``Retry-After`` is
honoured up to ``max_retry_after``; a longer one, or one longer than what is left of the
budget, ends the request at once with an error naming it. When an origin fails as a whole,
its :class:`~stook.service.api._gate.OriginGate` makes the requests wait together.
"""

from __future__ import annotations

import asyncio
import email.utils
import enum
import time
from collections import Counter
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Final, TypeVar

import aiohttp
from tenacity import (
    AsyncRetrying,
    RetryCallState,
    RetryError,
    retry_if_exception,
    wait_random_exponential,
)
from tenacity.stop import stop_base
from tenacity.wait import wait_base
from yarl import URL

from stook.service.api._errors import (
    ApiStatusError,
    OriginUnavailableError,
    RetriesExhaustedError,
    RetryAfterTooLongError,
    StorageError,
    TransportError,
)
from stook.service.api._gate import OriginGate, Passage
from stook.service.api._logging import get_logger
from stook.service.api._redact import redact_text, redact_url

__all__ = [
    "RetryPolicy",
    "TransferStats",
    "call_with_retries",
    "describe_failure",
    "is_retryable",
    "is_transient_transport_failure",
    "new_gate",
    "parse_retry_after",
]

_log = get_logger("stook.service.retry")

_T = TypeVar("_T")

THROTTLED_STATUS: Final = 429
RETRYABLE_STATUSES: Final = frozenset({THROTTLED_STATUS}) | frozenset(range(500, 600))


@dataclass(frozen=True, slots=True)
class RetryPolicy:
    """How long and how patiently to retry one request.

    ``backoff``, ``sleep`` and ``clock`` exist so tests (and the emulator) can run without
    waiting: ``RetryPolicy(backoff=tenacity.wait_none())`` keeps every other rule but never
    pauses, a recording ``sleep`` shows exactly which pauses were asked for, and a ``clock``
    that advances with it spends the time budget without the time passing.
    ``max_attempts`` adds a cap on attempts for such tests; runs are bounded by time alone.
    """

    retry_for: float = 120.0
    initial_backoff: float = 0.2
    max_backoff: float = 10.0
    # A server may ask for a long pause; beyond this the request ends with an error naming
    # it, rather than sleep away its budget (a `Retry-After: 3600` cannot be waited out).
    max_retry_after: float = 60.0
    request_timeout: float = 30.0
    max_attempts: int | None = None
    backoff: wait_base | None = None
    sleep: Callable[[float], Awaitable[None]] = asyncio.sleep
    clock: Callable[[], float] = time.monotonic

    def __post_init__(self) -> None:
        if self.retry_for <= 0:
            raise ValueError(f"retry_for must be positive, got {self.retry_for}")
        if self.max_attempts is not None and self.max_attempts < 1:
            raise ValueError(f"max_attempts must be at least 1, got {self.max_attempts}")
        if self.request_timeout <= 0:
            raise ValueError(f"request_timeout must be positive, got {self.request_timeout}")
        if self.max_retry_after < 0:
            raise ValueError(f"max_retry_after cannot be negative, got {self.max_retry_after}")

    def backoff_wait(self) -> wait_base:
        """The pause before a retry when the server did not name one: full-jitter exponential."""
        if self.backoff is not None:
            return self.backoff
        return wait_random_exponential(multiplier=self.initial_backoff, max=self.max_backoff)

    def pause(self, attempt: int) -> float:
        """The backoff after the `attempt`-th failure, outside a tenacity loop (the gate's)."""
        state = RetryCallState(AsyncRetrying(), None, (), {})
        state.attempt_number = attempt
        return self.backoff_wait()(state)


# The longest pause between two probes of a closed gate. Shorter than a request's own
# backoff cap: one probe every two seconds costs a failing origin nothing, and the run
# resumes within two seconds of it answering again instead of ten.
MAX_PROBE_INTERVAL: Final = 2.0


def new_gate(label: str, policy: RetryPolicy) -> OriginGate:
    """The gate of one origin ("the API", "object storage"), paced by `policy`."""
    return OriginGate(
        label,
        pause=policy.pause,
        max_pause=min(policy.max_backoff, MAX_PROBE_INTERVAL),
        clock=policy.clock,
        sleep=policy.sleep,
    )


@dataclass(slots=True)
class TransferStats:
    """Counters for one client; a single event loop updates them, so no lock is needed."""

    requests: int = 0
    retries: int = 0
    bytes_received: int = 0
    statuses: Counter[int] = field(default_factory=Counter)
    retry_reasons: Counter[str] = field(default_factory=Counter)

    def as_dict(self) -> dict[str, object]:
        return {
            "requests": self.requests,
            "retries": self.retries,
            "bytes_received": self.bytes_received,
            "statuses": dict(sorted(self.statuses.items())),
            "retry_reasons": dict(self.retry_reasons),
        }


def is_retryable(exc: BaseException) -> bool:
    """Whether asking again could give a different answer."""
    if isinstance(exc, ApiStatusError | StorageError):
        return exc.status is not None and exc.status in RETRYABLE_STATUSES
    if isinstance(exc, TransportError):
        return exc.retryable
    return is_transient_transport_failure(exc)


def is_transient_transport_failure(exc: BaseException) -> bool:
    """Whether an aiohttp or socket failure is the kind that heals: reset, refused, timeout."""
    if isinstance(exc, aiohttp.ClientSSLError | aiohttp.InvalidURL | aiohttp.TooManyRedirects):
        # A certificate, URL or redirect-loop problem does not heal between attempts.
        return False
    return isinstance(
        exc,
        aiohttp.ClientConnectionError | aiohttp.ClientPayloadError | ConnectionError | TimeoutError,
    )


def describe_failure(exc: BaseException) -> str:
    """A short, redacted reason for logs and :class:`RetriesExhaustedError`."""
    status = getattr(exc, "status", None)
    if isinstance(exc, ApiStatusError | StorageError) and status is not None:
        return f"HTTP {status}"
    if isinstance(exc, TransportError):
        return exc.reason
    if isinstance(exc, TimeoutError):
        return "timed out"
    text = redact_text(str(exc))
    name = type(exc).__name__
    return f"{name}: {text}" if text else name


def parse_retry_after(value: str | None, *, now: float | None = None) -> float | None:
    """Seconds to wait from a ``Retry-After`` header (delta seconds or an HTTP date)."""
    if not value:
        return None
    value = value.strip()
    try:
        return max(0.0, float(value))
    except ValueError:
        pass
    try:
        moment = email.utils.parsedate_to_datetime(value)
    except (TypeError, ValueError):
        return None
    if moment.tzinfo is None:
        return None
    current = time.time() if now is None else now
    return max(0.0, moment.timestamp() - current)


def trips_gate(exc: BaseException) -> bool:
    """Whether a failure says the origin is failing (5xx, no answer), not pacing us (429)."""
    if isinstance(exc, ApiStatusError | StorageError):
        return exc.status is not None and exc.status >= 500 and exc.status in RETRYABLE_STATUSES
    if isinstance(exc, TransportError):
        return exc.retryable
    return is_transient_transport_failure(exc)


def _is_answer(exc: BaseException) -> bool:
    """An HTTP status that shows the origin is there, though it refused (404, 429, 403...)."""
    return isinstance(exc, ApiStatusError | StorageError) and exc.status is not None


def _retry_after(exc: BaseException | None) -> float | None:
    value = getattr(exc, "retry_after", None)
    return float(value) if isinstance(value, int | float) else None


class _GiveUp(enum.Enum):
    ATTEMPTS = "attempts"
    BUDGET = "budget"
    RETRY_AFTER_CAP = "Retry-After above the cap"
    RETRY_AFTER_BUDGET = "Retry-After beyond the budget"


class _GateTimeoutError(Exception):
    """The request's budget ran out while it waited at its origin's closed gate."""


class _Budget:
    """One request's time budget: its deadline, and why it stopped. The request's identity
    for its origin's gate, too."""

    def __init__(self, policy: RetryPolicy, started: float, gate: OriginGate | None) -> None:
        self.policy = policy
        self.gate = gate
        self.deadline = started + policy.retry_for
        self.reason: _GiveUp | None = None
        self.left_at_stop = 0.0

    def left(self) -> float:
        return self.deadline - self.policy.clock()


class _Wait(wait_base):
    """The pause before the next attempt, never past the budget.

    A pause the server asked for comes first. Otherwise, while the origin's gate is closed,
    the request does not back off on its own: it waits at the gate (see run_attempt), so
    that it resumes with the others.
    """

    def __init__(self, budget: _Budget) -> None:
        self.budget = budget
        self.backoff = budget.policy.backoff_wait()

    def __call__(self, retry_state: RetryCallState) -> float:
        budget = self.budget
        left = max(0.0, budget.left())
        outcome = retry_state.outcome
        retry_after = _retry_after(outcome.exception() if outcome is not None else None)
        if retry_after is not None:
            return min(retry_after, budget.policy.max_retry_after, left)
        if budget.gate is not None and not budget.gate.is_open:
            return 0.0
        return min(self.backoff(retry_state), left)


class _Stop(stop_base):
    """Stop when the budget is spent, or a Retry-After cannot be honoured within it."""

    def __init__(self, budget: _Budget) -> None:
        self.budget = budget

    def __call__(self, retry_state: RetryCallState) -> bool:
        budget = self.budget
        policy = budget.policy
        outcome = retry_state.outcome
        retry_after = _retry_after(outcome.exception() if outcome is not None else None)
        left = budget.left()
        budget.left_at_stop = left
        if policy.max_attempts is not None and retry_state.attempt_number >= policy.max_attempts:
            budget.reason = _GiveUp.ATTEMPTS
        elif retry_after is not None and retry_after > policy.max_retry_after:
            budget.reason = _GiveUp.RETRY_AFTER_CAP
        elif left <= 0:
            budget.reason = _GiveUp.BUDGET
        elif retry_after is not None and retry_after > left:
            budget.reason = _GiveUp.RETRY_AFTER_BUDGET
        return budget.reason is not None


def _new_retrying(
    budget: _Budget,
    *,
    stats: TransferStats,
    method: str,
    url: str,
) -> AsyncRetrying:
    """A fresh :class:`AsyncRetrying` for one request.

    One per request because tenacity keeps its per-call state on the object, which
    concurrent tasks would otherwise share.
    """
    redacted = redact_url(url)
    policy = budget.policy

    def before_sleep(retry_state: RetryCallState) -> None:
        outcome = retry_state.outcome
        exc = outcome.exception() if outcome is not None else None
        reason = describe_failure(exc) if exc is not None else "unknown"
        stats.retries += 1
        stats.retry_reasons[reason.split(":", 1)[0]] += 1
        _log.info(
            "retrying request",
            method=method,
            url=redacted,
            reason=reason,
            attempt=retry_state.attempt_number,
            wait_s=round(retry_state.upcoming_sleep, 3),
            left_s=round(max(0.0, budget.left()), 3),
            retry_for_s=policy.retry_for,
        )

    return AsyncRetrying(
        stop=_Stop(budget),
        wait=_Wait(budget),
        retry=retry_if_exception(is_retryable),
        before_sleep=before_sleep,
        sleep=policy.sleep,
        reraise=False,
    )


def _observe(
    gate: OriginGate,
    exc: BaseException,
    url: str,
    policy: RetryPolicy,
    *,
    request: object,
    sent_in: int,
    probe: bool,
) -> None:
    """Tell the origin's gate what a failed attempt of `request` says about the origin."""
    if trips_gate(exc):
        retry_after = _retry_after(exc)
        if retry_after is not None and retry_after > policy.max_retry_after:
            retry_after = None  # not honoured: that request ends instead (see _Stop)
        gate.failed(
            request=request,
            reason=describe_failure(exc),
            origin=str(URL(url, encoded=True).origin()),
            retry_after=retry_after,
            probe=probe,
        )
    elif _is_answer(exc):
        gate.answered(sent_in)


async def call_with_retries(
    attempt: Callable[[], Awaitable[_T]],
    policy: RetryPolicy,
    *,
    stats: TransferStats,
    method: str,
    url: str,
    gate: OriginGate | None = None,
) -> _T:
    """Await ``attempt()`` until it succeeds, fails for good, or its time budget is spent.

    A non-transient error propagates unchanged after its first occurrence. Running out of
    budget raises :class:`OriginUnavailableError` when the origin's `gate` is closed (the
    origin is failing, not just this request), else :class:`RetriesExhaustedError` naming
    the last transient failure; a ``Retry-After`` that cannot be honoured raises
    :class:`RetryAfterTooLongError` at once.
    """
    budget: _Budget | None = None
    first_failure: Exception | None = None
    # The first attempt runs outside tenacity: almost every request succeeds at once, and
    # building and driving an AsyncRetrying cost a fifth of the client's CPU per request
    # (measured at 0 ms latency). A failure is handed to tenacity as its own first attempt
    # (replayed below), so counting, waits, logging and the stop rule are unchanged. At a
    # closed gate, the first attempt waits there inside the loop instead.
    if gate is None or gate.is_open:
        sent_in = 0 if gate is None else gate.closures
        try:
            result = await attempt()
        except Exception as exc:
            # Made only now, and the budget counted from here: most requests never need
            # one, and the clock is not free.
            budget = _Budget(policy, policy.clock(), gate)
            if gate is not None:
                _observe(gate, exc, url, policy, request=budget, sent_in=sent_in, probe=False)
            if not is_retryable(exc):
                raise
            first_failure = exc
        else:
            if gate is not None:
                gate.answered(sent_in)
            return result

    if budget is None:
        budget = _Budget(policy, policy.clock(), gate)
    retrying = _new_retrying(budget, stats=stats, method=method, url=url)

    # tenacity awaits only what it recognises as a coroutine function, not any callable
    # returning an awaitable (a lambda, a bound partial).
    async def run_attempt() -> _T:
        nonlocal first_failure
        if first_failure is not None:
            failure, first_failure = first_failure, None
            raise failure
        if gate is None or gate.is_open:
            passage = Passage.OPEN
        else:
            passage = await gate.enter(budget.deadline)
            if passage is Passage.TIMED_OUT:
                raise _GateTimeoutError
        sent_in = 0 if gate is None else gate.closures
        try:
            result = await attempt()
        except Exception as exc:
            if gate is not None:
                _observe(
                    gate,
                    exc,
                    url,
                    policy,
                    request=budget,
                    sent_in=sent_in,
                    probe=passage is Passage.PROBE,
                )
            raise
        else:
            if gate is not None:
                gate.answered(sent_in)
            return result
        finally:
            if gate is not None and passage is Passage.PROBE:
                gate.probe_finished()

    try:
        return await retrying(run_attempt)
    except _GateTimeoutError:
        budget.reason = _GiveUp.BUDGET
        last: BaseException | None = None
        # The attempt that timed out at the gate was never sent.
        attempts = max(int(retrying.statistics.get("attempt_number", 1)) - 1, 0)
    except RetryError as exhausted:
        last = exhausted.last_attempt.exception()
        attempts = exhausted.last_attempt.attempt_number
    raise _give_up(budget, last, attempts, method=method, url=url) from None


def _give_up(
    budget: _Budget, last: BaseException | None, attempts: int, *, method: str, url: str
) -> Exception:
    """The error that ends a request whose retries stopped (see :class:`_Stop`)."""
    policy = budget.policy
    gate = budget.gate
    retry_after = _retry_after(last)
    status = getattr(last, "status", None)
    status = status if isinstance(status, int) else None
    if budget.reason is _GiveUp.RETRY_AFTER_CAP and retry_after is not None:
        return RetryAfterTooLongError(
            method=method,
            url=url,
            status=status,
            retry_after=retry_after,
            limit=f"the {policy.max_retry_after:g} s stook waits at most",
        )
    if budget.reason is _GiveUp.RETRY_AFTER_BUDGET and retry_after is not None:
        return RetryAfterTooLongError(
            method=method,
            url=url,
            status=status,
            retry_after=retry_after,
            limit=(
                f"the {max(budget.left_at_stop, 0.0):.1f} s left of its "
                f"{policy.retry_for:g} s [fetch] retry_for"
            ),
        )
    if last is not None:
        reason = describe_failure(last)
    elif gate is not None and gate.last_failure:
        reason = gate.last_failure
    else:
        reason = "unknown"
    if budget.reason is _GiveUp.BUDGET and gate is not None and not gate.is_open:
        # Requests of many kinds fail and none is answered: the origin is down, and every
        # other request would wait out its budget the same way.
        return OriginUnavailableError(
            label=gate.label,
            origin=gate.origin or str(URL(url, encoded=True).origin()),
            retry_for=policy.retry_for,
            last_reason=reason,
        )
    return RetriesExhaustedError(
        method=method,
        url=url,
        attempts=attempts,
        last_reason=reason,
        last_status=status,
    )
