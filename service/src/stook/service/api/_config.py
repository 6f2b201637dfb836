"""The API layer's settings: one object per concern, each default written once, here.

As httpx's ``_config.py`` (``Timeout``, ``Limits``): :class:`RetryPolicy` says how long and
how patiently one request is retried and how long one attempt may take; :class:`BodyCap`
how large one answer may grow; the constants are what `ApiClient` and `StorageClient` use
when nothing else is said. stook.toml's ``[fetch]`` settings are read into these.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Final

__all__ = [
    "DEFAULT_CONCURRENCY",
    "DEFAULT_MAX_API_BODY_MB",
    "DEFAULT_MAX_BODY_MB",
    "DEFAULT_PAGE_SIZE",
    "BodyCap",
    "RetryPolicy",
    "body_cap_mb",
]

# Requests in flight, API and storage together.
DEFAULT_CONCURRENCY: Final = 64
# The API caps pages; 100 is the largest size ReSim's own tools ask for.
DEFAULT_PAGE_SIZE: Final = 100
# What one API answer (a JSON page) may hold, decompressed.
DEFAULT_MAX_API_BODY_MB: Final = 16.0
# What one download may hold, decompressed: generous for metrics data, a stop for a bomb.
DEFAULT_MAX_BODY_MB: Final = 256.0


@dataclass(frozen=True, slots=True)
class RetryPolicy:
    """How long and how patiently to retry one request. Tests pass ``initial_backoff=0``, a
    recording ``sleep`` and a ``clock`` that advances with it, and may cap
    ``max_attempts``; runs are bounded by time alone."""

    retry_for: float = 120.0
    first_contact_for: float = 10.0
    initial_backoff: float = 0.2
    max_backoff: float = 10.0
    max_retry_after: float = 60.0
    request_timeout: float = 30.0
    max_attempts: int | None = None
    sleep: Callable[[float], Awaitable[None]] = asyncio.sleep
    clock: Callable[[], float] = time.monotonic

    def __post_init__(self) -> None:
        for name in ("retry_for", "first_contact_for", "request_timeout"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        for name in ("initial_backoff", "max_backoff"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} cannot be negative, got {getattr(self, name)}")
        if self.max_attempts is not None and self.max_attempts < 1:
            raise ValueError(f"max_attempts must be at least 1, got {self.max_attempts}")
        if self.max_retry_after < 0:
            raise ValueError(f"max_retry_after cannot be negative, got {self.max_retry_after}")


@dataclass(frozen=True, slots=True)
class BodyCap:
    """The most bytes one answer's body may hold once decompressed, and the setting for it."""

    max_bytes: int
    setting: str  # named in the error, so the reader knows what to raise

    def __post_init__(self) -> None:
        if self.max_bytes < 1:
            raise ValueError(f"a body cap must be at least 1 byte, got {self.max_bytes}")


def body_cap_mb(megabytes: float, setting: str) -> BodyCap:
    """The cap of a ``[fetch]`` setting given in megabytes (MiB)."""
    return BodyCap(max(1, int(megabytes * 2**20)), f"[fetch] {setting}")
