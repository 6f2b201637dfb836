"""max_in_flight: a server-side concurrency limit, shared by the API and storage."""

from __future__ import annotations

import asyncio

import aiohttp
import pytest

from stook.emulator import Emulator
from tests.emulator.support import SMALL, Raw


async def test_requests_beyond_the_limit_are_answered_429_with_retry_after() -> None:
    # The latency holds the first two in flight while the third arrives.
    config = SMALL.replace(max_in_flight=2, latency_ms=300)
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        path = raw.url(f"/batches/{emu.batch_id}")

        async def get() -> tuple[int, str | None]:
            async with session.get(path, headers=raw.auth) as answer:
                return answer.status, answer.headers.get("Retry-After")

        answers = sorted(await asyncio.gather(get(), get(), get()))
        assert answers == [(200, None), (200, None), (429, "1")]
        # All answered: the count is back to zero, and a request gets through again.
        assert (await get())[0] == 200
    assert emu.stats.rate_limited["api"] == 1
    assert emu.stats.statuses["api:429"] == 1
    assert emu.stats.requests["api"] == 4


async def test_the_limit_counts_api_and_storage_requests_together() -> None:
    config = SMALL.replace(max_in_flight=1, latency_ms=300)
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        # One at a time: never refused.
        status, listing = await raw.get(f"/batches/{emu.batch_id}/jobs")
        assert status == 200
        job = listing["jobs"][0]["jobID"]
        status, data = await raw.get(f"/batches/{emu.batch_id}/jobs/{job}/metricsData")
        assert status == 200
        url = data["metricsData"][0]["metricsDataURL"]
        (api_status, _), (storage_status, _) = await asyncio.gather(
            raw.get(f"/batches/{emu.batch_id}"), raw.fetch(url)
        )
    assert sorted((api_status, storage_status)) == [200, 429]
    assert emu.stats.rate_limited["api"] + emu.stats.rate_limited["storage"] == 1


def test_the_limit_must_be_at_least_one() -> None:
    with pytest.raises(ValueError, match="max_in_flight"):
        SMALL.replace(max_in_flight=0)
