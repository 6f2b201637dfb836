"""`stook bench --probe`: how hard may a metrics build hit this ReSim API?

The probe reads the inputs and stook.toml a run would read, lists the batch's jobs (or the
report's batches) once, then climbs through the concurrency levels: at each, as many
workers as the level send the GETs a run sends (see _probe_plan) for a bounded time and
number of requests (see _probe_level). The first level answered with a 429, or with more
than a few percent of errors, is the last. It prints a table, the recommended
concurrency and the `[fetch]` lines for stook.toml, and writes probe.json, probe.csv and
probe.png (see _probe_results); interrupted, it writes what it measured so far.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Final, TextIO

import structlog

from stook.bench._probe_level import LevelResult, run_level
from stook.bench._probe_plan import ProbePlan
from stook.bench._probe_results import ProbeResult, fetch_lines, recommend, stops_climb
from stook.bench._probe_results import write_results as write_probe_results
from stook.service.api import RetryPolicy
from stook.service.modes import ConfigError, check_outputs_folder, open_api

__all__ = ["DEFAULT_LEVELS", "DEFAULT_MAX_REQUESTS", "DEFAULT_SECONDS_PER_LEVEL", "probe"]

log = structlog.get_logger("stook.probe")

DEFAULT_LEVELS: Final = (4, 8, 16, 32, 64, 128)
DEFAULT_SECONDS_PER_LEVEL: Final = 10.0
DEFAULT_MAX_REQUESTS: Final = 2_000
# How long the first requests (listing what the levels visit) may retry: an unreachable
# API or a refused token is said within seconds, not after a run's retry budget.
PREPARE_RETRY_S: Final = 5.0


async def probe(
    plan: ProbePlan,
    out: Path,
    *,
    levels: Sequence[int] = DEFAULT_LEVELS,
    seconds_per_level: float = DEFAULT_SECONDS_PER_LEVEL,
    max_requests: int = DEFAULT_MAX_REQUESTS,
    stream: TextIO | None = None,
) -> ProbeResult:
    """Run the probe of `plan`, write its results into `out` and print them to `stream`
    (stdout by default); cancelled, it writes and prints what it measured, then re-raises."""
    _check(levels, seconds_per_level, max_requests)
    check_outputs_folder(out)  # before the first request, as a run checks its outputs
    first = dataclasses.replace(plan.config.fetch, concurrency=min(levels), adaptive=False)
    retry = RetryPolicy(
        retry_for=min(first.retry_for, PREPARE_RETRY_S),
        request_timeout=min(first.timeout, PREPARE_RETRY_S),
    )
    async with open_api(plan.access, first, retry=retry) as api:
        await plan.prepare(api)
    log.info("probe listed", kind=plan.kind, units=len(plan.units))
    measured: list[LevelResult] = []
    stopped: str | None = None
    try:
        for concurrency in sorted(levels):
            level = await run_level(
                plan, concurrency, seconds=seconds_per_level, max_requests=max_requests
            )
            measured.append(level)
            log.info(
                "probe level",
                concurrency=concurrency,
                requests_per_s=level.requests_per_s,
                p95_ms=level.p95_ms,
                throttled=level.throttled,
                errors=level.errors,
            )
            stopped = stops_climb(level)
            if stopped is not None:
                break
    except Exception:
        raise  # a failure: its exit code and one line, and no partial output
    except BaseException:
        # Cancelled, or interrupted on the spot (Ctrl-C, SIGTERM): what was measured.
        _conclude(plan, measured, stopped, out, stream, interrupted=True)
        raise
    return _conclude(plan, measured, stopped, out, stream, interrupted=False)


def _conclude(
    plan: ProbePlan,
    measured: list[LevelResult],
    stopped: str | None,
    out: Path,
    stream: TextIO | None,
    *,
    interrupted: bool,
) -> ProbeResult:
    result = ProbeResult(
        kind=plan.kind,
        levels=tuple(measured),
        # A climb cut short recommends nothing: the next level might have been the best.
        recommended_concurrency=None if interrupted else recommend(measured),
        stopped=stopped,
        interrupted=interrupted,
    )
    # Interrupted, only what is quick: the signal's watchdog ends the process 1.5 s after
    # it, and importing matplotlib for the plot alone can take longer than that.
    written = write_probe_results(result, out, plot=not interrupted)
    print_result(result, stream or sys.stdout)
    log.info("probe written", files=[str(path) for path in written])
    return result


def print_result(result: ProbeResult, stream: TextIO) -> None:
    """The table of levels, the recommendation and the `[fetch]` lines."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"stook bench --probe ({result.kind} mode)")
    for header in ("concurrency", "req/s", "p50 ms", "p95 ms", "p99 ms"):
        table.add_column(header, justify="right")
    for header in ("API p95 ms", "storage p95 ms", "429s", "5xx", "errors", "retries"):
        table.add_column(header, justify="right")
    for level in result.levels:
        table.add_row(
            str(level.concurrency),
            f"{level.requests_per_s:g}",
            _ms(level.p50_ms),
            _ms(level.p95_ms),
            _ms(level.p99_ms),
            _ms(level.api.p95_ms),
            _ms(level.storage.p95_ms),
            str(level.throttled),
            str(level.api.server_errors + level.storage.server_errors),
            str(level.errors),
            str(level.retries),
        )
    console = Console(file=stream, width=120)
    console.print(table)
    if result.interrupted:
        console.print(
            "interrupted: the levels above are all that was measured; an unfinished climb "
            "recommends no concurrency (run the probe to its end for one)"
        )
        stream.flush()
        return
    if result.stopped:
        console.print(f"stopped climbing: {result.stopped}")
    recommended = result.recommended_concurrency
    console.print(
        f"recommended concurrency: {recommended}"
        if recommended is not None
        else "recommended concurrency: none of these levels (probe lower ones)"
    )
    console.print("paste into stook.toml:", highlight=False)
    stream.write(fetch_lines(result))
    stream.flush()


def _check(levels: Sequence[int], seconds_per_level: float, max_requests: int) -> None:
    if not levels or any(level < 1 for level in levels):
        raise ConfigError("--levels must be whole numbers of at least 1, e.g. 4,8,16")
    if len(set(levels)) != len(levels):
        raise ConfigError("--levels names a level twice")
    if not seconds_per_level > 0:
        raise ConfigError(f"--seconds-per-level must be positive, got {seconds_per_level:g}")
    if max_requests < 1:
        raise ConfigError(f"--max-requests must be at least 1, got {max_requests}")


def _ms(value: float | None) -> str:
    return "" if value is None else f"{value:g}"
