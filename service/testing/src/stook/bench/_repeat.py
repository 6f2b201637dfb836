"""The target points measured again, several times, stook and the bare loop interleaved.

The sweep runs each point once, and on a shared VM one run can be off by a third. The
targets that compare stook with the bare loop and the latency bound are judged on the
medians of these repeats instead; the sweep's single runs stay in the table.
"""

from __future__ import annotations

import asyncio
import statistics
from collections.abc import Callable
from typing import Any, Final

from stook.bench._bare import collect_targets, measure_bare
from stook.bench._measure import BARE_LOOP, STOOK, in_fresh_process, measure_stook
from stook.bench._sweep import SWEEP_CONFIG, SWEEP_DATA, emulator_for

__all__ = ["TARGET_POINTS", "repeat_target_points"]

# (latency ms, jobs, concurrency): the points the latency-bound and bare-loop targets name.
TARGET_POINTS: Final = ((0.0, 1000, 64), (10.0, 1000, 64))


def repeat_target_points(
    repeats: int,
    *,
    points: tuple[tuple[float, int, int], ...] = TARGET_POINTS,
    say: Callable[[str], None] = print,
) -> list[dict[str, Any]]:
    """Per point: every run's seconds and requests/s for both clients, and their medians."""
    results = []
    for latency, jobs, concurrency in points:
        with emulator_for(jobs, latency) as emulator:
            urls = asyncio.run(collect_targets(emulator.info, SWEEP_DATA))
            runs: dict[str, list[dict[str, float]]] = {STOOK: [], BARE_LOOP: []}
            for _ in range(repeats):
                for client, fn, args in (
                    (STOOK, measure_stook, (emulator.info, SWEEP_CONFIG, concurrency)),
                    (BARE_LOOP, measure_bare, (urls, concurrency, emulator.info.token)),
                ):
                    m = in_fresh_process(fn, *args)
                    runs[client].append(
                        {
                            "seconds": round(m.seconds, 4),
                            "requests_per_second": round(m.requests_per_second, 1),
                        }
                    )
        bound = len(urls) * latency / 1000 / concurrency
        medians = {
            client: {
                key: statistics.median(run[key] for run in client_runs)
                for key in ("seconds", "requests_per_second")
            }
            for client, client_runs in runs.items()
        }
        stook, bare = medians[STOOK], medians[BARE_LOOP]
        result = {
            "latency_ms": latency,
            "jobs": jobs,
            "concurrency": concurrency,
            "requests": len(urls),
            "repeats": repeats,
            "latency_bound_seconds": round(bound, 4),
            "runs": runs,
            "median": medians,
            "stook_share_of_bare": round(
                stook["requests_per_second"] / bare["requests_per_second"], 3
            ),
            "stook_over_bound": round(stook["seconds"] / bound, 2) if bound else None,
            "bare_over_bound": round(bare["seconds"] / bound, 2) if bound else None,
        }
        results.append(result)
        say(
            f"  {latency:g} ms, {jobs} jobs, c={concurrency}, {repeats} runs each: stook "
            f"{stook['seconds']:.2f} s, bare loop {bare['seconds']:.2f} s (medians); stook "
            f"at {result['stook_share_of_bare']:.0%} of the bare loop's requests/s"
            + (f", {result['stook_over_bound']}x the latency bound" if bound else "")
        )
    return results
