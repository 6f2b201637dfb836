"""The sweep: concurrency x latency x batch size, stook against its three references.

For every point: stook's batch mode, a bare aiohttp loop over the same URLs with the same
concurrency, the latency bound (requests x latency / concurrency), and, at concurrency 64
on the smaller batches, ReSim's `fetch_job_metrics_by_batch` (it has no concurrency
setting: it starts a thread per request). Each client runs in a fresh process against an
emulator in a process of its own.

Points where the clients mostly wait (at most `SIDE_BY_SIDE_RPS` requests per second even
at the latency bound) run side by side, a few at a time, each group with its own emulator;
run one after another they alone would take most of an hour. Every other point runs alone.
Rows say which way they were run.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any, Final

from stook.bench._bare import Target, collect_targets, measure_bare
from stook.bench._measure import (
    BENCH_CONFIG,
    LATENCY_BOUND,
    STOOK,
    Measurement,
    in_fresh_process,
    measure_resim,
    measure_stook,
    process_cpu_seconds,
    resim_available,
)
from stook.emulator import EmulatorConfig, EmulatorProcess

# One series downloaded per job (the histogram), the rest from the listing. A small
# max_values keeps the histogram in its streaming (exact counts per bucket) mode, so that
# memory does not grow with the batch.
# The histogram table comes last in BENCH_CONFIG, so this line lands in it.
SWEEP_CONFIG: Final = BENCH_CONFIG + "max_values = 10000\n"
SWEEP_DATA: Final = ("speeds",)

SIDE_BY_SIDE_RPS: Final = 100.0
SIDE_BY_SIDE_LANES: Final = 4
RESIM_CONCURRENCY: Final = 64


@dataclass(frozen=True, slots=True)
class Grid:
    concurrencies: tuple[int, ...]
    latencies_ms: tuple[float, ...]
    sizes: tuple[int, ...]
    resim_sizes: tuple[int, ...]  # ReSim's fetcher runs only at these sizes (it is slow)

    @property
    def points(self) -> int:
        return len(self.concurrencies) * len(self.latencies_ms) * len(self.sizes)


FULL: Final = Grid((1, 4, 16, 64, 256), (0.0, 10.0, 50.0), (100, 1000, 5000), (100, 1000))
QUICK: Final = Grid((4, 64), (0.0, 10.0), (100, 400), (100,))


def side_by_side(concurrency: int, latency_ms: float) -> bool:
    return latency_ms > 0 and concurrency / (latency_ms / 1000) <= SIDE_BY_SIDE_RPS


def emulator_for(jobs: int, latency_ms: float, **extra: Any) -> EmulatorProcess:
    return EmulatorProcess(
        EmulatorConfig(
            seed=11, jobs_per_batch=jobs, cache_jobs=max(jobs, 1), latency_ms=latency_ms, **extra
        )
    )


def _row(
    m: Measurement,
    *,
    concurrency: int | None,
    latency_ms: float,
    jobs: int,
    side: bool,
    server_cpu: float | None = None,
    requests: int | None = None,
) -> dict[str, Any]:
    n = requests if requests is not None else m.requests
    return {
        "client": m.client,
        "concurrency": concurrency,
        "latency_ms": latency_ms,
        "jobs": jobs,
        "seconds": round(m.seconds, 4),
        "requests": n,
        "requests_per_second": round(n / m.seconds, 1) if m.seconds else None,
        "retries": m.retries,
        "bytes": m.bytes_received,
        "peak_rss_mb": round(m.peak_rss_mb, 1),
        "client_cpu_us_per_request": round(m.cpu_seconds / n * 1e6) if n else None,
        "server_cpu_us_per_request": (
            round(server_cpu / n * 1e6) if server_cpu is not None and n else None
        ),
        "side_by_side": side,
    }


def bound_row(requests: int, concurrency: int, latency_ms: float, jobs: int) -> dict[str, Any]:
    seconds = requests * latency_ms / 1000 / concurrency
    return {
        "client": LATENCY_BOUND,
        "concurrency": concurrency,
        "latency_ms": latency_ms,
        "jobs": jobs,
        "seconds": round(seconds, 4),
        "requests": requests,
        "requests_per_second": round(requests / seconds, 1) if seconds else None,
        "retries": 0,
        "bytes": None,
        "peak_rss_mb": None,
        "client_cpu_us_per_request": None,
        "server_cpu_us_per_request": None,
        "side_by_side": False,
    }


class _Timed:
    """Runs one client in a fresh process and measures the emulator's CPU meanwhile."""

    def __init__(self, emulator: EmulatorProcess) -> None:
        self._emulator = emulator
        # The emulator exposes no pid; its process object is the only way to read its CPU.
        process = emulator._process
        self._pid = process.pid if process is not None else None

    def run(self, fn: Callable[..., Measurement], *args: Any) -> tuple[Measurement, float | None]:
        before = process_cpu_seconds(self._pid) if self._pid is not None else None
        m: Measurement = in_fresh_process(fn, *args)
        after = process_cpu_seconds(self._pid) if self._pid is not None else None
        return m, (after - before if before is not None and after is not None else None)


def run_sweep(grid: Grid, say: Callable[[str], None]) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    total = grid.points
    done = 0
    with_resim = resim_available()
    if not with_resim:
        say("  resim-open-core is not installed: no ReSim reference")

    def show(row: dict[str, Any]) -> None:
        say(
            f"  [{done}/{total}] {row['client']:>17} c={row['concurrency']!s:>3} "
            f"{row['latency_ms']:>4g} ms {row['jobs']:>5} jobs: {row['seconds']:7.2f} s "
            f"{row['requests_per_second'] or 0:8.0f} req/s  {row['retries']} retries  "
            f"peak {row['peak_rss_mb'] or 0:.0f} MB"
        )

    deferred: list[tuple[float, int, int]] = []
    for latency in grid.latencies_ms:
        for jobs in grid.sizes:
            alone = [c for c in grid.concurrencies if not side_by_side(c, latency)]
            deferred += [(latency, jobs, c) for c in grid.concurrencies if c not in alone]
            if not alone:
                continue
            with emulator_for(jobs, latency) as emulator:
                targets = asyncio.run(collect_targets(emulator.info, SWEEP_DATA))
                timed = _Timed(emulator)
                for c in alone:
                    done += 1
                    for fn, args in (
                        (measure_stook, (emulator.info, SWEEP_CONFIG, c)),
                        (measure_bare, (targets, c, emulator.info.token)),
                    ):
                        m, server = timed.run(fn, *args)
                        row = _row(
                            m,
                            concurrency=c,
                            latency_ms=latency,
                            jobs=jobs,
                            side=False,
                            server_cpu=server,
                        )
                        rows.append(row)
                        show(row)
                    rows.append(bound_row(len(targets), c, latency, jobs))
                    if with_resim and c == RESIM_CONCURRENCY and jobs in grid.resim_sizes:
                        before = sum(emulator.stats().requests.values())
                        m, server = timed.run(measure_resim, emulator.info)
                        requests = sum(emulator.stats().requests.values()) - before
                        row = _row(
                            m,
                            concurrency=None,
                            latency_ms=latency,
                            jobs=jobs,
                            side=False,
                            server_cpu=server,
                            requests=requests,
                        )
                        rows.append(row)
                        show(row)
    if deferred:
        say(f"  {len(deferred)} latency-bound points, side by side ({SIDE_BY_SIDE_LANES} lanes)")
        rows += _run_side_by_side(deferred, grid, done, say)
    return rows


def _run_side_by_side(
    points: list[tuple[float, int, int]], grid: Grid, done: int, say: Callable[[str], None]
) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    groups = sorted({(latency, jobs) for latency, jobs, _ in points})
    with ExitStack() as stack:
        emulators: dict[tuple[float, int], tuple[EmulatorProcess, list[Target]]] = {}
        for latency, jobs in groups:
            emulator = stack.enter_context(emulator_for(jobs, latency))
            targets = asyncio.run(collect_targets(emulator.info, SWEEP_DATA))
            emulators[latency, jobs] = (emulator, targets)
        runs: list[tuple[float, float, int, int, Callable[..., Measurement], tuple[Any, ...]]] = []
        for latency, jobs, c in points:
            emulator, targets = emulators[latency, jobs]
            expected = len(targets) * latency / 1000 / c
            runs.append(
                (expected, latency, jobs, c, measure_stook, (emulator.info, SWEEP_CONFIG, c))
            )
            runs.append(
                (expected, latency, jobs, c, measure_bare, (targets, c, emulator.info.token))
            )
            rows.append(bound_row(len(targets), c, latency, jobs))
        # Longest first, so that the long ones overlap the many short ones.
        runs.sort(key=lambda run: -run[0])
        with ThreadPoolExecutor(max_workers=SIDE_BY_SIDE_LANES) as pool:
            futures = [
                (pool.submit(in_fresh_process, fn, *args), latency, jobs, c)
                for _, latency, jobs, c, fn, args in runs
            ]
            for future, latency, jobs, c in futures:
                m: Measurement = future.result()
                row = _row(m, concurrency=c, latency_ms=latency, jobs=jobs, side=True)
                rows.append(row)
                if m.client == STOOK:
                    done += 1
                say(
                    f"  [{done}/{grid.points}] {row['client']:>17} c={c:>3} {latency:>4g} ms "
                    f"{jobs:>5} jobs: {row['seconds']:7.2f} s "
                    f"{row['requests_per_second'] or 0:8.0f} req/s  (side by side)"
                )
    return rows
