"""When and how long to retry a request: the policy, and which failures it retries.

What is transient: 5xx and 429 answers (honouring ``Retry-After``), connection resets and
refusals, timeouts, and bodies cut short. What is not: every other 4xx — asking again with
the same token or ID gets the same answer — and anything that is not a transport problem.
A failure that reached the transport says for itself whether it may heal
(``TransportError.retryable``, set by the transport that classified it).

How long: each request has a budget in time, ``retry_for`` (120 s by default), not a count
of attempts, so an API that is down for a minute costs the run a minute, not the run. The
pauses between attempts grow exponentially with full jitter from ``initial_backoff`` up to
``max_backoff``, and are cut short rather than sleep past the budget. A ``Retry-After`` is
honoured up to ``max_retry_after``; a longer one, or one longer than what is left of the
budget, ends the request at once with an error naming it. When an origin fails as a whole,
its :class:`~stook.service.api._gate.OriginGate` makes the requests wait together.
:mod:`stook.service.api._retrying` runs a request's attempts by these rules.
"""

from __future__ import annotations

import asyncio
import email.utils
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final

from stook.service.api._errors import ApiStatusError, StorageError, TransportError
from stook.service.api._gate import OriginGate
from stook.service.api._redact import redact_text
from stook.service.api._transport import is_transient_transport_failure

if TYPE_CHECKING:
    # tenacity (~24 M instructions to import) is imported by the first request that fails:
    # most runs never retry, and none needs it before its first request.
    from tenacity.wait import wait_base

__all__ = [
    "RETRYABLE_STATUSES",
    "RetryPolicy",
    "describe_failure",
    "is_answer",
    "is_retryable",
    "new_gate",
    "parse_retry_after",
    "retry_after_of",
    "trips_gate",
]

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
        from tenacity import wait_random_exponential

        return wait_random_exponential(multiplier=self.initial_backoff, max=self.max_backoff)

    def pause(self, attempt: int) -> float:
        """The backoff after the `attempt`-th failure, outside a tenacity loop (the gate's)."""
        from tenacity import AsyncRetrying, RetryCallState

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


def is_retryable(exc: BaseException) -> bool:
    """Whether asking again could give a different answer.

    An answer's status decides for an API or storage error; a transport failure says for
    itself (``TransportError.retryable``). Anything else an attempt raises is classified as
    the transport classifies what aiohttp and sockets raise.
    """
    if isinstance(exc, ApiStatusError | StorageError):
        return exc.status is not None and exc.status in RETRYABLE_STATUSES
    if isinstance(exc, TransportError):
        return exc.retryable
    return is_transient_transport_failure(exc)


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


def is_answer(exc: BaseException) -> bool:
    """An HTTP status that shows the origin is there, though it refused (404, 429, 403...)."""
    return isinstance(exc, ApiStatusError | StorageError) and exc.status is not None


def retry_after_of(exc: BaseException | None) -> float | None:
    value = getattr(exc, "retry_after", None)
    return float(value) if isinstance(value, int | float) else None
