"""The retry policy in isolation: what is transient, how long to wait, what is counted."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from datetime import UTC, datetime
from email.utils import format_datetime

import aiohttp
import pytest
from tenacity import wait_none

from stook.service._errors import (
    ApiStatusError,
    AuthError,
    IncompleteBodyError,
    NotFoundError,
    PresignedUrlExpiredError,
    RetriesExhaustedError,
    StorageError,
    TransportError,
)
from stook.service._retry import (
    RetryPolicy,
    TransferStats,
    call_with_retries,
    is_retryable,
    parse_retry_after,
)
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
    assert policy.max_attempts == 6
    assert policy.initial_backoff == 0.05
    assert policy.max_backoff == 5.0
    assert policy.request_timeout == 30.0
    with pytest.raises(ValueError, match="max_attempts"):
        RetryPolicy(max_attempts=0)


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


async def test_throttling_answers_spend_their_own_larger_allowance(sleep: RecordingSleep) -> None:
    # Ten 429s are more than max_attempts, but a server pacing us is not failing.
    calls, attempt = _scripted([status_error(429)] * 10)
    policy = RetryPolicy(backoff=wait_none(), sleep=sleep, max_attempts=3)
    got = await call_with_retries(attempt, policy, stats=TransferStats(), method="GET", url=URL)
    assert got == "done"
    assert calls[0] == 11


async def test_throttling_allowance_runs_out_too(sleep: RecordingSleep) -> None:
    calls, attempt = _scripted([status_error(429)] * 100)
    policy = RetryPolicy(backoff=wait_none(), sleep=sleep, max_throttled_attempts=7)
    with pytest.raises(RetriesExhaustedError) as caught:
        await call_with_retries(attempt, policy, stats=TransferStats(), method="GET", url=URL)
    assert calls[0] == 7
    assert caught.value.last_status == 429


async def test_throttles_do_not_buy_extra_failures(sleep: RecordingSleep) -> None:
    # 429s between them do not reset the count of real failures.
    failures: list[BaseException] = [status_error(503), status_error(429)] * 3
    calls, attempt = _scripted(failures)
    policy = RetryPolicy(backoff=wait_none(), sleep=sleep, max_attempts=3)
    with pytest.raises(RetriesExhaustedError) as caught:
        await call_with_retries(attempt, policy, stats=TransferStats(), method="GET", url=URL)
    assert calls[0] == 5  # 503, 429, 503, 429, 503: the third failure stops it
    assert caught.value.last_status == 503


def test_throttled_allowance_is_validated() -> None:
    assert RetryPolicy().max_throttled_attempts == 30
    with pytest.raises(ValueError, match="max_throttled_attempts"):
        RetryPolicy(max_throttled_attempts=0)
