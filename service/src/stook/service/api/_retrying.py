"""One request's attempts, run by the retry policy's rules within its time budget.

The attempts run on tenacity, with a stop and a wait of stook's own: the request stops when
its ``retry_for`` budget is spent or a ``Retry-After`` cannot be honoured within it, and
never sleeps past the budget. While its origin's gate is closed it waits there with the
other requests instead of backing off alone. What to retry and how long are the policy's
(:mod:`stook.service.api._retry`); what ends a request that stopped is one error naming
why (:func:`_give_up`).

tenacity is imported by the first request that fails (or meets a closed gate): most runs
never retry, and importing it cost ~24 M instructions of every start-up.
"""

from __future__ import annotations

import enum
from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING, TypeVar

from yarl import URL

from stook.service.api._errors import (
    OriginUnavailableError,
    RetriesExhaustedError,
    RetryAfterTooLongError,
)
from stook.service.api._gate import OriginGate, Passage
from stook.service.api._logging import get_logger
from stook.service.api._redact import redact_url
from stook.service.api._retry import (
    RetryPolicy,
    describe_failure,
    is_answer,
    is_retryable,
    retry_after_of,
    trips_gate,
)
from stook.service.api._stats import TransferStats

if TYPE_CHECKING:
    from tenacity import AsyncRetrying, RetryCallState

__all__ = ["call_with_retries", "sent_at_once"]

_log = get_logger("stook.service.retry")

_T = TypeVar("_T")


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


class _Wait:
    """The pause before the next attempt, never past the budget (a tenacity wait).

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
        retry_after = retry_after_of(outcome.exception() if outcome is not None else None)
        if retry_after is not None:
            return min(retry_after, budget.policy.max_retry_after, left)
        if budget.gate is not None and not budget.gate.is_open:
            return 0.0
        return min(self.backoff(retry_state), left)


class _Stop:
    """Stop when the budget is spent, or a Retry-After cannot be honoured within it (a
    tenacity stop)."""

    def __init__(self, budget: _Budget) -> None:
        self.budget = budget

    def __call__(self, retry_state: RetryCallState) -> bool:
        budget = self.budget
        policy = budget.policy
        outcome = retry_state.outcome
        retry_after = retry_after_of(outcome.exception() if outcome is not None else None)
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
    url: str | URL,
) -> AsyncRetrying:
    """A fresh :class:`AsyncRetrying` for one request.

    One per request because tenacity keeps its per-call state on the object, which
    concurrent tasks would otherwise share.
    """
    from tenacity import AsyncRetrying, retry_if_exception

    redacted = redact_url(url)
    policy = budget.policy

    def before_sleep(retry_state: RetryCallState) -> None:
        outcome = retry_state.outcome
        exc = outcome.exception() if outcome is not None else None
        reason = describe_failure(exc) if exc is not None else "unknown"
        stats.retries += 1
        stats.retry_reasons[reason.split(":", 1)[0]] += 1
        # At debug level: a run counts its retries (the progress bar, the progress events
        # and the final summary); a line per retry would bury the display under URLs.
        _log.debug(
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
    url: str | URL,
    policy: RetryPolicy,
    *,
    request: object,
    sent_in: int,
    probe: bool,
) -> None:
    """Tell the origin's gate what a failed attempt of `request` says about the origin."""
    if trips_gate(exc):
        retry_after = retry_after_of(exc)
        if retry_after is not None and retry_after > policy.max_retry_after:
            retry_after = None  # not honoured: that request ends instead (see _Stop)
        gate.failed(
            request=request,
            reason=describe_failure(exc),
            origin=str(URL(url, encoded=True).origin()),
            retry_after=retry_after,
            probe=probe,
        )
    elif is_answer(exc):
        gate.answered(sent_in)


def sent_at_once(gate: OriginGate | None) -> int | None:
    """Whether a request's first attempt may leave at once, and if so the gate's
    `closures` as it leaves (the `sent_in` of `OriginGate.answered`); None while the gate
    is closed (the request then goes through `call_with_retries` whole).

    A caller may send that attempt in its own frame rather than through
    `call_with_retries`: one coroutine layer fewer for each of the attempt's resumptions,
    for nearly every request. On success it tells the gate (`gate.answered(sent_in)`); on
    a failure it hands the error on as ``call_with_retries(..., first=(error, sent_in))``,
    which goes on exactly as if it had sent that attempt itself.
    """
    if gate is None:
        return 0
    return gate.closures if gate.is_open else None


def _first_failed(
    exc: Exception, sent_in: int, policy: RetryPolicy, gate: OriginGate | None, url: str | URL
) -> _Budget:
    """The budget of a request whose first attempt, sent at once, failed with `exc`; the
    gate hears of the failure."""
    # Made only now, and the budget counted from here: most requests never need one, and
    # the clock is not free.
    budget = _Budget(policy, policy.clock(), gate)
    if gate is not None:
        _observe(gate, exc, url, policy, request=budget, sent_in=sent_in, probe=False)
    return budget


async def call_with_retries(
    attempt: Callable[[], Awaitable[_T]],
    policy: RetryPolicy,
    *,
    stats: TransferStats,
    method: str,
    url: str | URL,
    gate: OriginGate | None = None,
    first: tuple[Exception, int] | None = None,
) -> _T:
    """Await ``attempt()`` until it succeeds, fails for good, or its time budget is spent.

    A non-transient error propagates unchanged after its first occurrence. Running out of
    budget raises :class:`OriginUnavailableError` when the origin's `gate` is closed (the
    origin is failing, not just this request), else :class:`RetriesExhaustedError` naming
    the last transient failure; a ``Retry-After`` that cannot be honoured raises
    :class:`RetryAfterTooLongError` at once.

    `first`: the caller sent the first attempt itself (see `sent_at_once`), and it failed
    with this error, sent in this state of the gate.
    """
    budget: _Budget | None = None
    first_failure: Exception | None = None
    # The first attempt runs outside tenacity: almost every request succeeds at once, and
    # building and driving an AsyncRetrying cost a fifth of the client's CPU per request
    # (measured at 0 ms latency). A failure is handed to tenacity as its own first attempt
    # (replayed below), so counting, waits, logging and the stop rule are unchanged. At a
    # closed gate, the first attempt waits there inside the loop instead.
    if first is not None:
        first_failure, first_sent_in = first
        budget = _first_failed(first_failure, first_sent_in, policy, gate, url)
        if not is_retryable(first_failure):
            raise first_failure
    elif (sent_in := sent_at_once(gate)) is not None:
        try:
            result = await attempt()
        except Exception as exc:
            budget = _first_failed(exc, sent_in, policy, gate, url)
            if not is_retryable(exc):
                raise
            first_failure = exc
        else:
            if gate is not None:
                gate.answered(sent_in)
            return result

    # Only a request that failed or met a closed gate gets here, and imports tenacity.
    from tenacity import RetryError

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
    budget: _Budget, last: BaseException | None, attempts: int, *, method: str, url: str | URL
) -> Exception:
    """The error that ends a request whose retries stopped (see :class:`_Stop`)."""
    policy = budget.policy
    gate = budget.gate
    retry_after = retry_after_of(last)
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
