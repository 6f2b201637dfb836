"""`[engine]`: one batch run on `local`, `processes` and `ray`, and the driver's memory
against the number of shards.

A batch of one series per job folded into a histogram, at 0 ms latency, so that the run is
bound by the client's CPU, which is what the engines spread. Each run is measured in a
fresh process (its peak RSS is the driver's own; the workers are other processes) against
one emulator process; the first run warms the emulator. Whole-run seconds include starting
the workers (and, for `ray` without a cluster, a local Ray instance): that is what a run
pays. On a machine of two cores the emulator shares them with the workers; the numbers
are honest about that, not a cluster's.

`stook bench --engines` (`--quick`: 2,000 jobs) writes `engines.json` and `engines.md`.
"""

from __future__ import annotations

import hashlib
import importlib
import io
import json
import resource
import tempfile
import time
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

from stook.bench._measure import in_fresh_process, peak_rss_mb, process_cpu_seconds
from stook.emulator import EmulatorConfig, EmulatorInfo, EmulatorProcess

FULL_JOBS: Final = 20_000
QUICK_JOBS: Final = 2_000
WORKERS: Final = 2
SHARD_COUNTS: Final = (2, 8, 32)

ENGINE_BENCH_CONFIG: Final = """\
[batch]
defaults = false

[[batch.histogram]]
name = "Speed distribution"
data = "speeds"
lower = 0.0
upper = 40.0
buckets = 20

[output]
summary = false
"""

#: (label, [engine] table) of the comparison
ENGINES: Final[tuple[tuple[str, dict[str, Any]], ...]] = (
    ("local", {"kind": "local"}),
    ("processes", {"kind": "processes", "workers": WORKERS}),
    ("ray", {"kind": "ray", "workers": WORKERS}),
)


def measure_engine(info: EmulatorInfo, engine: dict[str, Any]) -> dict[str, Any]:
    """One batch run as `stook run` does it with `engine`, in this (fresh) process."""
    from stook.service.modes import (
        BatchInputs,
        configure_logging,
        detect,
        parse,
        run_batch,
        run_on_event_loop,
    )

    events = io.StringIO()
    configure_logging(json=True, level="info", stream=events)
    for module in ("polars", "numpy"):  # start-up, not the run (as in _measure)
        importlib.import_module(module)
    doc = tomllib.loads(ENGINE_BENCH_CONFIG)
    doc["engine"] = engine
    config = parse(doc, source="bench")
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "inputs"
        info.write_batch_config(inputs)
        batch = detect(inputs)
        assert isinstance(batch, BatchInputs)
        started = time.perf_counter()
        cpu_before = _cpu_with_workers()
        result = run_on_event_loop(run_batch(batch, config, Path(tmp) / "outputs"))
        seconds = time.perf_counter() - started
        client_cpu = _cpu_with_workers() - cpu_before
        digest = hashlib.sha256(result.output.read_bytes()).hexdigest()
    shards = [e for e in _events(events.getvalue()) if e.get("event") == "shard finished"]
    state_bytes = [int(e["state_bytes"]) for e in shards]
    return {
        "engine": engine["kind"],
        "workers": engine.get("workers"),
        "shards": len(shards) or None,
        "jobs": result.outcome.jobs_listed,
        "seconds": round(seconds, 2),
        "client_cpu_s": round(client_cpu, 2),
        "driver_peak_rss_mb": round(peak_rss_mb(), 1),
        "state_bytes_per_shard_max": max(state_bytes, default=None),
        "requests": result.requests,
        "output_sha256": digest,
    }


def run_engine_bench(
    out_dir: Path, *, quick: bool, jobs: int | None = None, say: Callable[[str], None] = print
) -> dict[str, Any]:
    """The engines compared, then the driver's peak memory against the shard count."""
    jobs = jobs or (QUICK_JOBS if quick else FULL_JOBS)
    emulator_config = EmulatorConfig(
        seed=11, jobs_per_batch=jobs, cache_jobs=jobs, latency_ms=0.0, default_page_size=100
    )
    rows: list[dict[str, Any]] = []
    memory: list[dict[str, Any]] = []
    with EmulatorProcess(emulator_config) as emulator:
        say(f"engines: {jobs:,} jobs at 0 ms, one series per job into a histogram ...")
        in_fresh_process(measure_engine, emulator.info, {"kind": "local"})  # warm-up
        # The emulator shares the machine's cores: its CPU beside the client's says how
        # much of the machine was left for the engines to spread.
        pid = emulator.pid
        for label, engine in ENGINES:
            before = process_cpu_seconds(pid) if pid is not None else None
            try:
                row = in_fresh_process(measure_engine, emulator.info, engine)
            except Exception as exc:  # Ray not installed or not startable here: said, skipped
                say(f"  {label}: not measured ({type(exc).__name__}: {exc})")
                continue
            after = process_cpu_seconds(pid) if pid is not None else None
            row["emulator_cpu_s"] = (
                round(after - before, 2) if before is not None and after is not None else None
            )
            rows.append(row)
            say(
                f"  {label}: {row['seconds']:.2f} s, client CPU {row['client_cpu_s']:.1f} s, "
                f"emulator CPU {row['emulator_cpu_s']} s, driver peak RSS "
                f"{row['driver_peak_rss_mb']:.0f} MB, state per shard "
                f"{row['state_bytes_per_shard_max'] or 0:,} B"
            )
        for shards in SHARD_COUNTS:
            sharded: dict[str, Any] = {"kind": "processes", "workers": WORKERS, "shards": shards}
            row = in_fresh_process(measure_engine, emulator.info, sharded)
            memory.append(row)
            say(f"  processes, {shards} shards: driver peak RSS {row['driver_peak_rss_mb']:.0f} MB")
    identical = len({r["output_sha256"] for r in rows + memory}) == 1
    say(f"  outputs identical across engines and shard counts: {identical}")
    results = {"jobs": jobs, "engines": rows, "shards": memory, "identical_outputs": identical}
    prefix = "quick-" if quick else ""
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / f"{prefix}engines.json").write_text(json.dumps(results, indent=2) + "\n")
    (out_dir / f"{prefix}engines.md").write_text(engine_tables(results))
    say(f"wrote {out_dir / f'{prefix}engines.json'}, {out_dir / f'{prefix}engines.md'}")
    return results


def engine_tables(results: dict[str, Any]) -> str:
    lines = [
        f"{results['jobs']:,} jobs at 0 ms, one series per job into a histogram.",
        "",
        "| engine | workers | shards | seconds | client CPU (s) | driver peak RSS (MB) "
        "| state bytes per shard |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in results["engines"] + results["shards"]:
        lines.append(
            f"| {row['engine']} | {row['workers'] or '-'} | {row['shards'] or '-'} | "
            f"{row['seconds']:.2f} | {row['client_cpu_s']:.1f} | {row['driver_peak_rss_mb']:.0f} | "
            f"{row['state_bytes_per_shard_max'] or '-'} |"
        )
    lines += ["", f"Outputs identical: {results['identical_outputs']}.", ""]
    return "\n".join(lines)


def _cpu_with_workers() -> float:
    """CPU seconds of this process and of its ended children (worker processes; a local
    Ray instance's workers are not children of the driver and are not counted)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _events(text: str) -> list[dict[str, Any]]:
    found = []
    for line in text.splitlines():
        if line.startswith("{"):
            found.append(json.loads(line))
    return found
