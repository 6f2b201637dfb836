"""The concurrency limiters: a fixed bound, and the adaptive AIMD one, on a fake clock."""

from __future__ import annotations

import asyncio
import heapq
from collections.abc import Callable

import pytest

from stook.service._client import ApiClient
from stook.service._config import ConfigError, parse
from stook.service._limiter import AimdLimiter, FixedLimit


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


Serve = Callable[[float, int], tuple[int, float]]


def simulate(
    limiter: AimdLimiter, clock: Clock, serve: Serve, *, until: float, demand: int = 128
) -> list[tuple[float, int]]:
    """A closed loop on the fake clock: `demand` requests always want a slot.

    `serve(now, in_flight)` gives each request's status and round trip. Returns every
    answer as (time, status).
    """
    running: list[tuple[float, int, int, float]] = []
    answers: list[tuple[float, int]] = []
    waiting = demand
    sent = 0
    while clock.now < until:
        while waiting and limiter.try_acquire():
            waiting -= 1
            status, rtt = serve(clock.now, limiter.in_flight)
            heapq.heappush(running, (clock.now + rtt, sent, status, rtt))
            sent += 1
        finished, _, status, rtt = heapq.heappop(running)
        clock.now = finished
        limiter.release(status, rtt)
        answers.append((finished, status))
        waiting += 1
    return answers


def token_bucket(rate: float, burst: float, rtt: float) -> Serve:
    """The emulator's rate limit: a bucket of `burst` tokens refilled at `rate` per second."""
    state = {"tokens": burst, "stamp": 0.0}

    def serve(now: float, in_flight: int) -> tuple[int, float]:
        state["tokens"] = min(burst, state["tokens"] + (now - state["stamp"]) * rate)
        state["stamp"] = now
        if state["tokens"] >= 1:
            state["tokens"] -= 1
            return 200, rtt
        return 429, rtt

    return serve


def aimd(clock: Clock, **options: int | float) -> AimdLimiter:
    settings: dict[str, int | float] = {"maximum": 64, "initial": 4} | options
    return AimdLimiter(clock=clock, **settings)  # type: ignore[arg-type]


async def test_fixed_limit_bounds_requests_in_flight() -> None:
    limit = FixedLimit(2)
    await limit.acquire()
    await limit.acquire()
    third = asyncio.ensure_future(limit.acquire())
    await asyncio.sleep(0)
    assert not third.done()
    limit.release(200, 0.01)
    await third


def test_an_unthrottled_limit_climbs_to_the_maximum() -> None:
    clock = Clock()
    limiter = aimd(clock)
    answers = simulate(limiter, clock, lambda now, n: (200, 0.02), until=3.0)
    assert limiter.limit == 64
    assert limiter.stats.throttle_decreases == limiter.stats.latency_decreases == 0
    # Slow start: doubling per window gets from 4 to 32 within a few round trips.
    assert limiter.stats.peak_limit >= 32
    assert min(t for t, _ in answers[len(answers) // 2 :]) < 3.0


def test_an_unused_limit_does_not_grow() -> None:
    clock = Clock()
    limiter = aimd(clock)
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=2.0, demand=2)
    assert limiter.limit == 4
    assert limiter.stats.increases == 0


def test_a_rate_limited_server_is_tripped_only_while_probing() -> None:
    clock = Clock()
    limiter = aimd(clock)
    # 300 requests/s at 20 ms a round trip: 6 in flight is the server's pace.
    answers = simulate(limiter, clock, token_bucket(300, 300, 0.02), until=10.0)
    refused = [t for t, status in answers if status == 429]
    served = [t for t, status in answers if status == 200]
    # The first burst allowance hides the rate; after that, a refusal only now and then.
    late = [t for t in refused if t > 2.0]
    assert len(late) <= 0.02 * len([t for t in served if t > 2.0])
    assert 3 <= limiter.limit <= 12
    # And the limit keeps the server busy: close to its 300 per second.
    assert len([t for t in served if t > 2.0]) >= 0.85 * 300 * 8


def test_a_429_cuts_the_limit_to_what_got_through_and_ends_slow_start() -> None:
    clock = Clock()
    limiter = aimd(clock, maximum=64, initial=32)
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=0.1)
    reached = limiter.limit
    assert reached >= 32
    # Now only a quarter of the answers get through.
    simulate(
        limiter, clock, lambda now, n: (200 if int(now * 1000) % 4 == 0 else 429, 0.02), until=0.2
    )
    assert limiter.stats.throttle_decreases >= 1
    assert limiter.limit <= reached // 2
    assert not limiter._slow_start


def test_throttles_from_requests_sent_before_a_decrease_count_once() -> None:
    clock = Clock()
    limiter = aimd(clock, initial=16)
    simulate(limiter, clock, lambda now, n: (200, 0.05), until=0.11)
    before = limiter.stats.throttle_decreases
    sent_at = clock.now
    for _ in range(limiter.in_flight):
        limiter.release(200, 0.05)
    for _ in range(16):
        limiter.try_acquire()
    clock.now += 0.05
    # All sixteen were sent together and all come back throttled: one overload, one cut.
    for _ in range(16):
        limiter.release(429, clock.now - sent_at)
    assert limiter.stats.throttle_decreases == before + 1


def test_a_503_is_a_throttle_too_but_a_500_is_not() -> None:
    for status, throttled in ((500, False), (503, True)):
        clock = Clock()
        limiter = aimd(clock, initial=8)

        def serve(now: float, in_flight: int, s: int = status) -> tuple[int, float]:
            return (s if now > 0.2 else 200), 0.02

        simulate(limiter, clock, serve, until=1)
        assert (limiter.stats.throttle_decreases > 0) is throttled


def test_latency_growth_without_more_throughput_backs_off() -> None:
    clock = Clock()
    limiter = aimd(clock)
    # A server that works on 8 requests at a time; beyond that, requests queue.
    answers = simulate(
        limiter, clock, lambda now, n: (200, 0.01 * max(1.0, n / 8)), until=5.0, demand=256
    )
    assert limiter.stats.latency_decreases > 0
    assert limiter.limit <= 32
    # Backing off costs no throughput: the server's 800 per second are still used.
    assert len([t for t, _ in answers if t > 2.0]) >= 0.9 * 800 * 3


def test_the_limit_stays_between_minimum_and_maximum() -> None:
    clock = Clock()
    limiter = aimd(clock, initial=2, minimum=2, maximum=6)
    simulate(limiter, clock, lambda now, n: (429, 0.02), until=3.0)
    assert limiter.limit == 2
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=30.0)
    assert limiter.limit == 6


async def test_in_flight_never_exceeds_the_maximum_under_load() -> None:
    limiter = AimdLimiter(maximum=8, initial=2)
    peak = 0
    statuses = iter([200] * 60 + [429] * 3 + [200] * 200)

    async def request() -> None:
        nonlocal peak
        await limiter.acquire()
        peak = max(peak, limiter.in_flight)
        await asyncio.sleep(0)
        limiter.release(next(statuses, 200), 0.001)

    await asyncio.gather(*(request() for _ in range(200)))
    assert limiter.in_flight == 0
    assert peak <= 8


async def test_a_cancelled_waiter_does_not_leak_its_slot() -> None:
    limiter = AimdLimiter(maximum=1, initial=1)
    await limiter.acquire()
    waiting = asyncio.ensure_future(limiter.acquire())
    await asyncio.sleep(0)
    waiting.cancel()
    with pytest.raises(asyncio.CancelledError):
        await waiting
    limiter.release(200, 0.01)
    await asyncio.wait_for(limiter.acquire(), 1)
    assert limiter.in_flight == 1


def test_bad_settings_are_refused() -> None:
    with pytest.raises(ValueError, match="minimum"):
        AimdLimiter(maximum=4, minimum=8)
    with pytest.raises(ValueError, match="backoff"):
        AimdLimiter(maximum=4, backoff=1.0)
    with pytest.raises(ValueError, match="latency_tolerance"):
        AimdLimiter(maximum=4, latency_tolerance=1.0)


def test_api_client_uses_the_adaptive_limiter_only_when_asked() -> None:
    fixed = ApiClient("http://127.0.0.1:9/v1", "t", concurrency=8)
    adaptive = ApiClient("http://127.0.0.1:9/v1", "t", concurrency=8, adaptive=True)
    assert isinstance(fixed.limiter, FixedLimit)
    assert isinstance(adaptive.limiter, AimdLimiter)
    assert adaptive.limiter.maximum == 8


def test_fetch_adaptive_is_read_from_the_config() -> None:
    assert parse({}).fetch.adaptive is False
    assert parse({"fetch": {"adaptive": True}}).fetch.adaptive is True
    with pytest.raises(ConfigError, match="adaptive must be true or false"):
        parse({"fetch": {"adaptive": "yes"}})
