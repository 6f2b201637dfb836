"""How many requests may be in flight: a fixed bound, or one that adapts (AIMD).

Both transports of a client share one limiter, so the bound covers API and storage
requests together. A request holds a slot from `acquire()` until `release()`, which also
reports what happened (the status, or None for a transport failure, and the seconds the
slot was held), so that the adaptive limiter can learn from it.

The adaptive limiter probes like TCP congestion control, with the server's own signals:

* while nothing pushes back and the limit is actually in use, the limit doubles each
  window (slow start) up to `slow_start_until` or the first sign of trouble, then grows by
  one per window up to the last level found sustainable, and by one per `hold` seconds
  beyond it. Slow start stops early because a server's burst allowance hides its rate: a
  limit still doubling when the allowance runs out has that many requests refused at once;
* throttling answers (429, 503) cut the limit, by at least `backoff`, to what the server
  let through: the window's successful requests per second times the best round trip
  (Little's law). A rate limiter with a burst allowance lets a climbing limit through for
  a while and then refuses everything at once; this estimate lands on its rate in one
  step, where halving again and again would keep tripping it. No growth follows for
  `hold` seconds, the scale on which such a limiter refills;
* latency growing past `latency_tolerance` times the best seen, while throughput did not
  grow with it, cuts the limit by a fifth: requests are queueing, not being served faster.

A window lasts two of the best round trips seen (before the first, until as many requests
finished as were in flight at its start): long enough to hold a fair sample of answers,
short enough to react within a few round trips. Only requests sent after the last
decrease count as evidence against the new limit.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Final, Protocol

__all__ = ["AimdLimiter", "ConcurrencyLimit", "FixedLimit", "LimiterStats"]

THROTTLE_STATUSES: Final = frozenset({429, 503})


class ConcurrencyLimit(Protocol):
    """What a transport needs from a bound on requests in flight."""

    async def acquire(self) -> None: ...

    def release(self, status: int | None, seconds: float) -> None: ...


class FixedLimit:
    """At most `limit` requests in flight; outcomes are ignored."""

    def __init__(self, limit: int) -> None:
        if limit < 1:
            raise ValueError(f"concurrency must be at least 1, got {limit}")
        self.limit = limit
        self._slots = asyncio.Semaphore(limit)

    async def acquire(self) -> None:
        await self._slots.acquire()

    def release(self, status: int | None, seconds: float) -> None:
        self._slots.release()


@dataclass(slots=True)
class LimiterStats:
    """What the adaptive limiter did, for logs and benchmarks."""

    increases: int = 0
    throttle_decreases: int = 0
    latency_decreases: int = 0
    peak_limit: int = 0


class AimdLimiter:
    """An additive-increase, multiplicative-decrease bound between `minimum` and `maximum`."""

    def __init__(
        self,
        *,
        maximum: int,
        initial: int = 4,
        minimum: int = 1,
        backoff: float = 0.7,
        latency_backoff: float = 0.8,
        latency_tolerance: float = 2.0,
        hold: float = 1.0,
        slow_start_until: int = 32,
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
        self.minimum = minimum
        self.maximum = maximum
        self._limit = float(min(max(initial, minimum), maximum))
        self._backoff = backoff
        self._latency_backoff = latency_backoff
        self._tolerance = latency_tolerance
        self._clock = clock
        self._hold = hold
        self._slow_start_until = slow_start_until
        self.in_flight = 0
        self.stats = LimiterStats(peak_limit=self.limit)
        self._waiters: deque[asyncio.Future[None]] = deque()
        self._slow_start = True
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
        self._best_rtt = math.inf
        self._last_rate = 0.0
        self._sustainable = float(maximum)  # the level the last decrease settled on
        self._last_slow_growth = -math.inf

    @property
    def limit(self) -> int:
        return max(self.minimum, int(self._limit))

    def try_acquire(self) -> bool:
        """Take a slot if one is free now; a refusal marks the limit as the bottleneck."""
        if self.in_flight < self.limit and not self._waiters:
            self.in_flight += 1
            return True
        self._limited = True
        return False

    async def acquire(self) -> None:
        if self.try_acquire():
            return
        waiter: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._waiters.append(waiter)
        try:
            await waiter
        except BaseException:
            # Cancelled after being handed a slot: pass it on rather than leak it.
            if waiter.done() and not waiter.cancelled():
                self.in_flight -= 1
                self._wake()
            else:
                self._waiters.remove(waiter)
            raise

    def release(self, status: int | None, seconds: float) -> None:
        self.in_flight -= 1
        now = self._clock()
        self._done += 1
        if status is not None and status in THROTTLE_STATUSES:
            # Only a request sent after the last decrease tells us the new limit is still
            # too high; the others were already in flight when we backed off.
            if now - seconds >= self._last_decrease:
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
        if self._throttled:
            target = self._limit * self._backoff
            if math.isfinite(self._best_rtt):
                # At most a quarter per window: a short window that happened to hold only
                # refusals would otherwise drop any limit straight to the minimum.
                through = self._ok / elapsed * self._best_rtt
                target = min(target, max(through, self._limit / 4))
            self._decrease(target, now)
            self.stats.throttle_decreases += 1
        elif (
            mean_rtt is not None
            and mean_rtt > self._tolerance * self._best_rtt
            and rate <= self._last_rate * 1.05
        ):
            self._decrease(self._limit * self._latency_backoff, now)
            self.stats.latency_decreases += 1
        elif (
            # Grow only a limit that was the bottleneck; an idle one proves nothing.
            self._limited
            and not self._echoed
            and now >= self._last_decrease + self._hold
            and self.limit < self.maximum
        ):
            self._grow(now)
        if mean_rtt is not None:
            self._best_rtt = min(self._best_rtt, mean_rtt)
        self._last_rate = rate
        self._window_start = now
        self._window_size = max(1, min(self.limit, self.in_flight))
        self._done = 0
        self._rtt_sum = 0.0
        self._rtt_count = 0
        self._ok = 0
        self._throttled = 0
        self._echoed = False
        self._limited = bool(self._waiters)

    def _grow(self, now: float) -> None:
        if self._slow_start and self._limit < self._slow_start_until:
            grown = min(self._limit * 2, float(self._slow_start_until))
        elif self._limit + 1 <= self._sustainable:
            grown = self._limit + 1
        elif now >= self._last_slow_growth + self._hold:
            # Past the last sustainable level: probe gently, a burst allowance hides the edge.
            grown = self._limit + 1
            self._last_slow_growth = now
        else:
            return
        self._limit = min(float(self.maximum), grown)
        self.stats.increases += 1
        self.stats.peak_limit = max(self.stats.peak_limit, self.limit)

    def _decrease(self, target: float, now: float) -> None:
        self._slow_start = False
        self._limit = max(float(self.minimum), target)
        self._sustainable = self._limit
        self._last_decrease = now
        self._last_slow_growth = now

    def _wake(self) -> None:
        while self._waiters and self.in_flight < self.limit:
            waiter = self._waiters.popleft()
            if not waiter.done():
                self.in_flight += 1
                waiter.set_result(None)
