"""How many requests may be in flight: a fixed bound, or one that adapts (AIMD).

A client's transports share one fixed bound; in adaptive mode each also has its own limiter
inside it (`NestedLimit`). `release()` reports the status and the seconds the slot was held.
The adaptive limiter aims just below a gateway's token bucket (429 with a whole-second
`Retry-After`: overshooting costs a second per refusal). It doubles until `slow_start_until`,
then grows a quarter per window; a throttle to a request sent after the last cut cuts it to
`backoff` times what the server let through over the last second (Little's law), at most
three quarters off, and the limit it tripped at becomes the ceiling. Within `hold` it does
not grow, and only a quarter of a window refused cuts again; then it closes a quarter of its
gap to the ceiling per second, at least `probe` per second. Latency past `latency_tolerance`
times the best, with no more throughput, cuts a fifth. A fractional limit (6.4) grants its
last slot part of the time (to about 40 % of the admissions needing it).
"""

from __future__ import annotations

import asyncio
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Final, Protocol

THROTTLE_STATUSES: Final = frozenset({429, 503})


@dataclass(slots=True)
class LimitStats:
    """What a limiter did (a copy, its ``stats``). ``trips`` counts throttle episodes:
    throttling answers (fixed) or cuts (adaptive) more than ``hold`` after the last."""

    limit: float
    in_flight: int = 0
    acquisitions: int = 0  # slots granted
    waits: int = 0  # requests that had to wait for a slot
    throttled: int = 0  # throttling answers (429, 503)
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


class _Slots:
    """Slots handed to waiting requests first come, first served. Not an asyncio.Semaphore:
    its acquire is one more coroutine per request."""

    def __init__(self, counts: LimitStats) -> None:
        self.in_flight = 0
        self._counts = counts  # running: `stats` hands out copies
        self._waiters: deque[asyncio.Future[None]] = deque()

    def _has_room(self) -> bool:
        raise NotImplementedError

    def try_acquire(self) -> bool:
        """Take a slot if one is free now, without a coroutine; False changes nothing."""
        if not self._waiters and self._has_room():
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
            await waiter  # handed a slot, already counted in flight (see _wake)
        except BaseException:
            if waiter.done() and not waiter.cancelled():  # cancelled with a slot: pass it on
                self.in_flight -= 1
                self._counts.acquisitions -= 1
                self._wake()
            elif waiter in self._waiters:  # a release may have dropped it already
                self._waiters.remove(waiter)
            raise

    def _wake(self) -> None:
        while self._waiters and self._has_room():
            waiter = self._waiters.popleft()
            if not waiter.done():
                self.in_flight += 1
                self._counts.acquisitions += 1
                waiter.set_result(None)


class FixedLimit(_Slots):
    """At most `limit` requests in flight; outcomes are counted (``stats``), not acted on."""

    def __init__(
        self, limit: int, *, hold: float = 1.0, clock: Callable[[], float] = time.monotonic
    ) -> None:
        if limit < 1:
            raise ValueError(f"concurrency must be at least 1, got {limit}")
        super().__init__(LimitStats(float(limit), ceiling=float(limit), peak_limit=limit))
        self.limit = limit
        self._hold, self._clock, self._last_throttle = hold, clock, -math.inf

    @property
    def stats(self) -> LimitStats:
        return replace(self._counts, in_flight=self.in_flight)

    def _has_room(self) -> bool:
        return self.in_flight < self.limit

    def release(self, status: int | None, seconds: float) -> None:
        self.in_flight -= 1
        if self._waiters:
            self._wake()
        if status in THROTTLE_STATUSES:
            self._counts.throttled += 1
            now = self._clock()
            if now - self._last_throttle > self._hold:
                self._counts.trips += 1
            self._last_throttle = now


@dataclass(frozen=True)
class NestedLimit:
    """A slot from `inner` (one origin's pace), then from `outer` (a bound shared with other
    origins): one held back by its own origin's pace sits on no shared slot. Both learn from
    the outcome; ``stats`` are the inner limit's."""

    inner: ConcurrencyLimit
    outer: ConcurrencyLimit

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


_RATE_SPAN: Final = 1.0  # seconds over which the rate the server let through is measured
_RAMP: Final = 1.25  # growth per window after slow start and before the first trip
_GOLDEN: Final = 0.6180339887498949  # dithers a fractional limit's extra slot evenly


@dataclass(kw_only=True, eq=False)
class AimdLimiter(_Slots):
    """An additive-increase, multiplicative-decrease bound between `minimum` and `maximum`."""

    maximum: int
    initial: float = 4
    minimum: int = 1
    backoff: float = 0.9
    latency_backoff: float = 0.8
    latency_tolerance: float = 2.0
    hold: float = 1.0
    slow_start_until: int = 32
    probe: float = 0.05
    clock: Callable[[], float] = time.monotonic

    def __post_init__(self) -> None:
        if not 1 <= self.minimum <= self.maximum:
            raise ValueError(f"need 1 <= minimum <= maximum, got {self.minimum} and {self.maximum}")
        if not 0 < self.backoff < 1 or not 0 < self.latency_backoff < 1:
            raise ValueError("backoff factors must lie strictly between 0 and 1")
        if self.hold < 0 or self.latency_tolerance <= 1 or self.probe <= 0:
            raise ValueError("need hold >= 0, latency_tolerance > 1 and probe > 0")
        self._limit = float(min(max(self.initial, self.minimum), self.maximum))
        super().__init__(LimitStats(self._limit, peak_limit=self.limit))
        self._slow_start = True
        self._phase = 0.0
        self._last_decrease = self._last_trip = -math.inf
        # Answers to requests sent before this count for nothing against the limit: until
        # in-flight requests fall to a new limit, the old overload is still being answered.
        self._evidence_from = -math.inf
        self._best_rtt = math.inf
        self._last_rate = 0.0
        self._ceiling = float(self.maximum)  # the limit of the last decrease
        # Closed windows of the last second or so: (end, seconds, answers, successes, load).
        self._recent: deque[tuple[float, float, int, int, int]] = deque()
        self._new_window(self.clock(), self.limit)

    def _new_window(self, now: float, size: int) -> None:
        """A window ends after two of the best round trips (before the first, `size` answers)."""
        self._window_start, self._window_size = now, size
        self._done = self._ok = self._throttled = self._rtt_count = 0
        self._rtt_sum = 0.0
        self._load = 0  # the requests in flight at each answer, summed
        self._echoed = False  # a throttle from before the last decrease: hold, do not grow
        self._limited = bool(self._waiters)  # a request had to wait for a slot

    @property
    def limit(self) -> int:
        """Whole slots; a fractional part of the limit is granted part of the time."""
        return max(self.minimum, int(self._limit))

    @property
    def stats(self) -> LimitStats:
        return replace(
            self._counts,
            limit=self._limit,
            in_flight=self.in_flight,
            ceiling=self._ceiling,
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
        if super().try_acquire():
            return True
        self._limited = True
        return False

    def release(self, status: int | None, seconds: float) -> None:
        self._load += self.in_flight
        self.in_flight -= 1
        now = self.clock()
        self._done += 1
        if self._evidence_from == math.inf and self.in_flight <= self.limit:
            self._evidence_from = now
        if status is not None and status in THROTTLE_STATUSES:
            self._counts.throttled += 1
            # Only a request sent after the last cut took hold says the limit is too high.
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
            # A throttle ends the window early: each round trip over the limit costs a slot.
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
            if now > self._last_trip + self.hold or 4 * self._throttled >= max(
                self._done, self.limit
            ):
                self._throttle(now)
        elif (
            mean_rtt is not None
            and mean_rtt > self.latency_tolerance * self._best_rtt
            and rate <= self._last_rate * 1.05
        ):
            self._decrease(self._limit * self.latency_backoff, now, self._limit)
            self._counts.latency_decreases += 1
        elif (
            # Grow only a limit that was the bottleneck; an idle one proves nothing.
            self._limited
            and not self._echoed
            and now >= self._last_decrease + self.hold
            and self._limit < self.maximum
        ):
            self._grow(elapsed)
        if mean_rtt is not None:
            self._best_rtt = min(self._best_rtt, mean_rtt)
        self._last_rate = rate
        self._new_window(now, max(1, min(self.limit, self.in_flight)))

    def _throttle(self, now: float) -> None:
        # What the server let through over the last second (Little's law): the requests in
        # flight times the share of successes; at most three quarters off at once.
        answers = sum(r[2] for r in self._recent)
        in_flight = sum(r[4] for r in self._recent) / answers
        through = in_flight * sum(r[3] for r in self._recent) / answers
        target = self.backoff * min(self._limit, max(through, self._limit / 4))
        same_trip = now <= self._last_trip + self.hold  # keeps that trip's ceiling
        if not same_trip:
            self._counts.trips += 1
        self._last_trip = now
        self._decrease(target, now, max(self._limit, self._ceiling) if same_trip else self._limit)
        self._counts.throttle_decreases += 1

    def _grow(self, elapsed: float) -> None:
        if self._slow_start and self._limit < self.slow_start_until:
            grown = min(self._limit * 2, max(float(self.slow_start_until), self._limit + 1))
        elif self._slow_start:
            grown = self._limit * _RAMP
        else:
            # Back to the ceiling quickly, beyond it slowly; per second, whatever the RTT.
            step = max(0.25 * (self._ceiling - self._limit), self.probe * self._limit)
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
