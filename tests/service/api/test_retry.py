"""The retry policy in isolation: what is transient, how long to wait, what is counted."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from datetime import UTC, datetime
from email.utils import format_datetime

import aiohttp
import pytest
from tenacity import wait_none

from stook.service.api._errors import (
    ApiStatusError,
    AuthError,
    IncompleteBodyError,
    NotFoundError,
    PresignedUrlExpiredError,
    RetriesExhaustedError,
    RetryAfterTooLongError,
    StorageError,
    TransportError,
)
from stook.service.api._retry import RetryPolicy, is_retryable, parse_retry_after
from stook.service.api._retrying import call_with_retries
from stook.service.api._stats import TransferStats
from tests.service.conftest import RecordingSleep

URL = "https://api.example.com/v1/x"


def status_error(status: int) -> ApiStatusError:
    return ApiStatusError(status=status, method="GET", url=URL)


@pytest.mark.parametrize(
    ("exc", "retryable"),
    [
        (status_error(500), True),
        (status_error(503), True),
        (status_error(429), True),
        (status_error(400), False),
        (AuthError(status=401, method="GET", url=URL), False),
        (AuthError(status=403, method="GET", url=URL), False),
        (NotFoundError(status=404, method="GET", url=URL), False),
        (StorageError("x", url=URL, status=502), True),
        (PresignedUrlExpiredError("x", url=URL, status=403), False),
        (StorageError("x", url=URL), False),
        (TransportError(method="GET", url=URL, reason="reset"), True),
        (TransportError(method="GET", url=URL, reason="bad cert", retryable=False), False),
        (IncompleteBodyError(method="GET", url=URL, received=1, expected=2), True),
        (aiohttp.ServerDisconnectedError(), True),
        (aiohttp.ClientPayloadError("truncated"), True),
        (aiohttp.ClientConnectionError(), True),
        (TimeoutError(), True),
        (ConnectionResetError(), True),
        (aiohttp.TooManyRedirects(None, ()), False),  # type: ignore[arg-type]
        (ValueError("a bug"), False),
    ],
)
def test_is_retryable(exc: BaseException, retryable: bool) -> None:
    assert is_retryable(exc) is retryable


def test_parse_retry_after() -> None:
    assert parse_retry_after(None) is None
    assert parse_retry_after("") is None
    assert parse_retry_after("3") == 3.0
    assert parse_retry_after(" 0.5 ") == 0.5
    assert parse_retry_after("-4") == 0.0
    assert parse_retry_after("soon") is None
    moment = datetime(2030, 1, 1, 0, 0, 10, tzinfo=UTC)
    now = datetime(2030, 1, 1, 0, 0, 0, tzinfo=UTC).timestamp()
    assert parse_retry_after(format_datetime(moment, usegmt=True), now=now) == 10.0


def test_policy_defaults_and_validation() -> None:
    policy = RetryPolicy()
    assert policy.retry_for == 120.0
    assert policy.max_attempts is None  # bounded by time alone
    assert policy.initial_backoff == 0.2
    assert policy.max_backoff == 10.0
    assert policy.max_retry_after == 60.0
    assert policy.request_timeout == 30.0
    with pytest.raises(ValueError, match="max_attempts"):
        RetryPolicy(max_attempts=0)
    with pytest.raises(ValueError, match="retry_for"):
        RetryPolicy(retry_for=0)


async def test_call_with_retries_counts_and_gives_up(sleep: RecordingSleep) -> None:
    stats = TransferStats()
    calls = 0

    async def always_503() -> None:
        nonlocal calls
        calls += 1
        raise status_error(503)

    policy = RetryPolicy(backoff=wait_none(), sleep=sleep, max_attempts=4)
    with pytest.raises(RetriesExhaustedError) as caught:
        await call_with_retries(always_503, policy, stats=stats, method="GET", url=URL)
    assert calls == 4
    assert stats.retries == 3
    assert stats.retry_reasons == {"HTTP 503": 3}
    assert caught.value.attempts == 4
    assert caught.value.__cause__ is None
    assert stats.as_dict()["retries"] == 3


async def test_call_with_retries_lets_permanent_errors_through(sleep: RecordingSleep) -> None:
    calls = 0

    async def not_found() -> None:
        nonlocal calls
        calls += 1
        raise NotFoundError(status=404, method="GET", url=URL)

    policy = RetryPolicy(backoff=wait_none(), sleep=sleep)
    with pytest.raises(NotFoundError):
        await call_with_retries(not_found, policy, stats=TransferStats(), method="GET", url=URL)
    assert calls == 1
    assert sleep.waits == []


async def test_call_with_retries_returns_the_value(sleep: RecordingSleep) -> None:
    answers = iter([TransportError(method="GET", url=URL, reason="reset"), None])

    async def flaky() -> str:
        failure = next(answers)
        if failure is not None:
            raise failure
        return "done"

    policy = RetryPolicy(backoff=wait_none(), sleep=sleep)
    assert await call_with_retries(flaky, policy, stats=TransferStats(), method="GET", url=URL) == (
        "done"
    )
    assert sleep.waits == [0.0]


def _scripted(
    failures: list[BaseException],
) -> tuple[list[int], Callable[[], Awaitable[str]]]:
    """An attempt that raises `failures` in order, then returns "done"; counts its calls."""
    calls = [0]
    remaining = iter(failures)

    async def attempt() -> str:
        calls[0] += 1
        failure = next(remaining, None)
        if failure is not None:
            raise failure
        return "done"

    return calls, attempt


async def test_retries_last_the_time_budget_not_a_count(sleep: RecordingSleep) -> None:
    """Production backoff on a clock that advances with each pause: the request retries
    for the whole of `retry_for`, with full-jitter pauses from 0.2 s up to 10 s, and
    never sleeps past the budget."""
    calls, attempt = _scripted([status_error(503)] * 10_000)
    policy = RetryPolicy(retry_for=120.0, sleep=sleep, clock=sleep.now)
    with pytest.raises(RetriesExhaustedError) as caught:
        await call_with_retries(attempt, policy, stats=TransferStats(), method="GET", url=URL)
    assert calls[0] > 6  # the old count; 120 s of backoff holds about 25 attempts
    assert calls[0] == len(sleep.waits) + 1
    assert caught.value.attempts == calls[0]
    assert sum(sleep.waits) == pytest.approx(120.0)
    for retry, wait in enumerate(sleep.waits):
        assert 0 <= wait <= min(10.0, 0.2 * 2**retry)


async def test_an_outage_shorter_than_the_budget_is_ridden_out(sleep: RecordingSleep) -> None:
    calls = 0

    async def down_for_a_minute() -> str:
        nonlocal calls
        calls += 1
        if sleep.now() < 60.0:
            raise status_error(503)
        return "done"

    policy = RetryPolicy(retry_for=120.0, sleep=sleep, clock=sleep.now)
    got = await call_with_retries(
        down_for_a_minute, policy, stats=TransferStats(), method="GET", url=URL
    )
    assert got == "done"
    assert 60.0 <= sleep.now() <= 70.0  # back within one capped pause of the recovery


async def test_a_retry_after_beyond_the_cap_ends_the_request_at_once(
    sleep: RecordingSleep,
) -> None:
    throttled = ApiStatusError(status=429, method="GET", url=URL, retry_after=3600.0)
    calls, attempt = _scripted([throttled] * 100)
    policy = RetryPolicy(sleep=sleep, clock=sleep.now)
    with pytest.raises(RetryAfterTooLongError) as caught:
        await call_with_retries(attempt, policy, stats=TransferStats(), method="GET", url=URL)
    assert calls[0] == 1
    assert sleep.waits == []
    message = str(caught.value)
    assert "Retry-After: 3600" in message
    assert "the 60 s stook waits at most" in message
    assert "HTTP 429" in message


async def test_a_retry_after_beyond_the_budget_left_ends_the_request(
    sleep: RecordingSleep,
) -> None:
    unavailable = ApiStatusError(status=503, method="GET", url=URL, retry_after=30.0)
    calls, attempt = _scripted([unavailable] * 100)
    policy = RetryPolicy(retry_for=10.0, sleep=sleep, clock=sleep.now)
    with pytest.raises(RetryAfterTooLongError, match=r"left of its 10 s \[fetch\] retry_for"):
        await call_with_retries(attempt, policy, stats=TransferStats(), method="GET", url=URL)
    assert calls[0] == 1
    assert sleep.waits == []


async def test_a_retry_after_within_the_cap_and_budget_is_waited(sleep: RecordingSleep) -> None:
    throttled = ApiStatusError(status=429, method="GET", url=URL, retry_after=45.0)
    calls, attempt = _scripted([throttled, throttled])
    policy = RetryPolicy(sleep=sleep, clock=sleep.now)
    got = await call_with_retries(attempt, policy, stats=TransferStats(), method="GET", url=URL)
    assert got == "done"
    assert calls[0] == 3
    assert sleep.waits == [45.0, 45.0]
