"""The concurrency limiters: a fixed bound, and the adaptive AIMD one, on a fake clock."""

from __future__ import annotations

import asyncio
import heapq
import itertools
from collections.abc import Callable

import pytest

from stook.service.api._client import ApiClient
from stook.service.api._limits import AimdLimiter, FixedLimit, NestedLimit


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
    answer as (time, status), including those to requests still in flight at `until`.
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
    # Answer what is still in flight, so that the next call starts from a clean slate.
    while running:
        finished, _, status, rtt = heapq.heappop(running)
        clock.now = finished
        limiter.release(status, rtt)
        answers.append((finished, status))
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


async def test_a_fixed_limit_grants_a_free_slot_without_waiting_and_refusal_changes_nothing() -> (
    None
):
    limit = FixedLimit(1)
    assert limit.try_acquire()
    assert not limit.try_acquire()  # full
    assert (limit.stats.in_flight, limit.stats.acquisitions, limit.stats.waits) == (1, 1, 0)
    waiting = asyncio.ensure_future(limit.acquire())
    await asyncio.sleep(0)
    limit.release(200, 0.01)  # handed to the waiter
    await waiting
    limit.release(200, 0.01)
    assert limit.stats.in_flight == 0
    queued = [asyncio.ensure_future(limit.acquire()) for _ in range(2)]
    await asyncio.sleep(0)
    # The first took the free slot at once, the second waits for it.
    assert limit.stats.in_flight == 1
    assert not limit.try_acquire()
    limit.release(200, 0.01)
    await asyncio.gather(*queued)
    limit.release(200, 0.01)
    assert (limit.stats.in_flight, limit.stats.acquisitions, limit.stats.waits) == (0, 4, 2)


async def test_a_fixed_limit_serves_waiters_in_order_and_passes_on_a_cancelled_slot() -> None:
    limit = FixedLimit(1)
    await limit.acquire()
    first = asyncio.ensure_future(limit.acquire())
    second = asyncio.ensure_future(limit.acquire())
    third = asyncio.ensure_future(limit.acquire())
    await asyncio.sleep(0)
    # The slot goes to the first waiter, which is cancelled before it could use it: the
    # slot passes on to the next one instead of being lost.
    limit.release(200, 0.01)
    first.cancel()
    await asyncio.sleep(0)
    assert first.cancelled()
    await second
    assert not third.done()
    # A waiter cancelled while still waiting just leaves the queue.
    third.cancel()
    await asyncio.sleep(0)
    limit.release(200, 0.01)
    assert limit.stats.in_flight == 0
    assert limit.stats.acquisitions == 2
    await limit.acquire()
    assert limit.stats.in_flight == 1


async def test_a_waiter_cancelled_and_passed_over_before_it_runs_stays_cancelled() -> None:
    limit = FixedLimit(1)
    await limit.acquire()
    waiting = asyncio.ensure_future(limit.acquire())
    await asyncio.sleep(0)
    waiting.cancel()  # its future is cancelled now, its task runs later
    limit.release(200, 0.01)  # passes over the cancelled waiter and frees the slot
    await asyncio.sleep(0)
    assert waiting.cancelled()
    assert limit.stats.in_flight == 0
    await limit.acquire()
    assert limit.stats.in_flight == 1


async def test_a_fixed_limit_counts_slots_waits_and_throttle_trips() -> None:
    clock = Clock()
    limit = FixedLimit(1, clock=clock)
    await limit.acquire()
    second = asyncio.ensure_future(limit.acquire())
    await asyncio.sleep(0)
    assert (limit.stats.in_flight, limit.stats.waits) == (1, 1)
    # Two throttling answers within `hold` (1 s) of each other are one trip; a third two
    # seconds later is a trip of its own. A 500 is a failure, not a throttle.
    limit.release(429, 0.01)
    await second
    for status, at in ((503, 0.5), (500, 1.0), (429, 2.5)):
        clock.now = at
        limit.release(status, 0.01)
        await limit.acquire()
    stats = limit.stats
    assert (stats.acquisitions, stats.waits, stats.in_flight) == (5, 1, 1)
    assert (stats.throttled, stats.trips) == (3, 2)
    assert stats.limit == stats.ceiling == stats.peak_limit == 1
    assert stats.increases == stats.throttle_decreases == stats.latency_decreases == 0


async def test_an_adaptive_limit_counts_slots_and_waits() -> None:
    limiter = AimdLimiter(maximum=8, initial=2)
    await limiter.acquire()
    await limiter.acquire()
    third = asyncio.ensure_future(limiter.acquire())
    await asyncio.sleep(0)
    assert (limiter.stats.acquisitions, limiter.stats.waits) == (2, 1)
    limiter.release(200, 0.01)
    await third
    assert (limiter.stats.acquisitions, limiter.stats.in_flight) == (3, 2)
    assert limiter.stats.slow_start
    # A nested limit shows its inner (per-origin) limit's counters.
    assert NestedLimit(limiter, FixedLimit(4)).stats == limiter.stats


def test_an_unthrottled_limit_climbs_to_the_maximum() -> None:
    clock = Clock()
    limiter = aimd(clock)
    # Slow start doubles per window (two round trips) to 32, then grows by a quarter:
    # 4 to 64 in well under a second at 20 ms, where one more per window took seconds.
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=0.6)
    assert limiter.limit == 64
    assert limiter.stats.throttle_decreases == limiter.stats.latency_decreases == 0
    assert limiter.stats.trips == limiter.stats.throttled == 0


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
        limiter, clock, lambda now, n: (200 if int(now * 1000) % 4 == 0 else 429, 0.02), until=0.5
    )
    assert limiter.stats.throttle_decreases >= 1
    assert limiter.limit <= reached * 0.7
    assert not limiter.stats.slow_start


def test_a_gateway_bucket_is_tripped_a_few_times_and_its_rate_kept_busy() -> None:
    clock = Clock()
    limiter = aimd(clock)
    # 300 requests/s with a burst of a tenth of a second, as gateways run them: 6 in
    # flight at 20 ms is the server's pace, and the burst hides an overshoot only briefly.
    answers = simulate(limiter, clock, token_bucket(300, 30, 0.02), until=20.0)
    served = [t for t, status in answers if status == 200 and t > 2.0]
    refused = [t for t, status in answers if status == 429]
    assert len(served) >= 0.93 * 300 * 18
    assert limiter.stats.trips <= 8
    assert limiter.stats.throttled == len(refused) <= 0.03 * len(answers)
    # A trip is an episode: it may take more than one cut to end it.
    assert limiter.stats.throttle_decreases >= limiter.stats.trips


def test_a_trip_cuts_once_and_ignores_stray_refusals_while_the_bucket_refills() -> None:
    clock = Clock()
    limiter = aimd(clock, initial=8)
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=0.2)
    # One window with a refusal among many successes: a trip, one cut.
    first = itertools.chain([429], itertools.repeat(200))
    simulate(limiter, clock, lambda now, n: (next(first), 0.02), until=0.25)
    assert (limiter.stats.trips, limiter.stats.throttle_decreases) == (1, 1)
    cut = limiter.limit
    # Now and then a refusal within `hold` (1 s) of the trip: no further cut, no new trip.
    stray = itertools.chain([429], [200] * 30, [429], itertools.repeat(200))
    simulate(limiter, clock, lambda now, n: (next(stray), 0.02), until=0.9)
    assert (limiter.stats.trips, limiter.stats.throttle_decreases) == (1, 1)
    assert limiter.limit == cut
    # A refusal after `hold` is a trip of its own.
    simulate(limiter, clock, lambda now, n: (429 if now > 2.0 else 200, 0.02), until=2.1)
    assert limiter.stats.trips == 2


def test_after_a_trip_the_limit_regains_its_ceiling_quickly_and_probes_beyond_slowly() -> None:
    clock = Clock()
    limiter = aimd(clock, initial=32, maximum=1000)
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=0.1)
    # Half of the answers refused for a while: the limit drops to what got through.
    simulate(limiter, clock, lambda now, n: (200 if int(now * 1000) % 2 else 429, 0.02), until=0.3)
    low = limiter.stats.limit
    ceiling = limiter.stats.ceiling
    assert low < ceiling / 2
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=5.0)
    # Within a few seconds, most of the way back: a quarter of the gap closes per second.
    assert limiter.stats.limit >= low + 0.5 * (ceiling - low)
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=25.0)
    probed = limiter.stats.limit
    assert probed > ceiling
    # Beyond the ceiling it grows by `probe` (5%) a second: a bucket's burst lasts.
    simulate(limiter, clock, lambda now, n: (200, 0.02), until=26.0)
    assert probed < limiter.stats.limit <= probed * 1.06


def test_a_fractional_limit_grants_its_last_slot_part_of_the_time() -> None:
    clock = Clock()
    limiter = aimd(clock, initial=6.4)  # as a cut or a probe leaves it
    # One window of answers, none of them waiting for a slot, gives the limiter its round
    # trip without growing the limit; on this frozen clock no later window closes, so the
    # limit stays put.
    for _ in range(6):
        assert limiter.try_acquire()
        limiter.release(200, 0.01)
    assert limiter.stats.limit == 6.4
    assert limiter.limit == 6
    granted = []
    for _ in range(1000):
        while limiter.try_acquire():
            pass
        granted.append(limiter.in_flight)
        while limiter.in_flight:
            limiter.release(200, 0.01)
    assert set(granted) == {6, 7}
    assert 0.35 <= granted.count(7) / len(granted) <= 0.45


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


def test_api_client_uses_adaptive_paces_only_when_asked() -> None:
    fixed = ApiClient("http://127.0.0.1:9/v1", "t", concurrency=8)
    adaptive = ApiClient("http://127.0.0.1:9/v1", "t", concurrency=8, adaptive=True)
    assert fixed.paces == {}
    # The shared bound stays fixed; each origin gets a pace of its own inside it.
    assert isinstance(adaptive.limiter, FixedLimit)
    assert adaptive.limiter.limit == 8
    assert sorted(adaptive.paces) == ["api", "storage"]
    assert all(pace.maximum == 8 for pace in adaptive.paces.values())
    assert adaptive.paces["api"] is not adaptive.paces["storage"]


async def test_nested_limit_needs_both_slots_and_releases_both() -> None:
    api, storage, shared = AimdLimiter(maximum=4, initial=2), FixedLimit(3), FixedLimit(3)
    api_limit, storage_limit = NestedLimit(api, shared), NestedLimit(storage, shared)
    for _ in range(2):
        await api_limit.acquire()
    # The API's own pace (2) is full: a third API request waits, holding no shared slot,
    third = asyncio.ensure_future(api_limit.acquire())
    await asyncio.sleep(0)
    assert not third.done()
    # so the shared bound's last slot is still there for storage.
    await asyncio.wait_for(storage_limit.acquire(), 1)
    storage_limit.release(200, 0.01)
    await asyncio.sleep(0)
    assert not third.done()  # storage's slot does not lift the API's pace
    api_limit.release(200, 0.01)
    await asyncio.wait_for(third, 1)
    assert api.in_flight == 2
    assert storage.limit == 3


async def test_nested_limit_gives_back_the_inner_slot_when_cancelled() -> None:
    inner, outer = FixedLimit(1), FixedLimit(1)
    nested = NestedLimit(inner, outer)
    await outer.acquire()  # the shared bound is full
    waiting = asyncio.ensure_future(nested.acquire())
    await asyncio.sleep(0)
    waiting.cancel()
    with pytest.raises(asyncio.CancelledError):
        await waiting
    await asyncio.wait_for(inner.acquire(), 1)  # its inner slot was given back
