"""Adaptive against fixed concurrency on a rate-limited emulator (token buckets per origin).

The buckets are set up the way gateways usually run them: `rps` requests per second with
a burst of a tenth of a second's worth (nginx's `limit_req ... burst=`, Envoy's local rate
limit), and a refusal says `Retry-After: 1` (whole seconds, as HTTP has it). Against
such a limiter overshooting costs more than the refused requests: each one sleeps a
second while the bucket saves up only its burst.

Every run starts with full buckets (the emulator rests in between) and is counted twice:
by the emulator, how many requests it refused with 429; and by the client, in how many
trips, i.e. bursts of refusals with more than a second (the Retry-After) between them, as
the client's shared limiter counts them (``LimitStats.trips``; a run that fails has none).
The adaptive limiter's own counters come with its runs, from the same stats.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any, Final

from stook.bench._measure import in_fresh_process, measure_stook, run_stook
from stook.bench._sweep import SWEEP_CONFIG, emulator_for
from stook.emulator import EmulatorInfo

FIXED: Final = (1, 4, 8, 16, 64, 256)
ADAPTIVE_MAXIMUM: Final = 64
BURST_SECONDS: Final = 0.1  # the bucket's burst, in seconds of its rate


def measure_run(info: EmulatorInfo, concurrency: int, adaptive: bool) -> dict[str, Any]:
    """One batch-mode run (in a fresh process): its measurement, trips and limiter stats.

    The trips are the shared bound's (every request passes it, adaptive or not): bursts
    of throttling answers more than a second apart. The adaptive limiters' counters come
    with adaptive runs (API first, then storage). A run that gives up is a result, not a
    crash.
    """
    try:
        m, traffic = run_stook(info, SWEEP_CONFIG, concurrency, adaptive)
    except Exception as exc:
        return {"seconds": None, "error": f"{type(exc).__name__}: {exc}", "trips": None}
    stats = traffic.limit_stats
    outcome: dict[str, Any] = {
        "seconds": round(m.seconds, 3),
        "requests": m.requests,
        "retries": m.retries,
        "peak_rss_mb": round(m.peak_rss_mb, 1),
        "trips": stats["shared"].trips,
    }
    paces = [stats[origin] for origin in ("api", "storage") if origin in stats]
    if paces:
        outcome["limiters"] = [
            {
                "trips": pace.trips,
                "throttle_decreases": pace.throttle_decreases,
                "latency_decreases": pace.latency_decreases,
                "increases": pace.increases,
                "peak_limit": pace.peak_limit,
                "final_limit": int(pace.limit),
            }
            for pace in paces
        ]
    return outcome


def run_rate_limited(
    *,
    jobs: int,
    latency_ms: float,
    rps: float,
    fixed: tuple[int, ...] = FIXED,
    repeats: int = 1,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    rows: list[dict[str, Any]] = []
    burst = max(1, round(rps * BURST_SECONDS))
    with emulator_for(
        jobs,
        latency_ms,
        rate_limit_rps=rps,
        rate_limit_burst=burst,
        storage_rate_limit_rps=rps,
        storage_rate_limit_burst=burst,
    ) as emulator:
        # Warm-up: the emulator generates every job's data on first request.
        in_fresh_process(measure_stook, emulator.info, SWEEP_CONFIG, ADAPTIVE_MAXIMUM, True)
        settings = [(c, False) for c in fixed] + [(ADAPTIVE_MAXIMUM, True)]
        for repeat in range(repeats):
            for concurrency, adaptive in settings:
                time.sleep(burst / rps + 0.2)  # let both buckets fill up again
                before = emulator.stats()
                outcome = in_fresh_process(measure_run, emulator.info, concurrency, adaptive)
                after = emulator.stats()
                name = f"adaptive (max {concurrency})" if adaptive else f"fixed {concurrency}"
                row = {
                    "setting": name,
                    "concurrency": concurrency,
                    "adaptive": adaptive,
                    "repeat": repeat,
                    **outcome,
                    "rate_limited_429": sum(after.rate_limited.values())
                    - sum(before.rate_limited.values()),
                }
                rows.append(row)
                seconds = f"{row['seconds']:.2f} s" if row["seconds"] is not None else "FAILED"
                trips = "?" if row["trips"] is None else row["trips"]
                say(
                    f"  {name:>20}: {seconds}, {row['rate_limited_429']} answered 429 "
                    f"in {trips} trips" + (f" ({row['error']})"[:120] if "error" in row else "")
                )
    return {
        "jobs": jobs,
        "latency_ms": latency_ms,
        "rate_limit_rps": rps,
        "rate_limit_burst": burst,
        "runs": rows,
        "summary": _summary(rows),
    }


def _summary(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per setting: median seconds (None if any run failed), 429s and trips."""
    out: list[dict[str, Any]] = []
    for name in dict.fromkeys(r["setting"] for r in rows):
        runs = [r for r in rows if r["setting"] == name]
        times = [r["seconds"] for r in runs]
        out.append(
            {
                "setting": name,
                "runs": len(runs),
                "failed": sum(t is None for t in times),
                "median_seconds": None if None in times else statistics.median(times),
                "max_429": max(r["rate_limited_429"] for r in runs),
                "max_trips": max(
                    (r["trips"] for r in runs if r["trips"] is not None), default=None
                ),
            }
        )
    return out
