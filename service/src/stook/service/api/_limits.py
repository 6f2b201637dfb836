"""How many requests may be in flight: a fixed bound, or one that adapts (AIMD).

Both transports of a client share one fixed bound, so it covers API and storage requests
together; in adaptive mode each transport also has an adaptive limiter of its own inside it
(`NestedLimit`), since two servers have two paces. A request holds a slot from `acquire()`
until `release()`, which also reports what happened (the status, or None for a transport
failure, and the seconds the slot was held), so that the adaptive limiter can learn from
it.

The adaptive limiter probes like TCP congestion control, with the server's own signals.
It is built for the rate limiters real gateways run: a token bucket whose burst is a small
part of a second's rate, answering 429 with a `Retry-After` in whole seconds. Against
such a limiter a client that overshoots loses more than the refused requests: every
refused request sleeps a whole second while the bucket can save up only its burst, so
the server's rate goes unused. Staying just below the rate is what finishes first.

* Until the first sign of trouble the limit grows each window while it is in use:
  doubling up to `slow_start_until`, then by a quarter, up to `maximum`.
* A throttling answer (429, 503) to a request sent after the last decrease took hold
  (once the requests in flight fell to it) is a trip. It cuts the limit to `backoff`
  times the smaller of the limit and what the server let through over the last second:
  the requests in flight times the share of answers that succeeded (Little's law), but
  by at most three quarters at once. The limit it tripped at becomes the ceiling. For
  `hold` seconds, the scale on which refused requests return, the limit does not grow,
  and only a quarter of a window's answers refused cuts it again: a refusal now and then
  is the emptied bucket filling up, not a new overload. Cuts within `hold` of each other
  are one trip (`stats.trips`).
* After a trip the limit closes a quarter of its gap to the ceiling per second, and
  grows by at least `probe` (a fraction) per second, so that it finds a higher rate.
  Far below the ceiling it recovers in a few seconds; near it, it probes so slowly that
  a bucket's burst is used up only every few seconds: a trip is a handful of refusals.
* Latency growing past `latency_tolerance` times the best seen, while throughput did not
  grow with it, cuts the limit by a fifth: requests are queueing, not being served faster.

The limit is fractional: at 6.4 the seventh slot is granted to about 40% of the
admissions that would need it. A server whose rate sits between two whole numbers of
requests in flight (a few requests at tens of milliseconds each) is then neither left
idle nor tripped every second.

A window lasts two of the best round trips seen (before the first, until as many requests
finished as were in flight at its start): long enough to hold a fair sample of answers,
short enough to react within a few round trips.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Final, Protocol

__all__ = [
    "THROTTLE_STATUSES",
    "AimdLimiter",
    "ConcurrencyLimit",
    "FixedLimit",
    "LimitStats",
    "NestedLimit",
]

THROTTLE_STATUSES: Final = frozenset({429, 503})


@dataclass(frozen=True, slots=True)
class LimitStats:
    """What a limiter did, at one moment (its ``stats``): for logs, tests and benchmarks.

    ``limit`` is the bound now; an adaptive limit's may be fractional (its last slot is
    granted part of the time). ``trips`` counts throttle episodes: for a fixed limit,
    throttling answers (429, 503) more than ``hold`` seconds after the one before; for an
    adaptive limit, cuts for throttling more than ``hold`` after the one before.
    """

    limit: float
    in_flight: int = 0
    acquisitions: int = 0  # slots granted
    waits: int = 0  # requests that had to wait for a slot
    throttled: int = 0  # throttling answers (429, 503) that came back
    trips: int = 0
    # Adaptive only (a fixed limit's ceiling and peak are its limit):
    ceiling: float = 0.0  # the limit at the last trip (the maximum before the first)
    peak_limit: int = 0
    increases: int = 0
    throttle_decreases: int = 0
    latency_decreases: int = 0
    slow_start: bool = False  # still doubling: no sign of trouble yet


class ConcurrencyLimit(Protocol):
    """What a transport needs from a bound on requests in flight, and what it tells."""

    async def acquire(self) -> None: ...

    def release(self, status: int | None, seconds: float) -> None: ...

    @property
    def stats(self) -> LimitStats: ...


@dataclass(slots=True)
class _Counters:
    """A limiter's running counts; :class:`LimitStats` is their snapshot."""

    acquisitions: int = 0
    waits: int = 0
    throttled: int = 0
    trips: int = 0
    increases: int = 0
    throttle_decreases: int = 0
    latency_decreases: int = 0
    peak_limit: int = 0


class FixedLimit:
    """At most `limit` requests in flight; outcomes are counted (``stats``), not acted on."""

    def __init__(
        self, limit: int, *, hold: float = 1.0, clock: Callable[[], float] = time.monotonic
    ) -> None:
        if limit < 1:
            raise ValueError(f"concurrency must be at least 1, got {limit}")
        self.limit = limit
        self.in_flight = 0
        # Waiting requests, first come first served; a slot is handed straight to the
        # first. Not an asyncio.Semaphore: its acquire is one more coroutine per request,
        # and asks twice whether it is locked.
        self._waiters: deque[asyncio.Future[None]] = deque()
        self._counts = _Counters(peak_limit=limit)
        self._hold = hold
        self._clock = clock
        self._last_throttle = -math.inf

    @property
    def stats(self) -> LimitStats:
        counts = self._counts
        return LimitStats(
            limit=float(self.limit),
            in_flight=self.in_flight,
            acquisitions=counts.acquisitions,
            waits=counts.waits,
            throttled=counts.throttled,
            trips=counts.trips,
            ceiling=float(self.limit),
            peak_limit=self.limit,
        )

    def try_acquire(self) -> bool:
        """Take a slot if one is free now, without a coroutine; False changes nothing."""
        if self.in_flight < self.limit and not self._waiters:
            self.in_flight += 1
            self._counts.acquisitions += 1
            return True
        return False

    async def acquire(self) -> None:
        if self.try_acquire():
            return
        self._counts.waits += 1
        waiter: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._waiters.append(waiter)
        try:
            await waiter  # handed a slot, already counted in flight (see _hand_over)
        except BaseException:
            # Cancelled after being handed a slot: pass it on rather than leak it.
            if waiter.done() and not waiter.cancelled():
                self._counts.acquisitions -= 1
                self._hand_over()
            elif waiter in self._waiters:  # a release may have passed it over already
                self._waiters.remove(waiter)
            raise

    def release(self, status: int | None, seconds: float) -> None:
        if self._waiters:
            self._hand_over()
        else:
            self.in_flight -= 1
        if status in THROTTLE_STATUSES:
            counts = self._counts
            counts.throttled += 1
            now = self._clock()
            if now - self._last_throttle > self._hold:
                counts.trips += 1
            self._last_throttle = now

    def _hand_over(self) -> None:
        """Give a freed slot to the first request still waiting, or free it."""
        waiters = self._waiters
        while waiters:
            waiter = waiters.popleft()
            if not waiter.done():
                self._counts.acquisitions += 1
                waiter.set_result(None)
                return
        self.in_flight -= 1


class NestedLimit:
    """A slot from `inner` (one origin's own pace), then one from `outer` (a bound shared
    with other origins); both learn from the outcome.

    The inner slot comes first so that a request held back by its own origin's pace does
    not sit on a shared slot that a request to the other origin could use. Its ``stats``
    are the inner limit's: what the nesting adds to the shared bound.
    """

    def __init__(self, inner: ConcurrencyLimit, outer: ConcurrencyLimit) -> None:
        self.inner = inner
        self.outer = outer

    @property
    def stats(self) -> LimitStats:
        return self.inner.stats

    async def acquire(self) -> None:
        await self.inner.acquire()
        try:
            await self.outer.acquire()
        except BaseException:
            self.inner.release(None, 0.0)
            raise

    def release(self, status: int | None, seconds: float) -> None:
        self.outer.release(status, seconds)
        self.inner.release(status, seconds)


# How far back the rate the server let through is measured, in seconds.
_RATE_SPAN: Final = 1.0
# Growth per window after slow start and before the first trip.
_RAMP: Final = 1.25
# Dithering a fractional limit: the golden ratio spreads the extra slot evenly.
_GOLDEN: Final = 0.6180339887498949


class AimdLimiter:
    """An additive-increase, multiplicative-decrease bound between `minimum` and `maximum`."""

    def __init__(
        self,
        *,
        maximum: int,
        initial: float = 4,
        minimum: int = 1,
        backoff: float = 0.9,
        latency_backoff: float = 0.8,
        latency_tolerance: float = 2.0,
        hold: float = 1.0,
        slow_start_until: int = 32,
        probe: float = 0.05,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if not 1 <= minimum <= maximum:
            raise ValueError(f"need 1 <= minimum <= maximum, got {minimum} and {maximum}")
        if not 0 < backoff < 1 or not 0 < latency_backoff < 1:
            raise ValueError("backoff factors must lie strictly between 0 and 1")
        if hold < 0:
            raise ValueError("hold cannot be negative")
        if latency_tolerance <= 1:
            raise ValueError("latency_tolerance must be above 1")
        if probe <= 0:
            raise ValueError("probe must be positive")
        self.minimum = minimum
        self.maximum = maximum
        self._limit = float(min(max(initial, minimum), maximum))
        self._backoff = backoff
        self._latency_backoff = latency_backoff
        self._tolerance = latency_tolerance
        self._clock = clock
        self._hold = hold
        self._slow_start_until = slow_start_until
        self._probe = probe
        self.in_flight = 0
        self._counts = _Counters(peak_limit=self.limit)
        self._waiters: deque[asyncio.Future[None]] = deque()
        self._slow_start = True
        self._phase = 0.0
        # The current window: when it began, what finished in it, and what it saw.
        self._window_start = clock()
        self._window_size = self.limit
        self._done = 0
        self._rtt_sum = 0.0
        self._rtt_count = 0
        self._ok = 0
        self._throttled = 0
        self._limited = False  # whether a request had to wait for a slot in this window
        self._echoed = False  # a throttle from before the last decrease: hold, do not grow
        self._last_decrease = -math.inf
        # Answers to requests sent before this count for nothing against the limit: until
        # in-flight requests fall to a new limit, the old overload is still being answered.
        self._evidence_from = -math.inf
        self._last_trip = -math.inf
        self._best_rtt = math.inf
        self._last_rate = 0.0
        self._ceiling = float(maximum)  # the limit of the last decrease
        self._load = 0  # the requests in flight at each answer of this window, summed
        # Closed windows of the last second or so: (end, seconds, answers, successes, load).
        self._recent: deque[tuple[float, float, int, int, int]] = deque()

    @property
    def limit(self) -> int:
        """Whole slots; a fractional part of the limit is granted part of the time."""
        return max(self.minimum, int(self._limit))

    @property
    def stats(self) -> LimitStats:
        counts = self._counts
        return LimitStats(
            limit=self._limit,
            in_flight=self.in_flight,
            acquisitions=counts.acquisitions,
            waits=counts.waits,
            throttled=counts.throttled,
            trips=counts.trips,
            ceiling=self._ceiling,
            peak_limit=counts.peak_limit,
            increases=counts.increases,
            throttle_decreases=counts.throttle_decreases,
            latency_decreases=counts.latency_decreases,
            slow_start=self._slow_start,
        )

    def _has_room(self) -> bool:
        """Whether one more request fits; the slot a fractional limit adds, part-time."""
        whole = self.limit
        if self.in_flight != whole:
            return self.in_flight < whole
        fraction = self._limit - whole
        if fraction <= 0:
            return False
        self._phase = (self._phase + _GOLDEN) % 1.0
        return self._phase < fraction

    def try_acquire(self) -> bool:
        """Take a slot if one is free now; a refusal marks the limit as the bottleneck."""
        if not self._waiters and self._has_room():
            self.in_flight += 1
            self._counts.acquisitions += 1
            return True
        self._limited = True
        return False

    async def acquire(self) -> None:
        if self.try_acquire():
            return
        self._counts.waits += 1
        waiter: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._waiters.append(waiter)
        try:
            await waiter
        except BaseException:
            # Cancelled after being handed a slot: pass it on rather than leak it.
            if waiter.done() and not waiter.cancelled():
                self.in_flight -= 1
                self._counts.acquisitions -= 1
                self._wake()
            else:
                self._waiters.remove(waiter)
            raise

    def release(self, status: int | None, seconds: float) -> None:
        self._load += self.in_flight
        self.in_flight -= 1
        now = self._clock()
        self._done += 1
        if self._evidence_from == math.inf and self.in_flight <= self.limit:
            self._evidence_from = now
        if status is not None and status in THROTTLE_STATUSES:
            self._counts.throttled += 1
            # Only a request sent after the last decrease took hold tells us the new limit
            # is still too high; the others were part of the overload we backed off from.
            if now - seconds >= self._evidence_from:
                self._throttled += 1
            else:
                self._echoed = True
        elif status is not None and status < 400:
            self._ok += 1
            if now - seconds >= self._last_decrease:
                self._rtt_sum += seconds
                self._rtt_count += 1
        if math.isfinite(self._best_rtt):
            elapsed = now - self._window_start
            # A throttle ends the window early: every round trip spent over the limit costs
            # a refused request per slot.
            closes = elapsed >= 2 * self._best_rtt or (
                self._throttled > 0 and elapsed >= self._best_rtt / 2
            )
        else:
            closes = self._done >= self._window_size
        if closes:
            self._close_window(now)
        self._wake()

    def _close_window(self, now: float) -> None:
        elapsed = max(now - self._window_start, 1e-9)
        rate = self._done / elapsed
        mean_rtt = self._rtt_sum / self._rtt_count if self._rtt_count else None
        self._recent.append((now, elapsed, self._done, self._ok, self._load))
        while len(self._recent) > 1 and self._recent[0][0] - self._recent[0][1] < now - _RATE_SPAN:
            self._recent.popleft()
        if self._throttled:
            # Within `hold` of a trip, a refusal now and then is the emptied bucket filling
            # up again, not a new overload; a quarter of the answers refused is.
            if now > self._last_trip + self._hold or 4 * self._throttled >= max(
                self._done, self.limit
            ):
                self._throttle(now)
        elif (
            mean_rtt is not None
            and mean_rtt > self._tolerance * self._best_rtt
            and rate <= self._last_rate * 1.05
        ):
            self._decrease(self._limit * self._latency_backoff, now, self._limit)
            self._counts.latency_decreases += 1
        elif (
            # Grow only a limit that was the bottleneck; an idle one proves nothing.
            self._limited
            and not self._echoed
            and now >= self._last_decrease + self._hold
            and self._limit < self.maximum
        ):
            self._grow(elapsed)
        if mean_rtt is not None:
            self._best_rtt = min(self._best_rtt, mean_rtt)
        self._last_rate = rate
        self._window_start = now
        self._window_size = max(1, min(self.limit, self.in_flight))
        self._done = 0
        self._rtt_sum = 0.0
        self._rtt_count = 0
        self._ok = 0
        self._load = 0
        self._throttled = 0
        self._echoed = False
        self._limited = bool(self._waiters)

    def _throttle(self, now: float) -> None:
        # What the server let through, over the last second: the requests in flight times
        # the share of answers that were successes (Little's law). At most three quarters
        # off at once, as a short window may have held only refusals.
        answers = sum(r[2] for r in self._recent)
        in_flight = sum(r[4] for r in self._recent) / answers
        through = in_flight * sum(r[3] for r in self._recent) / answers
        target = self._backoff * min(self._limit, max(through, self._limit / 4))
        # Further cuts within `hold` belong to the same trip and keep its ceiling.
        ceiling = self._limit
        if now > self._last_trip + self._hold:
            self._counts.trips += 1
        else:
            ceiling = max(ceiling, self._ceiling)
        self._last_trip = now
        self._decrease(target, now, ceiling)
        self._counts.throttle_decreases += 1

    def _grow(self, elapsed: float) -> None:
        if self._slow_start:
            factor = 2.0 if self._limit < self._slow_start_until else _RAMP
            grown = self._limit * factor
            if self._limit < self._slow_start_until:
                grown = min(grown, max(float(self._slow_start_until), self._limit + 1))
        else:
            # Back towards the ceiling quickly, beyond it slowly; time-based, so that the
            # pace does not depend on the round trip.
            step = max(0.25 * (self._ceiling - self._limit), self._probe * self._limit)
            grown = self._limit + step * min(elapsed, 1.0)
        self._limit = min(float(self.maximum), grown)
        self._counts.increases += 1
        self._counts.peak_limit = max(self._counts.peak_limit, self.limit)

    def _decrease(self, target: float, now: float, ceiling: float) -> None:
        self._slow_start = False
        self._ceiling = ceiling
        self._limit = max(float(self.minimum), target)
        self._last_decrease = now
        self._evidence_from = now if self.in_flight <= self.limit else math.inf

    def _wake(self) -> None:
        while self._waiters and self._has_room():
            waiter = self._waiters.popleft()
            if not waiter.done():
                self.in_flight += 1
                self._counts.acquisitions += 1
                waiter.set_result(None)
