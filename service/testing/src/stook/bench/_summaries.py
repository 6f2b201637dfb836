"""Report mode with batch summaries against report mode on the per-job listings.

With summaries the emulator serves synthetic ones (`batch_summaries = "synthetic"`), so a
report of a million jobs needs no million job outputs; the per-job fallback is measured
at smaller sizes, where the emulator can generate every job, and extrapolated per job.
Each size runs twice on the same emulator: the first run warms it (job specs, summaries
and outputs are generated on first request), the second is measured.
"""

from __future__ import annotations

import dataclasses
import resource
from collections.abc import Callable
from typing import Any

from stook.bench._measure import Measurement, in_fresh_process
from stook.bench._report_compare import measure_stook_report
from stook.emulator import EmulatorConfig, EmulatorInfo, EmulatorProcess

# (batches, jobs per batch)
FULL_SUMMARIES = (1000, 1000)
QUICK_SUMMARIES = (20, 100)
FULL_FALLBACK = ((10, 100), (20, 100), (40, 100))
QUICK_FALLBACK = ((5, 40),)
CONCURRENCY = 64


def _emulator_config(batches: int, jobs: int, *, summaries: bool) -> EmulatorConfig:
    return EmulatorConfig(
        seed=5,
        report_batches=batches,
        report_jobs_per_batch=jobs,
        decoy_batches=0,
        batch_summaries="synthetic" if summaries else "off",
        # The fallback's job outputs stay cached after the warm-up run.
        cache_jobs=1 if summaries else max(1, batches * jobs),
        default_page_size=100,
    )


def measure_report_cpu(info: EmulatorInfo, concurrency: int) -> Measurement:
    """`measure_stook_report` with the client's CPU time: on a shared machine the wall
    time says how loaded it was, the CPU time what the report cost."""
    started = resource.getrusage(resource.RUSAGE_SELF)
    run = measure_stook_report(info, concurrency)
    ended = resource.getrusage(resource.RUSAGE_SELF)
    cpu = ended.ru_utime - started.ru_utime + ended.ru_stime - started.ru_stime
    return dataclasses.replace(run, cpu_seconds=round(cpu, 2))


def measure_report(batches: int, jobs: int, *, summaries: bool) -> dict[str, Any]:
    """One report run (after a warm-up run) against a fresh emulator process."""
    with EmulatorProcess(_emulator_config(batches, jobs, summaries=summaries)) as emulator:
        in_fresh_process(measure_stook_report, emulator.info, CONCURRENCY)
        before = emulator.stats().endpoints.copy()
        run: Measurement = in_fresh_process(measure_report_cpu, emulator.info, CONCURRENCY)
        after = emulator.stats().endpoints
    served = {k: after[k] - before.get(k, 0) for k in after if after[k] != before.get(k, 0)}
    return {
        "batches": batches,
        "jobs_per_batch": jobs,
        "jobs": batches * jobs,
        "summaries": summaries,
        "seconds": round(run.seconds, 2),
        "cpu_seconds": run.cpu_seconds,
        "seconds_per_job_us": round(1e6 * run.seconds / max(1, batches * jobs), 2),
        "requests": run.requests,
        "job_listings": served.get("api:list_jobs", 0) + served.get("api:list_job_metrics", 0),
        "peak_rss_mb": round(run.peak_rss_mb, 1),
        "client": dataclasses.asdict(run),
    }


def run_summary_bench(quick: bool, say: Callable[[str], None] = print) -> dict[str, Any]:
    """The summaries' section of `stook bench`: the big report with summaries, the
    fallback at smaller sizes, and the fallback extrapolated to the big report's jobs."""
    batches, jobs = QUICK_SUMMARIES if quick else FULL_SUMMARIES
    say(f"report of {batches} batches x {jobs} jobs with batch summaries ...")
    with_summaries = measure_report(batches, jobs, summaries=True)
    say(
        f"  {with_summaries['seconds']:.1f} s, {with_summaries['requests']} requests, "
        f"peak RSS {with_summaries['peak_rss_mb']:.0f} MB"
    )
    fallback = []
    for small_batches, small_jobs in QUICK_FALLBACK if quick else FULL_FALLBACK:
        say(f"the same on per-job listings: {small_batches} batches x {small_jobs} jobs ...")
        row = measure_report(small_batches, small_jobs, summaries=False)
        say(f"  {row['seconds']:.2f} s, {row['requests']} requests")
        fallback.append(row)
    per_job = max(r["seconds"] / r["jobs"] for r in fallback)
    requests_per_job = max(r["requests"] / r["jobs"] for r in fallback)
    extrapolated = {
        "jobs": batches * jobs,
        "seconds": round(per_job * batches * jobs, 1),
        "requests": round(requests_per_job * batches * jobs),
    }
    say(
        f"  extrapolated to {batches * jobs:,} jobs: {extrapolated['seconds']:,.0f} s, "
        f"{extrapolated['requests']:,} requests"
    )
    return {
        "with_summaries": with_summaries,
        "fallback": fallback,
        "fallback_extrapolated": extrapolated,
    }
