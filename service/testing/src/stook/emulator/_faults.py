"""Latency, transient faults, outages and rate limits; faults are decided from the seed."""

from __future__ import annotations

import enum
import hashlib
import math
import random
from dataclasses import dataclass

from stook.emulator._config import EmulatorConfig, Origin, Outage


class FaultKind(enum.StrEnum):
    SERVER_ERROR = "5xx"
    RATE_LIMITED = "429"
    RESET = "reset"  # the connection is aborted before any answer
    TRUNCATED = "truncated"  # Content-Length promises more than is sent


@dataclass(frozen=True, slots=True)
class Fault:
    kind: FaultKind
    status: int = 0  # for SERVER_ERROR and RATE_LIMITED
    retry_after_s: int = 0  # for RATE_LIMITED


class FaultInjector:
    """Decides per request whether it faults, from a hash of (seed, request, attempt).

    The attempt number is the request's current streak of faults, so the same request
    faults the same way in every run, and never more than `max_consecutive` times in a
    row: a client that retries always gets through. Only requests that are in a streak
    are remembered, which keeps memory flat over millions of requests.
    """

    def __init__(self, config: EmulatorConfig) -> None:
        self._seed = config.seed
        self._origins = frozenset(config.fault_origins)
        self._bounds = _cumulative(
            (FaultKind.SERVER_ERROR, config.fault_5xx),
            (FaultKind.RATE_LIMITED, config.fault_429),
            (FaultKind.RESET, config.fault_reset),
            (FaultKind.TRUNCATED, config.fault_truncate),
        )
        self._enabled = config.fault_total > 0 and config.max_consecutive_faults > 0
        self._max_consecutive = config.max_consecutive_faults
        self._retry_after_max = config.retry_after_max_s
        self._streaks: dict[str, int] = {}

    def decide(self, origin: Origin, method: str, path_qs: str) -> Fault | None:
        if not self._enabled or origin not in self._origins:
            return None
        key = f"{origin} {method} {path_qs}"
        streak = self._streaks.get(key, 0)
        if streak >= self._max_consecutive:
            del self._streaks[key]
            return None
        digest = hashlib.blake2b(f"{self._seed}|{key}|{streak}".encode(), digest_size=16).digest()
        u = int.from_bytes(digest[:8], "big") / 2**64
        v = int.from_bytes(digest[8:], "big") / 2**64
        kind = next((k for k, bound in self._bounds if u < bound), None)
        if kind is None:
            self._streaks.pop(key, None)
            return None
        self._streaks[key] = streak + 1
        if kind is FaultKind.SERVER_ERROR:
            return Fault(kind, status=(500, 502, 503)[int(v * 3)])
        if kind is FaultKind.RATE_LIMITED:
            return Fault(kind, status=429, retry_after_s=int(v * (self._retry_after_max + 1)))
        return Fault(kind)


def _cumulative(*parts: tuple[FaultKind, float]) -> list[tuple[FaultKind, float]]:
    out: list[tuple[FaultKind, float]] = []
    total = 0.0
    for kind, fraction in parts:
        if fraction > 0:
            total += fraction
            out.append((kind, total))
    return out


class OutageSchedule:
    """Which requests fall into one of the configured outages (wall time, not seeded)."""

    def __init__(self, outages: tuple[Outage, ...], now: float) -> None:
        self._outages = outages
        self._started = now
        self.began: list[float | None] = [None] * len(outages)

    def refuses(self, origin: Origin, answered: int, now: float) -> tuple[str, float, float] | None:
        """The outage window (origin, start, end) this request to `origin` falls into, if
        any; `answered` requests to it came before."""
        for index, outage in enumerate(self._outages):
            if outage.origin != origin:
                continue
            began = self.began[index]
            if began is None:
                if answered < outage.after_requests or now - self._started < outage.after_s:
                    continue
                began = self.began[index] = now
            if now < began + outage.duration_s:
                return (origin, began, began + outage.duration_s)
        return None


class TokenBucket:
    """Requests per second with a burst; `take` says how long to wait when empty."""

    def __init__(self, rate: float, burst: int | None, now: float) -> None:
        self.rate = rate
        self.capacity = float(burst if burst is not None else max(1, math.ceil(rate)))
        self._tokens = self.capacity
        self._stamp = now

    def take(self, now: float) -> float:
        """0 when a token was taken, else the seconds until one is available."""
        self._tokens = min(self.capacity, self._tokens + (now - self._stamp) * self.rate)
        self._stamp = now
        if self._tokens >= 1.0:
            self._tokens -= 1.0
            return 0.0
        return (1.0 - self._tokens) / self.rate


class Latency:
    def __init__(self, config: EmulatorConfig) -> None:
        self._fixed = config.latency_ms / 1000
        self._jitter = config.latency_jitter_ms / 1000
        self._rng = random.Random(f"{config.seed}:latency")

    def next_delay(self) -> float:
        if self._jitter:
            return self._fixed + self._rng.uniform(0.0, self._jitter)
        return self._fixed
