"""When and how long to retry a request, built on tenacity.

What is transient: 5xx and 429 answers (honouring ``Retry-After``), connection resets and
refusals, timeouts, and bodies cut short. What is not: every other 4xx — asking again with
the same token or ID gets the same answer — and anything that is not a transport problem.
"""

from __future__ import annotations

import asyncio
import email.utils
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

from stook.service._errors import (
    ApiStatusError,
    RetriesExhaustedError,
    StorageError,
    TransportError,
)
from stook.service._logging import get_logger
from stook.service._redact import redact_text, redact_url

__all__ = [
    "RetryPolicy",
    "TransferStats",
    "call_with_retries",
    "describe_failure",
    "is_retryable",
    "is_transient_transport_failure",
    "new_retrying",
    "parse_retry_after",
]

_log = get_logger("stook.service.retry")

_T = TypeVar("_T")

THROTTLED_STATUS: Final = 429
RETRYABLE_STATUSES: Final = frozenset({THROTTLED_STATUS}) | frozenset(range(500, 600))


@dataclass(frozen=True, slots=True)
class RetryPolicy:
    """How often and how patiently to retry one request.

    ``backoff`` and ``sleep`` exist so tests (and the emulator) can run without waiting:
    ``RetryPolicy(backoff=tenacity.wait_none())`` keeps every other rule but never pauses,
    and a recording ``sleep`` shows exactly which pauses were asked for.
    """

    max_attempts: int = 6
    # A 429 is the server pacing us, not failing: it spends this larger allowance instead,
    # so that a client over a strict rate limit slows down rather than gives up.
    max_throttled_attempts: int = 30
    initial_backoff: float = 0.05
    max_backoff: float = 5.0
    # A server may ask for a long pause; beyond this we would rather spend an attempt.
    max_retry_after: float = 30.0
    request_timeout: float = 30.0
    backoff: wait_base | None = None
    sleep: Callable[[float], Awaitable[None]] = asyncio.sleep

    def __post_init__(self) -> None:
        if self.max_attempts < 1:
            raise ValueError(f"max_attempts must be at least 1, got {self.max_attempts}")
        if self.max_throttled_attempts < 1:
            raise ValueError(
                f"max_throttled_attempts must be at least 1, got {self.max_throttled_attempts}"
            )
        if self.request_timeout <= 0:
            raise ValueError(f"request_timeout must be positive, got {self.request_timeout}")

    def backoff_wait(self) -> wait_base:
        """The pause before a retry when the server did not name one: full-jitter exponential."""
        if self.backoff is not None:
            return self.backoff
        return wait_random_exponential(multiplier=self.initial_backoff, max=self.max_backoff)


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


class _WaitRetryAfterOrBackoff(wait_base):
    """Wait as long as the server asked (capped), else fall back to the backoff strategy."""

    def __init__(self, backoff: wait_base, cap: float) -> None:
        self.backoff = backoff
        self.cap = cap

    def __call__(self, retry_state: RetryCallState) -> float:
        outcome = retry_state.outcome
        exc = outcome.exception() if outcome is not None else None
        retry_after = getattr(exc, "retry_after", None)
        if isinstance(retry_after, int | float):
            return min(float(retry_after), self.cap)
        return self.backoff(retry_state)


class _StopAfterAttempts(stop_base):
    """Stop after `attempts` failed attempts, where a 429 answer counts against `throttled`.

    Stateful, which is safe because every request gets its own AsyncRetrying.
    """

    def __init__(self, attempts: int, throttled: int) -> None:
        self._attempts = attempts
        self._throttled = throttled
        self._failures = 0
        self._throttles = 0

    def __call__(self, retry_state: RetryCallState) -> bool:
        outcome = retry_state.outcome
        failure = outcome.exception() if outcome is not None else None
        if getattr(failure, "status", None) == THROTTLED_STATUS:
            self._throttles += 1
        else:
            self._failures += 1
        return self._failures >= self._attempts or self._throttles >= self._throttled


def new_retrying(
    policy: RetryPolicy,
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

    def before_sleep(retry_state: RetryCallState) -> None:
        outcome = retry_state.outcome
        exc = outcome.exception() if outcome is not None else None
        reason = describe_failure(exc) if exc is not None else "unknown"
        stats.retries += 1
        stats.retry_reasons[reason.split(":", 1)[0]] += 1
        wait = retry_state.upcoming_sleep
        _log.info(
            "retrying request",
            method=method,
            url=redacted,
            reason=reason,
            attempt=retry_state.attempt_number,
            max_attempts=policy.max_attempts,
            max_throttled_attempts=policy.max_throttled_attempts,
            wait_s=round(wait, 3),
        )

    return AsyncRetrying(
        stop=_StopAfterAttempts(policy.max_attempts, policy.max_throttled_attempts),
        wait=_WaitRetryAfterOrBackoff(policy.backoff_wait(), policy.max_retry_after),
        retry=retry_if_exception(is_retryable),
        before_sleep=before_sleep,
        sleep=policy.sleep,
        reraise=False,
    )


async def call_with_retries(
    attempt: Callable[[], Awaitable[_T]],
    policy: RetryPolicy,
    *,
    stats: TransferStats,
    method: str,
    url: str,
) -> _T:
    """Await ``attempt()`` until it succeeds, fails for good, or the policy gives up.

    A non-transient error propagates unchanged after its first occurrence; running out of
    attempts raises :class:`RetriesExhaustedError` naming the last transient failure.
    """
    # The first attempt runs outside tenacity: almost every request succeeds at once, and
    # building and driving an AsyncRetrying cost a fifth of the client's CPU per request
    # (measured at 0 ms latency). A failure is handed to tenacity as its own first attempt
    # (replayed below), so counting, waits, logging and the stop rule are unchanged.
    try:
        return await attempt()
    except Exception as exc:
        if not is_retryable(exc):
            raise
        first_failure: Exception | None = exc

    retrying = new_retrying(policy, stats=stats, method=method, url=url)

    # tenacity awaits only what it recognises as a coroutine function, not any callable
    # returning an awaitable (a lambda, a bound partial).
    async def run_attempt() -> _T:
        nonlocal first_failure
        if first_failure is not None:
            failure, first_failure = first_failure, None
            raise failure
        return await attempt()

    try:
        return await retrying(run_attempt)
    except RetryError as exhausted:
        last = exhausted.last_attempt.exception()
        last_status = getattr(last, "status", None)
        raise RetriesExhaustedError(
            method=method,
            url=url,
            attempts=exhausted.last_attempt.attempt_number,
            last_reason=describe_failure(last) if last is not None else "unknown",
            last_status=last_status if isinstance(last_status, int) else None,
        ) from None
