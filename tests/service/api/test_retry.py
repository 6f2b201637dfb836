"""Retries (stook.service.api._retry): what is transient, how long and how patiently to
retry, first contact, and how requests to a failing origin wait together. No real sleeps:
the policy's `sleep` records each pause and its `clock` advances by it."""

from __future__ import annotations

import asyncio
import socket
from collections.abc import Awaitable, Callable, Iterator
from datetime import UTC, datetime
from email.utils import format_datetime

import aiohttp
import pytest
import yarl
from aiohttp import web

from stook.service.api import (
    ApiClient,
    ApiStatusError,
    AuthError,
    NotFoundError,
    OriginUnavailableError,
    OriginUnreachableError,
    PresignedUrlExpiredError,
    RetriesExhaustedError,
    RetryAfterTooLongError,
    RetryPolicy,
    StorageError,
    TrafficCounts,
    TransportError,
)
from stook.service.api._retry import Origin, is_retryable, parse_retry_after, send
from stook.service.api._transport import transport_error
from tests.service.conftest import RecordingSleep
from tests.service.scripted_server import ScriptedServer, answer, answer_json

URL = "https://api.example.com/v1/x"
PROJECT = "11111111-1111-4111-8111-111111111111"
BATCH = "22222222-2222-4222-8222-222222222222"
BATCH_PATH = f"/v1/projects/{PROJECT}/batches/{BATCH}"


def status_error(status: int) -> ApiStatusError:
    return ApiStatusError(status=status, method="GET", url=URL)


def refused() -> TransportError:
    return TransportError(method="GET", url=URL, reason="refused", kind="connect")


async def retried(
    attempt: Callable[[], Awaitable[str]],
    policy: RetryPolicy,
    *,
    stats: TrafficCounts | None = None,
    origin: Origin | None = None,
) -> str:
    """`send` for an origin that has answered before (unless one is passed)."""
    if origin is None:
        origin = Origin("the API", policy, setting="apiURL")
        origin.answered = True
    return await send(attempt, origin, url=yarl.URL(URL), stats=stats or TrafficCounts())


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
        (TransportError(method="GET", url=URL, reason="bad cert", kind="permanent"), False),
        (TransportError(method="GET", url=URL, reason="body ended after 1 of 2 bytes"), True),
        (ValueError("a bug"), False),
    ],
)
def test_is_retryable(exc: BaseException, retryable: bool) -> None:
    assert is_retryable(exc) is retryable


@pytest.mark.parametrize(
    ("exc", "kind"),
    [
        (aiohttp.ServerDisconnectedError(), "broken"),
        (aiohttp.ClientPayloadError("truncated"), "broken"),
        (aiohttp.ClientConnectionError(), "broken"),
        (ConnectionResetError(), "broken"),
        (TimeoutError(), "timeout"),
        (aiohttp.InvalidURL("x"), "permanent"),
    ],
)
def test_what_aiohttp_raises_is_mapped_in_one_place(exc: BaseException, kind: str) -> None:
    error = transport_error(exc, yarl.URL(URL + "?X-Amz-Signature=secret"), 30.0)
    assert error.kind == kind
    assert "secret" not in str(error)


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


async def test_send_counts_and_gives_up(sleep: RecordingSleep) -> None:
    stats = TrafficCounts()
    calls = 0

    async def always_503() -> str:
        nonlocal calls
        calls += 1
        raise status_error(503)

    policy = RetryPolicy(initial_backoff=0, sleep=sleep, max_attempts=4)
    with pytest.raises(RetriesExhaustedError) as caught:
        await retried(always_503, policy, stats=stats)
    assert calls == 4
    assert stats.retries == 3
    assert caught.value.attempts == 4
    assert caught.value.__cause__ is None


async def test_send_lets_permanent_errors_through(sleep: RecordingSleep) -> None:
    calls = 0

    async def not_found() -> str:
        nonlocal calls
        calls += 1
        raise NotFoundError(status=404, method="GET", url=URL)

    policy = RetryPolicy(initial_backoff=0, sleep=sleep)
    with pytest.raises(NotFoundError):
        await retried(not_found, policy)
    assert calls == 1
    assert sleep.waits == []


async def test_send_returns_the_value(sleep: RecordingSleep) -> None:
    answers = iter([TransportError(method="GET", url=URL, reason="reset"), None])

    async def flaky() -> str:
        failure = next(answers)
        if failure is not None:
            raise failure
        return "done"

    policy = RetryPolicy(initial_backoff=0, sleep=sleep)
    assert await retried(flaky, policy) == "done"
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
        await retried(attempt, policy)
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
    got = await retried(down_for_a_minute, policy)
    assert got == "done"
    assert 60.0 <= sleep.now() <= 70.0  # back within one capped pause of the recovery


async def test_a_retry_after_beyond_the_cap_ends_the_request_at_once(
    sleep: RecordingSleep,
) -> None:
    throttled = ApiStatusError(status=429, method="GET", url=URL, retry_after=3600.0)
    calls, attempt = _scripted([throttled] * 100)
    policy = RetryPolicy(sleep=sleep, clock=sleep.now)
    with pytest.raises(RetryAfterTooLongError) as caught:
        await retried(attempt, policy)
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
        await retried(attempt, policy)
    assert calls[0] == 1
    assert sleep.waits == []


async def test_a_retry_after_within_the_cap_and_budget_is_waited(sleep: RecordingSleep) -> None:
    throttled = ApiStatusError(status=429, method="GET", url=URL, retry_after=45.0)
    calls, attempt = _scripted([throttled, throttled])
    policy = RetryPolicy(sleep=sleep, clock=sleep.now)
    got = await retried(attempt, policy)
    assert got == "done"
    assert calls[0] == 3
    assert sleep.waits == [45.0, 45.0]


# -- first contact -------------------------------------------------------------------------


@pytest.fixture
def refusing_port() -> Iterator[int]:
    """A port bound and never listening: connections to it are refused, and no other
    program can take it while the test runs."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        yield int(sock.getsockname()[1])


async def test_a_host_that_does_not_resolve_ends_the_first_request_at_once(
    sleep: RecordingSleep,
) -> None:
    policy = RetryPolicy(sleep=sleep, clock=sleep.now)
    async with ApiClient("http://nonexistent.invalid:8080/v1", "t" * 20, retry=policy) as api:
        with pytest.raises(OriginUnreachableError) as caught:
            await api.get_batch(PROJECT, BATCH)
        assert api.stats.requests == 1
    assert sleep.waits == []
    message = str(caught.value)
    assert message.startswith("the API at http://nonexistent.invalid:8080 cannot be reached (")
    assert message.endswith("; check apiURL")
    assert "\n" not in message


async def test_a_refused_first_contact_gets_the_short_budget(
    sleep: RecordingSleep, refusing_port: int
) -> None:
    port = refusing_port
    policy = RetryPolicy(retry_for=120.0, first_contact_for=3.0, sleep=sleep, clock=sleep.now)
    async with ApiClient(f"http://127.0.0.1:{port}/v1", "t" * 20, retry=policy) as api:
        with pytest.raises(OriginUnreachableError) as caught:
            await api.get_batch(PROJECT, BATCH)
        assert api.stats.requests > 1  # retried, for a while
    assert sum(sleep.waits) == pytest.approx(3.0)  # the short budget, not retry_for
    message = str(caught.value)
    assert f"the API at http://127.0.0.1:{port} cannot be reached (" in message
    assert "tried for 3 s" in message
    assert message.endswith("; check apiURL")


async def test_after_the_first_answer_connection_failures_get_the_whole_budget(
    sleep: RecordingSleep,
) -> None:
    _calls, attempt = _scripted([refused()] * 10_000)
    policy = RetryPolicy(retry_for=60.0, first_contact_for=3.0, sleep=sleep, clock=sleep.now)
    with pytest.raises(RetriesExhaustedError):
        await retried(attempt, policy)  # an origin that answered before
    assert sum(sleep.waits) == pytest.approx(60.0)


async def test_an_origin_answering_with_an_error_status_is_past_first_contact(
    sleep: RecordingSleep,
) -> None:
    """A 503 is an answer: the URL is right, the origin is down; the whole budget."""
    policy = RetryPolicy(retry_for=60.0, first_contact_for=3.0, sleep=sleep, clock=sleep.now)
    origin = Origin("the API", policy, setting="apiURL")
    _calls, attempt = _scripted([status_error(503)] + [refused()] * 10_000)
    with pytest.raises(RetriesExhaustedError):
        await retried(attempt, policy, origin=origin)
    assert origin.answered
    assert sum(sleep.waits) == pytest.approx(60.0)


async def test_an_origin_being_retried_says_so_until_its_requests_end(
    sleep: RecordingSleep,
) -> None:
    policy = RetryPolicy(initial_backoff=0, sleep=sleep, clock=sleep.now)
    origin = Origin("the API", policy, setting="apiURL")
    seen: list[tuple[int, str]] = []

    async def fails_twice() -> str:
        seen.append((origin.retrying, origin.last_failure))
        if len(seen) < 3:
            raise status_error(503)
        return "done"

    assert await retried(fails_twice, policy, origin=origin) == "done"
    assert seen == [(0, ""), (1, "HTTP 503"), (1, "HTTP 503")]
    assert origin.retrying == 0


# -- the origin's gate ---------------------------------------------------------------------


def failing(origin: Origin, requests: int, exc: BaseException | None = None) -> None:
    for _ in range(requests):
        origin.fail(object(), exc or status_error(503), yarl.URL(URL), probe=False)


def test_failures_among_answers_leave_the_gate_open() -> None:
    origin = Origin("the API", RetryPolicy(), setting="apiURL")
    for _ in range(3):
        failing(origin, 4)
        origin.answer(origin.closures)
    assert origin.is_open


def test_one_request_failing_again_and_again_leaves_the_gate_open() -> None:
    """A job whose listings always answer 500 is that job's trouble, not the origin's."""
    origin = Origin("the API", RetryPolicy(), setting="apiURL")
    metrics, data = object(), object()
    for _ in range(50):
        origin.fail(metrics, status_error(500), yarl.URL(URL), probe=False)
        origin.fail(data, status_error(500), yarl.URL(URL), probe=False)
    assert origin.is_open
    failing(origin, 3)  # five requests have now failed with no answer between
    assert not origin.is_open


async def test_an_answer_to_a_request_sent_before_the_closure_does_not_reopen_it() -> None:
    origin = Origin("the API", RetryPolicy(), setting="apiURL")
    sent_in = origin.closures  # a request sent while it was open...
    failing(origin, 5)
    origin.answer(sent_in)  # ...answered after it closed
    assert not origin.is_open
    origin.answer(origin.closures)  # a request sent since
    assert origin.is_open


async def test_a_retry_after_holds_the_gate_closed_as_long_as_asked(
    sleep: RecordingSleep,
) -> None:
    origin = Origin("the API", RetryPolicy(sleep=sleep, clock=sleep.now), setting="apiURL")
    failing(origin, 4)
    failing(origin, 1, ApiStatusError(status=503, method="GET", url=URL, retry_after=7.0))
    await origin.enter(deadline=100.0)  # the probe
    assert sleep.now() == pytest.approx(7.0)


async def test_requests_wait_together_at_a_failing_origin_and_resume_together(
    server: ScriptedServer,
) -> None:
    """64 requests against an API that answers 503 to everything for half a second, then
    recovers. Each alone would retry on its own schedule; behind the gate only the first
    wave and one probe at a time go out, and the API's first answer lets every request
    through. (On the real clock, with short pauses: the waiters wait on a probe's outcome,
    which a fake clock that jumps at each pause cannot show.)"""
    served_in_outage = 0
    loop = asyncio.get_running_loop()
    recovers = loop.time() + 0.5

    async def down_then_up(request: web.Request) -> web.StreamResponse:
        nonlocal served_in_outage
        if loop.time() < recovers:
            served_in_outage += 1
            return web.json_response({"error": "unavailable"}, status=503)
        return await answer_json({"batchID": BATCH, "status": "SUCCEEDED"})(request)

    server.script(BATCH_PATH, down_then_up)
    policy = RetryPolicy(initial_backoff=0.02, max_backoff=0.2, retry_for=20.0)
    async with ApiClient(server.base_url, "tok-" + "x" * 20, retry=policy) as api:
        batches = await asyncio.gather(*(api.get_batch(PROJECT, BATCH) for _ in range(64)))
        assert api.origin.is_open
    assert len(batches) == 64
    assert served_in_outage <= 64 + 25, served_in_outage  # the first wave, then probes


async def test_a_closed_gate_past_the_budget_names_the_origin(
    server: ScriptedServer, sleep: RecordingSleep
) -> None:
    server.script(BATCH_PATH, answer(503))
    policy = RetryPolicy(retry_for=30.0, sleep=sleep, clock=sleep.now)
    async with ApiClient(server.base_url, "tok-" + "x" * 20, retry=policy) as api:
        results = await asyncio.gather(
            *(api.get_batch(PROJECT, BATCH) for _ in range(8)), return_exceptions=True
        )
    assert all(isinstance(r, OriginUnavailableError) for r in results), results
    assert str(results[0]).startswith(f"the API at {server.url('/').rstrip('/')} was unavailable")
