"""What a plan costs: three fetch loads on one batch, against ReSim's fetcher on the same emulator.

stook downloads what the aggregations declare; ReSim's `fetch_job_metrics_by_batch`
downloads every metric and metrics data of every job, whatever is read of them. The loads:

- ``defaults``: the default batch metrics' needs (listings only, no blob);
- ``histogram metric``: those plus one merged histogram metric per job ("Acceleration
  distribution": its Metric blob and the data it references);
- ``every metric``: every job metric of every job with its data (`Needs(every_metric=True)`),
  the load ReSim's fetcher always carries.

Each runs through the public `stook.service.fetch_batch` (the core `stook run` uses), in a
fresh process so that its peak RSS is its own; requests are the emulator's count.
"""

from __future__ import annotations

import asyncio
import dataclasses
import importlib
import time
from collections.abc import Callable
from typing import Any, Final

from stook.bench._measure import (
    Measurement,
    cpu_seconds,
    in_fresh_process,
    measure_resim,
    peak_rss_mb,
    resim_available,
)
from stook.emulator import EmulatorConfig, EmulatorInfo, EmulatorProcess

HISTOGRAM_METRIC: Final = "Acceleration distribution"
LOADS: Final = ("defaults", "histogram metric", "every metric")
# What each load must beat ReSim's fetcher by, in seconds (the targets).
SPEEDUP_TARGETS: Final = {"histogram metric": 15.0, "every metric": 5.0}


def _needs(load: str) -> Any:
    from stook.sdk.aggregations import Needs, default_batch_aggregations

    defaults = Needs()
    for aggregation in default_batch_aggregations():
        defaults = defaults | aggregation.needs()
    if load == "defaults":
        return defaults
    if load == "histogram metric":
        return defaults | Needs(metrics=frozenset({HISTOGRAM_METRIC}))
    if load == "every metric":
        return Needs(every_metric=True)
    raise ValueError(f"unknown fetch load {load!r} (known: {', '.join(LOADS)})")


def measure_fetch_load(info: EmulatorInfo, load: str, concurrency: int) -> Measurement:
    """One load through `fetch_batch`; each record is looked at and dropped, as a fold does."""
    from stook.service import fetch_batch
    from stook.service.modes import configure_logging

    configure_logging(json=True, level="error")
    # Imported before the clock starts, as in `measure_stook`: start-up is measured apart.
    importlib.import_module("polars")
    importlib.import_module("numpy")
    needs = _needs(load)

    async def consume() -> int:
        jobs = 0
        async for record in fetch_batch(
            api_url=info.api_url,
            token=info.token,
            project_id=info.project_id,
            batch_id=info.batch_id,
            needs=needs,
            concurrency=concurrency,
        ):
            jobs += 1
            if record.job_metrics is not None:
                len(record.job_metrics.metrics)
        return jobs

    started = time.perf_counter()
    cpu_before = cpu_seconds()
    jobs = asyncio.run(consume())
    return Measurement(
        client=f"stook {load}",
        jobs=jobs,
        seconds=time.perf_counter() - started,
        requests=0,  # the emulator counts them, for stook and ReSim alike
        retries=0,
        bytes_received=0,
        peak_rss_mb=peak_rss_mb(),
        cpu_seconds=cpu_seconds() - cpu_before,
    )


def _requests(emulator: EmulatorProcess) -> int:
    return sum(emulator.stats().requests.values())


def run_fetch_loads(
    jobs: int,
    latency_ms: float,
    *,
    concurrency: int = 64,
    resim: bool = True,
    isolate: bool = True,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Each load once, then ReSim's fetcher once, on one emulator of `jobs` jobs.

    `isolate=False` runs the clients in this process (tests: quicker, but then peak RSS
    is this process's).
    """

    def measured(fn: Any, *args: Any) -> Any:
        return in_fresh_process(fn, *args) if isolate else fn(*args)

    config = EmulatorConfig(
        seed=11, jobs_per_batch=jobs, cache_jobs=max(jobs, 1), latency_ms=latency_ms
    )
    rows: list[dict[str, Any]] = []
    with EmulatorProcess(config) as emulator:
        # The emulator builds each job's metrics on first request: kept out of the timing.
        measured(measure_fetch_load, emulator.info, "every metric", concurrency)
        for load in LOADS:
            before = _requests(emulator)
            m: Measurement = measured(measure_fetch_load, emulator.info, load, concurrency)
            rows.append({**dataclasses.asdict(m), "requests": _requests(emulator) - before})
            say(
                f"  {m.client}: {m.seconds:.2f} s, {rows[-1]['requests']:,} requests, "
                f"peak RSS {m.peak_rss_mb:.0f} MB"
            )
        if resim and resim_available():
            before = _requests(emulator)
            r: Measurement = measured(measure_resim, emulator.info)
            rows.append({**dataclasses.asdict(r), "requests": _requests(emulator) - before})
            say(
                f"  {r.client}: {r.seconds:.2f} s, {rows[-1]['requests']:,} requests, "
                f"peak RSS {r.peak_rss_mb:.0f} MB"
            )
    return {
        "jobs": jobs,
        "latency_ms": latency_ms,
        "concurrency": concurrency,
        "rows": rows,
        "targets": fetch_load_targets(rows),
    }


def fetch_load_targets(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Each load's speed-up over ReSim's fetcher, against the target where it has one."""
    resim = next((r for r in rows if r["client"].startswith("resim")), None)
    if resim is None:
        return {}
    targets: dict[str, Any] = {}
    for row in rows:
        load = row["client"].removeprefix("stook ")
        if load not in LOADS or not row["seconds"]:
            continue
        speedup = resim["seconds"] / row["seconds"]
        target = SPEEDUP_TARGETS.get(load)
        targets[f"fetch {load} vs resim"] = {
            "at": f"{row['jobs']} jobs",
            "measured": round(speedup, 1),
            "requests": f"{row['requests']:,} against {resim['requests']:,}",
            "peak_rss_mb": f"{row['peak_rss_mb']:.0f} against {resim['peak_rss_mb']:.0f}",
            "target": f">= {target:g}" if target else "none",
            "met": speedup >= target if target else True,
        }
    return targets
