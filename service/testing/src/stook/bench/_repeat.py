"""The target points measured again, several times, stook and the bare loop interleaved.

The sweep runs each point once, and on a shared VM one run can be off by a third. The
targets that compare stook with the bare loop and the latency bound are judged on the
medians of these repeats instead; the sweep's single runs stay in the table.

Each run also records its client's CPU and the emulator's, per request. At 0 ms the
emulator, on the same machine, is often what holds the bare loop back: its wall time is
then the emulator's CPU, and the share by requests/s says as much about the emulator as
about stook. The share by CPU (the bare loop's CPU per request over stook's) does not
depend on it, and `emulator_held_bare` counts the runs where the emulator was busy for
nearly all of the bare loop's time.
"""

from __future__ import annotations

import asyncio
import statistics
from collections.abc import Callable
from typing import Any, Final

from stook.bench._bare import collect_targets, measure_bare
from stook.bench._measure import (
    BARE_LOOP,
    STOOK,
    Measurement,
    in_fresh_process,
    measure_stook,
    process_cpu_seconds,
)
from stook.bench._sweep import SWEEP_CONFIG, SWEEP_DATA, emulator_for

__all__ = ["TARGET_POINTS", "repeat_target_points"]

# (latency ms, jobs, concurrency): the points the latency-bound and bare-loop targets name.
TARGET_POINTS: Final = ((0.0, 1000, 64), (10.0, 1000, 64))
# A run during which the emulator's CPU was at least this share of the run's wall time was
# held back by the emulator rather than by its client.
EMULATOR_BUSY: Final = 0.9


def repeat_target_points(
    repeats: int,
    *,
    points: tuple[tuple[float, int, int], ...] = TARGET_POINTS,
    say: Callable[[str], None] = print,
) -> list[dict[str, Any]]:
    """Per point: every run's seconds, requests/s and CPU per request for both clients and
    the emulator, their medians, and the shares they give."""
    results = []
    for latency, jobs, concurrency in points:
        with emulator_for(jobs, latency) as emulator:
            urls = asyncio.run(collect_targets(emulator.info, SWEEP_DATA))
            runs: dict[str, list[dict[str, float | None]]] = {STOOK: [], BARE_LOOP: []}
            for _ in range(repeats):
                for client, fn, args in (
                    (STOOK, measure_stook, (emulator.info, SWEEP_CONFIG, concurrency)),
                    (BARE_LOOP, measure_bare, (urls, concurrency, emulator.info.token)),
                ):
                    emulator_before = _cpu_of(emulator.pid)
                    m = in_fresh_process(fn, *args)
                    emulator_after = _cpu_of(emulator.pid)
                    emulator_cpu = (
                        emulator_after - emulator_before
                        if emulator_before is not None and emulator_after is not None
                        else None
                    )
                    runs[client].append(_run_row(m, emulator_cpu))
        bound = len(urls) * latency / 1000 / concurrency
        medians = {client: _medians(client_runs) for client, client_runs in runs.items()}
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
            "stook_share_of_bare_by_cpu": round(
                bare["cpu_us_per_request"] / stook["cpu_us_per_request"], 3
            ),
            "emulator_held_bare": sum(
                run["emulator_busy"] is not None and run["emulator_busy"] >= EMULATOR_BUSY
                for run in runs[BARE_LOOP]
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
            + f"; CPU per request {stook['cpu_us_per_request']:.0f} vs "
            f"{bare['cpu_us_per_request']:.0f} µs ({result['stook_share_of_bare_by_cpu']:.0%})"
            + (
                f"; the emulator held the bare loop in {result['emulator_held_bare']} of "
                f"{repeats} runs"
                if not bound
                else ""
            )
        )
    return results


_MEDIAN_KEYS: Final = (
    "seconds",
    "requests_per_second",
    "cpu_us_per_request",
    "emulator_cpu_us_per_request",
)


def _medians(runs: list[dict[str, float | None]]) -> dict[str, float]:
    """The median of each of `_MEDIAN_KEYS` that every run measured."""
    medians = {}
    for key in _MEDIAN_KEYS:
        known = [value for run in runs if (value := run[key]) is not None]
        if len(known) == len(runs):
            medians[key] = statistics.median(known)
    return medians


def _cpu_of(pid: int | None) -> float | None:
    return process_cpu_seconds(pid) if pid is not None else None


def _run_row(m: Measurement, emulator_cpu: float | None) -> dict[str, float | None]:
    """One run: its wall time and requests/s, its client's and the emulator's CPU per
    request, and the emulator's CPU as a share of the run's wall time (`emulator_busy`)."""
    per_request = 1e6 / m.requests if m.requests else 0.0
    return {
        "seconds": round(m.seconds, 4),
        "requests_per_second": round(m.requests_per_second, 1),
        "cpu_us_per_request": round(m.cpu_seconds * per_request, 1),
        "emulator_cpu_us_per_request": (
            round(emulator_cpu * per_request, 1) if emulator_cpu is not None else None
        ),
        "emulator_busy": (
            round(emulator_cpu / m.seconds, 3) if emulator_cpu is not None and m.seconds else None
        ),
    }
