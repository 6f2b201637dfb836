"""The benchmark suite behind `stook bench`; results go to docs/benchmarks/ as JSON."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from stook.service.bench._measure import (
    Measurement,
    in_fresh_process,
    measure_resim,
    measure_stook,
    resim_available,
)
from stook.service.emulator import EmulatorConfig, EmulatorProcess

# One series downloaded per job (the histogram), the rest from the listing.
BENCH_CONFIG = """\
[[batch.weighted_mean]]
name = "Distance-weighted localization error"
metric = "Localization error"
weight = "Distance driven"

[[batch.histogram]]
name = "Speed distribution"
data = "speeds"
lower = 0.0
upper = 40.0
buckets = 20
"""


def _emulator(jobs: int, latency_ms: float, seed: int = 11) -> EmulatorProcess:
    return EmulatorProcess(
        EmulatorConfig(
            seed=seed, jobs_per_batch=jobs, cache_jobs=max(jobs, 1), latency_ms=latency_ms
        )
    )


def _warm(emulator: EmulatorProcess) -> None:
    # The emulator generates each job's metrics on first request; a warm-up pass keeps
    # that one-off server cost out of the measured runs.
    in_fresh_process(measure_stook, emulator.info, BENCH_CONFIG, 64)


def compare_with_resim(jobs: int, latency_ms: float, concurrency: int) -> dict[str, Any]:
    """stook against ReSim's fetcher on one batch, one run each, same emulator."""
    with _emulator(jobs, latency_ms) as emulator:
        _warm(emulator)
        before = emulator.stats().requests
        stook: Measurement = in_fresh_process(
            measure_stook, emulator.info, BENCH_CONFIG, concurrency
        )
        middle = emulator.stats().requests
        result: dict[str, Any] = {
            "jobs": jobs,
            "latency_ms": latency_ms,
            "concurrency": concurrency,
            "stook": dataclasses.asdict(stook),
            "stook_server_requests": sum(middle.values()) - sum(before.values()),
        }
        if resim_available():
            resim: Measurement = in_fresh_process(measure_resim, emulator.info)
            after = emulator.stats().requests
            result["resim"] = dataclasses.asdict(resim)
            result["resim_server_requests"] = sum(after.values()) - sum(middle.values())
            result["speedup"] = resim.seconds / stook.seconds
    return result


def memory_scaling(sizes: list[int], concurrency: int) -> list[dict[str, Any]]:
    rows = []
    for jobs in sizes:
        with _emulator(jobs, 0.0) as emulator:
            _warm(emulator)
            m: Measurement = in_fresh_process(
                measure_stook, emulator.info, BENCH_CONFIG, concurrency
            )
        rows.append(dataclasses.asdict(m))
    return rows


def run_bench(
    out_dir: Path,
    *,
    quick: bool,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    jobs = 100 if quick else 400
    say(f"stook vs ReSim's fetch_job_metrics_by_batch: {jobs} jobs, 10 ms latency ...")
    compare = compare_with_resim(jobs, 10.0, 64)
    s = compare["stook"]
    say(
        f"  stook: {s['seconds']:.2f} s, {s['requests']} requests, {s['retries']} retries, "
        f"peak RSS {s['peak_rss_mb']:.0f} MB"
    )
    if "resim" in compare:
        r = compare["resim"]
        say(
            f"  resim: {r['seconds']:.2f} s, {compare['resim_server_requests']} requests, "
            f"peak RSS {r['peak_rss_mb']:.0f} MB  ->  stook is {compare['speedup']:.1f}x faster"
        )
    sizes = [200, 1000] if quick else [1000, 5000]
    say(f"peak memory of batch mode at {', '.join(map(str, sizes))} jobs ...")
    memory = memory_scaling(sizes, 64)
    for row in memory:
        say(f"  {row['jobs']} jobs: {row['seconds']:.2f} s, peak RSS {row['peak_rss_mb']:.0f} MB")
    results = {"quick": quick, "compare": compare, "memory": memory}
    out_dir.mkdir(parents=True, exist_ok=True)
    name = "batch-quick.json" if quick else "batch.json"
    (out_dir / name).write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    say(f"wrote {out_dir / name}")
    return results
