"""One gate per origin (the API, object storage): when the origin fails, requests wait together.

Without it, 64 workers that meet an outage each retry on their own schedule, so the
failing server gets a steady stream of requests, and when it recovers the workers come
back one by one over the next ten seconds. With it:

* Transient failures (5xx, resets, refusals, timeouts, truncated bodies) of
  ``trip_after`` different requests, with no answer between them, close the gate for a
  backoff: full jitter, doubling per failed probe, up to ``max_pause`` (a few seconds),
  and at least what a ``Retry-After`` asked for. A failure among successes does not:
  sporadic faults should cost the request that met them, not stall every worker. Nor
  does one request failing again and again (a job whose listing always answers 500):
  that is the request's trouble, not the origin's.
* While it is closed, requests wait at the gate instead of sending. When the backoff is
  over, the first one through is the probe; the others keep waiting for its outcome.
* Any answer (a success, but also a 404 or a 429: the origin is there) to a request sent
  since the gate closed opens it and wakes every waiter at once. A failed probe closes it
  for the next, longer backoff.

The gate holds no lock: it is plain state on one event loop, changed only between awaits,
so nothing is held across a network call. Waiting uses the retry policy's clock and sleep,
so tests that record pauses instead of waiting drive the gate too.
"""

from __future__ import annotations

import asyncio
import enum
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Final

from stook.service.api._logging import get_logger

__all__ = ["GateStats", "OriginGate", "Passage"]

_log = get_logger("stook.service.gate")

# Requests failing, with no answer between their failures, that close the gate. With 64
# requests in flight an outage reaches it at once; a 10% fault rate almost never does, nor
# the two listings of a job whose data is broken.
DEFAULT_TRIP_AFTER: Final = 5


class Passage(enum.Enum):
    """How a request got past the gate."""

    OPEN = "open"  # the gate was open: an ordinary request
    PROBE = "probe"  # the gate was closed and this request tests whether the origin is back
    TIMED_OUT = "timed out"  # the request's deadline passed while it waited


@dataclass(slots=True)
class GateStats:
    trips: int = 0  # times the gate closed after answers
    probes: int = 0
    reopened: int = 0


class OriginGate:
    """The shared state of one origin's health; see the module docstring."""

    def __init__(
        self,
        label: str,
        *,
        pause: Callable[[int], float],
        max_pause: float,
        clock: Callable[[], float],
        sleep: Callable[[float], Awaitable[None]],
        trip_after: int = DEFAULT_TRIP_AFTER,
    ) -> None:
        if trip_after < 1:
            raise ValueError(f"trip_after must be at least 1, got {trip_after}")
        self.label = label
        self.stats = GateStats()
        self._pause = pause
        self._max_pause = max_pause
        self._clock = clock
        self._sleep = sleep
        self._trip_after = trip_after
        self._failing: set[object] = set()  # requests that failed since the last answer
        # A plain attribute, not a property over a `_closed` flag: every request reads it
        # (see sent_at_once). Only the gate sets it.
        self.is_open = True
        # Open, and no request failed since the last answer: an answer has nothing to
        # change (see `answered`), so the caller need not tell it.
        self.quiet = True
        self._closed_at = 0.0
        self._until = 0.0
        self._failed_probes = 0
        self._probing = False
        # Times the gate closed: a request notes it when sent, so that an answer can tell
        # whether it was sent before the current closure (and so says nothing about now).
        self.closures = 0
        self.last_failure = ""  # a short reason, for messages
        self.origin = ""  # scheme://host[:port] of the last failure
        self._changed = asyncio.Event()

    def answered(self, sent_in: int) -> None:
        """The origin answered (any status but a transient failure) a request sent when
        `closures` was `sent_in`: open the gate, unless the request left before it closed
        (an answer to an old request says nothing about the origin now).

        Called for every successful request, so it does as little as it can.
        """
        if self._failing:
            self._failing.clear()
            self.quiet = self.is_open
        if not self.is_open and sent_in == self.closures:
            self.is_open = self.quiet = True
            self._failed_probes = 0
            self._probing = False
            self.stats.reopened += 1
            _log.info(
                "origin answers again; requests resume",
                origin=self.label,
                closed_s=round(self._clock() - self._closed_at, 3),
            )
            self._notify()

    def failed(
        self,
        *,
        request: object,
        reason: str,
        origin: str,
        retry_after: float | None,
        probe: bool,
    ) -> None:
        """A transient failure of `request`; a probe's failure, or failures of enough
        requests with no answer between them, close the gate."""
        self.last_failure = reason
        self.origin = origin
        self.quiet = False
        if not self.is_open:
            if not probe:
                return  # an echo of the failure that closed it: sent before it closed
            self._failed_probes += 1
            self._probing = False
            self._close_for(self._failed_probes + 1, retry_after)
            self._notify()
            return
        self._failing.add(request)
        if len(self._failing) < self._trip_after:
            return
        self._failing.clear()
        self.is_open = False
        self._closed_at = self._clock()
        self.closures += 1
        self._failed_probes = 0
        self.stats.trips += 1
        wait = self._close_for(1, retry_after)
        _log.warning(
            "origin failing; requests wait at its gate",
            origin=self.label,
            url=origin,
            reason=reason,
            wait_s=round(wait, 3),
        )

    def probe_finished(self) -> None:
        """The probe ended without news (cancelled, or an error that is no answer)."""
        if self._probing:
            self._probing = False
            self._notify()

    async def enter(self, deadline: float) -> Passage:
        """Wait until the gate lets this request through, or until `deadline` (clock time)."""
        while not self.is_open:
            now = self._clock()
            if now >= deadline:
                return Passage.TIMED_OUT
            if not self._probing and now >= self._until:
                self._probing = True
                self.stats.probes += 1
                return Passage.PROBE
            # Until the backoff ends, or, while a probe is out, until its outcome.
            wake = self._until if now < self._until else deadline
            await self._wait_for_change(min(wake, deadline) - now)
        return Passage.OPEN

    def _close_for(self, attempt: int, retry_after: float | None) -> float:
        wait = min(self._pause(attempt), self._max_pause)
        if retry_after is not None:
            wait = max(wait, retry_after)
        self._until = self._clock() + wait
        return wait

    def _notify(self) -> None:
        self._changed.set()
        self._changed = asyncio.Event()

    async def _wait_for_change(self, seconds: float) -> None:
        changed = asyncio.ensure_future(self._changed.wait())
        timer = asyncio.ensure_future(self._sleep(max(seconds, 0.0)))
        try:
            await asyncio.wait((changed, timer), return_when=asyncio.FIRST_COMPLETED)
        finally:
            changed.cancel()
            timer.cancel()
