"""Adaptive against fixed concurrency on a rate-limited emulator (token buckets per origin).

Every run starts with full buckets (the emulator rests for one bucket's worth of time in
between) and is counted by the emulator: how many requests it refused with 429.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Final

from stook.service.bench._measure import Measurement, in_fresh_process, measure_stook
from stook.service.bench._sweep import SWEEP_CONFIG, emulator_for

FIXED: Final = (4, 16, 64, 256)
ADAPTIVE_MAXIMUM: Final = 64


def run_rate_limited(
    *,
    jobs: int,
    latency_ms: float,
    rps: float,
    fixed: tuple[int, ...] = FIXED,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    rows: list[dict[str, Any]] = []
    burst = max(1, round(rps))
    with emulator_for(
        jobs,
        latency_ms,
        rate_limit_rps=rps,
        rate_limit_burst=burst,
        storage_rate_limit_rps=rps,
        storage_rate_limit_burst=burst,
    ) as emulator:
        # Warm-up: the emulator generates every job's data on first request.
        in_fresh_process(measure_stook, emulator.info, SWEEP_CONFIG, 16, True)
        settings = [(c, False) for c in fixed] + [(ADAPTIVE_MAXIMUM, True)]
        for concurrency, adaptive in settings:
            time.sleep(burst / rps + 0.5)  # let both buckets fill up again
            before = emulator.stats()
            try:
                m: Measurement = in_fresh_process(
                    measure_stook, emulator.info, SWEEP_CONFIG, concurrency, adaptive
                )
            except Exception as exc:  # a run that gives up is a result, not a crash
                outcome: dict[str, Any] = {"seconds": None, "error": type(exc).__name__}
            else:
                outcome = {
                    "seconds": round(m.seconds, 3),
                    "requests": m.requests,
                    "retries": m.retries,
                    "peak_rss_mb": round(m.peak_rss_mb, 1),
                }
            after = emulator.stats()
            row = {
                "setting": f"adaptive (max {concurrency})" if adaptive else f"fixed {concurrency}",
                "concurrency": concurrency,
                "adaptive": adaptive,
                **outcome,
                "rate_limited_429": sum(after.rate_limited.values())
                - sum(before.rate_limited.values()),
            }
            rows.append(row)
            seconds = f"{row['seconds']:.2f} s" if row["seconds"] is not None else "failed"
            say(
                f"  {row['setting']:>20}: {seconds}, {row.get('retries', '-')} retries, "
                f"{row['rate_limited_429']} answered 429"
            )
    return {"jobs": jobs, "latency_ms": latency_ms, "rate_limit_rps": rps, "runs": rows}
