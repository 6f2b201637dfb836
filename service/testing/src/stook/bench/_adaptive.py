"""Adaptive against fixed concurrency on a rate-limited emulator (token buckets per origin).

The buckets are set up the way gateways usually run them: `rps` requests per second with
a burst of a tenth of a second's worth (nginx's `limit_req ... burst=`, Envoy's local rate
limit), and a refusal says `Retry-After: 1` (whole seconds, as HTTP has it). Against
such a limiter overshooting costs more than the refused requests: each one sleeps a
second while the bucket saves up only its burst.

Every run starts with full buckets (the emulator rests in between) and is counted twice:
by the emulator, how many requests it refused with 429; and by the client, in how many
trips, i.e. bursts of refusals with more than a second (the Retry-After) between them.
The adaptive limiter's own counters come with its runs.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any, Final

from stook.bench._measure import in_fresh_process, measure_stook
from stook.bench._sweep import SWEEP_CONFIG, emulator_for
from stook.emulator import EmulatorInfo

FIXED: Final = (1, 4, 8, 16, 64, 256)
ADAPTIVE_MAXIMUM: Final = 64
BURST_SECONDS: Final = 0.1  # the bucket's burst, in seconds of its rate
TRIP_GAP_S: Final = 1.0  # refusals further apart than this are separate trips


def _count_trips(refusals: list[float]) -> int:
    trips = 0
    last = -float("inf")
    for moment in sorted(refusals):
        if moment - last > TRIP_GAP_S:
            trips += 1
        last = moment
    return trips


def measure_run(info: EmulatorInfo, concurrency: int, adaptive: bool) -> dict[str, Any]:
    """One batch-mode run (in a fresh process): its measurement, trips and limiter stats.

    The limiters are wrapped in this process only, to note when a 429 came back and to
    keep the adaptive limiters' counters (API first, then storage). A run that gives up is
    a result, not a crash.
    """
    from stook.service.api import _limits as _limiter

    refusals: list[float] = []
    paces: list[_limiter.AimdLimiter] = []
    # Every request passes the shared fixed bound, adaptive or not: note refusals there.
    shared_release = _limiter.FixedLimit.release
    pace_init = _limiter.AimdLimiter.__init__

    def release(self: Any, status: int | None, seconds: float) -> None:
        if status == 429:
            refusals.append(time.monotonic())
        shared_release(self, status, seconds)

    def init(self: Any, *args: Any, **kwargs: Any) -> None:
        pace_init(self, *args, **kwargs)
        paces.append(self)

    _limiter.FixedLimit.release = release  # type: ignore[method-assign]
    _limiter.AimdLimiter.__init__ = init  # type: ignore[method-assign]
    try:
        m = measure_stook(info, SWEEP_CONFIG, concurrency, adaptive)
    except Exception as exc:
        outcome: dict[str, Any] = {"seconds": None, "error": f"{type(exc).__name__}: {exc}"}
    else:
        outcome = {
            "seconds": round(m.seconds, 3),
            "requests": m.requests,
            "retries": m.retries,
            "peak_rss_mb": round(m.peak_rss_mb, 1),
        }
    outcome["trips"] = _count_trips(refusals)
    if paces:
        outcome["limiters"] = [
            {
                "trips": pace.stats.trips,
                "throttle_decreases": pace.stats.throttle_decreases,
                "latency_decreases": pace.stats.latency_decreases,
                "increases": pace.stats.increases,
                "peak_limit": pace.stats.peak_limit,
                "final_limit": pace.limit,
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
                say(
                    f"  {name:>20}: {seconds}, {row['rate_limited_429']} answered 429 "
                    f"in {row['trips']} trips"
                    + (f" ({row['error']})"[:120] if "error" in row else "")
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
                "max_trips": max(r["trips"] for r in runs),
            }
        )
    return out
