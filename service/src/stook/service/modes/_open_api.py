"""What batch and report mode share around a fetch: the configured client, its traffic."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator, Mapping
from dataclasses import dataclass, field

from stook.service.api import ApiClient, ConcurrencyLimit, LimitStats, RetryPolicy, body_cap_mb
from stook.service.modes._config import FetchSettings
from stook.service.modes._inputs import ApiAccess


@contextlib.asynccontextmanager
async def open_api(
    access: ApiAccess, settings: FetchSettings, retry: RetryPolicy | None = None
) -> AsyncIterator[ApiClient]:
    """An ApiClient configured from `[fetch]`; `retry` overrides its retry policy (tests)."""
    policy = retry or RetryPolicy(retry_for=settings.retry_for, request_timeout=settings.timeout)
    async with ApiClient(
        access.api_url,
        access.token,
        concurrency=settings.concurrency,
        retry=policy,
        page_size=settings.page_size,
        adaptive=settings.adaptive,
        body_cap=body_cap_mb(settings.max_api_body_mb, "max_api_body_mb"),
        storage_body_cap=body_cap_mb(settings.max_body_mb, "max_body_mb"),
    ) as api:
        yield api


@dataclass(frozen=True, slots=True)
class Traffic:
    """Requests, retries and bytes of a client, API and storage together, and its limiters.

    The limiters are the client's own (``ApiClient.limiters``), not copies: taking a
    Traffic after every job costs nothing, and ``limit_stats`` reads what they did when
    asked, at the end of a run what they did in all.
    """

    requests: int = 0
    retries: int = 0
    bytes_received: int = 0
    # Requests being retried now: the origins and their last failure ("" when none).
    retrying: str = ""
    limiters: Mapping[str, ConcurrencyLimit] = field(default_factory=dict, compare=False)

    @classmethod
    def of(cls, api: ApiClient) -> Traffic:
        return cls(
            requests=api.stats.requests + api.storage.stats.requests,
            retries=api.stats.retries + api.storage.stats.retries,
            bytes_received=api.stats.bytes_received + api.storage.stats.bytes_received,
            retrying="; ".join(
                f"{origin.label} at {origin.url}: {origin.last_failure}"
                for origin in (api.origin, api.storage.origin)
                if origin.retrying
            ),
            limiters=api.limiters,
        )

    def __add__(self, other: Traffic) -> Traffic:
        """Two clients' traffic together (a sharded run's shards and its driver); the
        limiters are the right-hand one's, the client still open."""
        return Traffic(
            requests=self.requests + other.requests,
            retries=self.retries + other.retries,
            bytes_received=self.bytes_received + other.bytes_received,
            retrying=other.retrying or self.retrying,
            limiters=other.limiters or self.limiters,
        )

    @property
    def limit_stats(self) -> dict[str, LimitStats]:
        """What each limiter did, by name ("shared", and "api" and "storage" when adaptive)."""
        return {name: limiter.stats for name, limiter in self.limiters.items()}


class HasTraffic:
    """Mixin for run results: the traffic's counters as plain attributes."""

    __slots__ = ()
    traffic: Traffic

    @property
    def requests(self) -> int:
        return self.traffic.requests

    @property
    def retries(self) -> int:
        return self.traffic.retries

    @property
    def bytes_received(self) -> int:
        return self.traffic.bytes_received
