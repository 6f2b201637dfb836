"""Latency, seeded transient faults and rate limits."""

from __future__ import annotations

import asyncio
import json
import time
from collections import Counter

import aiohttp
import pytest

from stook.emulator import Emulator, EmulatorConfig, FaultKind
from stook.emulator._faults import FaultInjector, TokenBucket
from tests.emulator.support import SMALL, Raw

FAULTY = EmulatorConfig(
    fault_5xx=0.1, fault_429=0.05, fault_reset=0.05, fault_truncate=0.05, retry_after_max_s=1
)


def test_fault_fractions_are_roughly_as_configured() -> None:
    injector = FaultInjector(FAULTY)
    kinds: Counter[FaultKind | None] = Counter()
    n = 20_000
    for i in range(n):
        fault = injector.decide("storage", "GET", f"/object/{i}")
        kinds[fault.kind if fault else None] += 1
    assert kinds[FaultKind.SERVER_ERROR] / n == pytest.approx(0.10, abs=0.01)
    assert kinds[FaultKind.RATE_LIMITED] / n == pytest.approx(0.05, abs=0.01)
    assert kinds[FaultKind.RESET] / n == pytest.approx(0.05, abs=0.01)
    assert kinds[FaultKind.TRUNCATED] / n == pytest.approx(0.05, abs=0.01)


def test_faults_are_deterministic_by_seed() -> None:
    def decisions(seed: int) -> list[object]:
        injector = FaultInjector(FAULTY.replace(seed=seed))
        return [injector.decide("api", "GET", f"/p/{i}") for i in range(500)]

    assert decisions(3) == decisions(3)
    assert decisions(3) != decisions(4)


@pytest.mark.parametrize("limit", [1, 2, 3])
def test_the_same_request_never_faults_more_than_k_times_in_a_row(limit: int) -> None:
    always = EmulatorConfig(fault_5xx=1.0, max_consecutive_faults=limit)
    injector = FaultInjector(always)
    outcomes = [injector.decide("api", "GET", "/same") is None for _ in range(3 * (limit + 1))]
    assert outcomes == ([False] * limit + [True]) * 3


def test_faults_only_on_the_configured_origins() -> None:
    injector = FaultInjector(EmulatorConfig(fault_5xx=1.0, fault_origins=("storage",)))
    assert injector.decide("api", "GET", "/x") is None
    assert injector.decide("storage", "GET", "/x") is not None


def test_429_faults_carry_a_small_retry_after() -> None:
    injector = FaultInjector(EmulatorConfig(fault_429=1.0, retry_after_max_s=2))
    waits = {injector.decide("api", "GET", f"/{i}").retry_after_s for i in range(200)}  # type: ignore[union-attr]
    assert waits == {0, 1, 2}


def test_token_bucket() -> None:
    bucket = TokenBucket(rate=10.0, burst=3, now=0.0)
    assert [bucket.take(0.0) for _ in range(3)] == [0.0, 0.0, 0.0]
    assert bucket.take(0.0) == pytest.approx(0.1)
    assert bucket.take(0.1) == 0.0


async def _get_with_retries(
    session: aiohttp.ClientSession, url: str, headers: dict[str, str], attempts: int
) -> tuple[int, bytes, list[str]]:
    """GET until 200; the failures seen on the way."""
    seen: list[str] = []
    for _ in range(attempts):
        try:
            async with session.get(url, headers=headers) as answer:
                body = await answer.read()
                if answer.status == 200:
                    return answer.status, body, seen
                if answer.status == 429:
                    assert 0 <= int(answer.headers["Retry-After"]) <= 1
                seen.append(str(answer.status))
        except aiohttp.ClientPayloadError:
            seen.append("truncated")
        except aiohttp.ServerDisconnectedError:
            seen.append("reset")
    raise AssertionError(f"{url} still failing after {attempts} attempts: {seen}")


async def test_a_retrying_client_gets_everything_through_faults() -> None:
    config = SMALL.replace(
        jobs_per_batch=10,
        fault_5xx=0.15,
        fault_429=0.1,
        fault_reset=0.1,
        fault_truncate=0.1,
        max_consecutive_faults=2,
    )
    async with Emulator(config) as emu:
        # A fresh connection per request, so a reset never poisons a pooled one.
        connector = aiohttp.TCPConnector(force_close=True)
        async with aiohttp.ClientSession(connector=connector) as session:
            raw = Raw(emu, session)
            failures: Counter[str] = Counter()
            urls: list[str] = []
            for job in emu.dataset.jobs(emu.batch_id):
                url = raw.url(f"/batches/{emu.batch_id}/jobs/{job.id}/metrics")
                _, body, seen = await _get_with_retries(session, url, raw.auth, attempts=3)
                failures.update(seen)
                urls += [m["metricURL"] for m in json.loads(body)["metrics"]]
            results = await asyncio.gather(
                *(_get_with_retries(session, u, {}, attempts=3) for u in urls)
            )
            for _, _, seen in results:
                failures.update(seen)
    # Every kind of fault happened, and at most K=2 times per URL (3 attempts sufficed).
    assert {"truncated", "429"} <= set(failures)
    assert failures.keys() & {"500", "502", "503"}
    stats = emu.stats
    assert stats.fault_count(kind="truncated") == failures["truncated"]
    assert stats.fault_count(kind="429") == failures["429"]
    assert stats.fault_count(kind="5xx") == failures["500"] + failures["502"] + failures["503"]
    # aiohttp retries an idempotent request once by itself after a reset.
    assert stats.fault_count(kind="reset") >= failures["reset"]
    assert stats.fault_count(origin="storage") > 0
    assert stats.fault_count(origin="api") > 0
    assert emu.stats.leaked_tokens == 0


async def test_rate_limit_answers_429_with_retry_after() -> None:
    config = SMALL.replace(rate_limit_rps=20.0, rate_limit_burst=5)
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        statuses = [(await raw.get(f"/batches/{emu.batch_id}"))[0] for _ in range(12)]
        assert statuses[:5] == [200] * 5
        assert 429 in statuses[5:]
        assert emu.stats.rate_limited["api"] == statuses.count(429)
        async with session.get(raw.url(f"/batches/{emu.batch_id}"), headers=raw.auth) as answer:
            if answer.status == 429:
                assert int(answer.headers["Retry-After"]) >= 1
        await asyncio.sleep(0.2)  # four tokens back at 20/s
        assert (await raw.get(f"/batches/{emu.batch_id}"))[0] == 200


async def test_latency_is_added_to_each_request() -> None:
    async with (
        Emulator(SMALL.replace(latency_ms=40, latency_jitter_ms=10)) as emu,
        aiohttp.ClientSession() as session,
    ):
        raw = Raw(emu, session)
        start = time.perf_counter()
        await asyncio.gather(*(raw.get(f"/batches/{emu.batch_id}") for _ in range(10)))
        elapsed = time.perf_counter() - start
    assert elapsed >= 0.04
    # Concurrent requests wait concurrently: the server does not serialize the delay.
    assert emu.stats.peak_in_latency["api"] == 10
