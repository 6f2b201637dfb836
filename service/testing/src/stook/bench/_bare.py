"""The client stack's own limit: a bare aiohttp GET loop over the URLs stook requests.

The URLs are collected first (the job listing pages, each job's metrics and metricsData
listings, the presigned data URLs), in the order and with the query strings stook's client
uses; the measured loop then only GETs them with `concurrency` workers. It has no
dependencies between requests, no parsing, no retries: whatever stook does on top of this
is its own cost.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Iterable
from dataclasses import dataclass

import aiohttp
from yarl import URL

from stook.bench._measure import BARE_LOOP, Measurement, cpu_seconds, peak_rss_mb
from stook.emulator import EmulatorInfo


@dataclass(frozen=True, slots=True)
class Target:
    """One URL to GET; `api` ones carry the bearer token, storage ones nothing."""

    url: str
    api: bool


async def _pages(
    session: aiohttp.ClientSession, url: str, key: str, page_size: int
) -> tuple[list[str], list[dict[str, object]]]:
    """Every page URL of a list endpoint as stook asks for them, and the items."""
    urls: list[str] = []
    items: list[dict[str, object]] = []
    token = ""
    while True:
        query: dict[str, str | int] = {"pageSize": page_size}
        if token:
            query["pageToken"] = token
        page_url = str(URL(url).with_query(query))
        urls.append(page_url)
        async with session.get(URL(page_url, encoded=True)) as answer:
            answer.raise_for_status()
            page = await answer.json()
        items.extend(page.get(key) or [])
        token = page.get("nextPageToken") or ""
        if not token:
            return urls, items


async def collect_targets(
    info: EmulatorInfo, data_names: Iterable[str], *, page_size: int = 100, workers: int = 64
) -> list[Target]:
    """The URLs a batch-mode run requests, fetched once (which also warms the emulator)."""
    wanted = frozenset(data_names)
    base = f"{info.api_url.rstrip('/')}/projects/{info.project_id}/batches/{info.batch_id}"
    headers = {"Authorization": f"Bearer {info.token}"}
    async with aiohttp.ClientSession(headers=headers, trust_env=False) as api:
        job_pages, jobs = await _pages(api, f"{base}/jobs", "jobs", page_size)
        targets = [Target(u, api=True) for u in job_pages]
        slots = asyncio.Semaphore(workers)

        async def per_job(job_id: object) -> list[Target]:
            async with slots:
                metric_pages, _ = await _pages(
                    api, f"{base}/jobs/{job_id}/metrics", "metrics", page_size
                )
                data_pages, items = await _pages(
                    api, f"{base}/jobs/{job_id}/metricsData", "metricsData", page_size
                )
            found = [Target(u, api=True) for u in metric_pages + data_pages]
            for item in items:
                # The three keys that say which data stook downloads, read off the JSON
                # (a missing or empty type is STANDARD, as ApiMetricsData reads it).
                url = item.get("metricsDataURL")
                standard = item.get("metricsDataType") in (None, "", "STANDARD")
                if item.get("name") in wanted and standard and isinstance(url, str) and url:
                    found.append(Target(url, api=False))
            return found

        for found in await asyncio.gather(*(per_job(job["jobID"]) for job in jobs)):
            targets.extend(found)
    # One pass over the data URLs too, so that every object the loop reads is warm.
    await _get_all([t for t in targets if not t.api], workers, info.token)
    return targets


async def _get_all(targets: list[Target], concurrency: int, token: str) -> tuple[int, int, int]:
    """GET every target with `concurrency` workers; (requests, non-2xx answers, bytes)."""
    counts = [0, 0, 0]
    pending = iter(targets)
    limit = aiohttp.TCPConnector(limit=concurrency, limit_per_host=concurrency)
    storage_limit = aiohttp.TCPConnector(limit=concurrency, limit_per_host=concurrency)
    async with (
        aiohttp.ClientSession(
            connector=limit, headers={"Authorization": f"Bearer {token}"}, trust_env=False
        ) as api,
        aiohttp.ClientSession(connector=storage_limit, trust_env=False) as storage,
    ):

        async def worker() -> None:
            # A shared iterator: each worker takes the next URL as soon as it is free.
            for target in pending:
                session = api if target.api else storage
                async with session.get(URL(target.url, encoded=True)) as answer:
                    body = await answer.read()
                counts[0] += 1
                counts[1] += answer.status >= 300
                counts[2] += len(body)

        await asyncio.gather(*(worker() for _ in range(concurrency)))
    return counts[0], counts[1], counts[2]


def measure_bare(targets: list[Target], concurrency: int, token: str) -> Measurement:
    """Run in a fresh process (see `in_fresh_process`) so its RSS and CPU are its own."""
    started = time.perf_counter()
    cpu_before = cpu_seconds()
    requests, failed, received = asyncio.run(_get_all(targets, concurrency, token))
    seconds = time.perf_counter() - started
    return Measurement(
        client=BARE_LOOP,
        jobs=0,
        seconds=seconds,
        requests=requests,
        retries=failed,
        bytes_received=received,
        peak_rss_mb=peak_rss_mb(),
        cpu_seconds=cpu_seconds() - cpu_before,
    )
