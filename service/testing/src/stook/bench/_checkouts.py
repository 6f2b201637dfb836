"""Several checkouts of stook, interleaved on one emulator: CPU per request, whole processes.

What a speed change is measured by (docs/performance.md). `compare_checkouts`: each round
runs every checkout once, each a fresh process running `measure_stook` (batch mode, the
sweep's plan) with ``PYTHONPATH`` pointing at that checkout's sources, against one
emulator: the client's CPU per request. `compare_whole_processes`: each round runs every
checkout's `stook run` as a whole process, as a user times it (start-up, fetch, write and
exit), with its wall seconds and the CPU seconds the process used. Plain subprocesses, not
`in_fresh_process`: multiprocessing's spawn hands the child the parent's ``sys.path``, which
overrides ``PYTHONPATH``, so every "checkout" would run the installed one.

    python -m stook.bench._checkouts 5 1000 . /path/to/other/checkout
    python -m stook.bench._checkouts --whole 7 400 . /path/to/other/checkout  # at 10 ms
"""

from __future__ import annotations

import compileall
import json
import os
import pickle
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from stook.bench._startup import stook_command
from stook.bench._sweep import SWEEP_CONFIG, emulator_for

_SOURCES = ("proto", "sdk", "service", "service/testing")

_CHILD = """
import json, pickle, sys
from stook.bench._measure import measure_stook
from stook.bench._sweep import SWEEP_CONFIG
import stook.service
with open(sys.argv[1], "rb") as f:
    info = pickle.load(f)
m = measure_stook(info, SWEEP_CONFIG, int(sys.argv[2]))
print(json.dumps([m.cpu_seconds, m.requests, m.seconds, m.peak_rss_mb, stook.service.__file__]))
"""


def source_path(checkout: Path) -> str:
    """The ``PYTHONPATH`` that runs `checkout`'s stook instead of the installed one."""
    return os.pathsep.join(str(checkout.resolve() / part / "src") for part in _SOURCES)


def compare_checkouts(
    checkouts: Sequence[Path],
    rounds: int,
    jobs: int,
    *,
    latency_ms: float = 0.0,
    concurrency: int = 64,
) -> dict[str, dict[str, Any]]:
    """Per checkout: every round's CPU µs per request, wall seconds and peak RSS, and their
    medians (a first, untimed round warms the emulator)."""
    runs: dict[str, list[tuple[float, float, float]]] = {str(c): [] for c in checkouts}
    for checkout in checkouts:
        _compile(checkout)
    with emulator_for(jobs, latency_ms) as emulator, tempfile.TemporaryDirectory() as tmp:
        info_file = Path(tmp) / "info.pickle"
        info_file.write_bytes(pickle.dumps(emulator.info))
        for round_number in range(rounds + 1):
            for checkout in checkouts:
                env = dict(os.environ, PYTHONPATH=source_path(checkout))
                done = subprocess.run(
                    [sys.executable, "-c", _CHILD, str(info_file), str(concurrency)],
                    env=env,
                    capture_output=True,
                    text=True,
                    check=True,
                )
                cpu, requests, seconds, rss, module = json.loads(done.stdout.splitlines()[-1])
                if not Path(module).resolve().is_relative_to(checkout.resolve()):
                    raise RuntimeError(f"{checkout}: the run imported stook from {module}")
                if round_number:
                    runs[str(checkout)].append((cpu / requests * 1e6, seconds, rss))
    return {
        name: {
            "cpu_us_per_request": [round(r[0], 1) for r in rows],
            "seconds": [round(r[1], 3) for r in rows],
            "peak_rss_mb": [round(r[2], 1) for r in rows],
            "median_cpu_us_per_request": round(statistics.median(r[0] for r in rows), 1),
            "median_seconds": round(statistics.median(r[1] for r in rows), 3),
        }
        for name, rows in runs.items()
    }


def _compile(checkout: Path) -> None:
    for part in _SOURCES:  # as pip compiles an installed wheel (see _startup)
        compileall.compile_dir(checkout / part / "src", quiet=1)


def compare_whole_processes(
    checkouts: Sequence[Path],
    rounds: int,
    jobs: int,
    *,
    latency_ms: float = 10.0,
    env: Mapping[str, Mapping[str, str]] | None = None,
) -> dict[str, dict[str, Any]]:
    """Per checkout: every round's wall and CPU seconds of a whole `stook run` process
    (batch mode, the sweep's config) and their medians; a first round warms the emulator.

    `env` adds environment variables per checkout (by its path as given), e.g. to compare
    one checkout with a setting and without.
    """
    runs: dict[str, list[tuple[float, float]]] = {str(c): [] for c in checkouts}
    for checkout in checkouts:
        _compile(checkout)
    with emulator_for(jobs, latency_ms) as emulator, tempfile.TemporaryDirectory() as tmp:
        for round_number in range(rounds + 1):
            for i, checkout in enumerate(checkouts):
                folder = Path(tmp) / f"{round_number}-{i}"
                inputs, outputs = folder / "inputs", folder / "outputs"
                inputs.mkdir(parents=True)
                emulator.info.write_batch_config(inputs)
                config = folder / "stook.toml"
                config.write_text(SWEEP_CONFIG, encoding="utf-8")
                extra = (env or {}).get(str(checkout), {})
                child_env = dict(os.environ, PYTHONPATH=source_path(checkout), **extra)
                argv = [
                    *stook_command(),
                    "run",
                    "--inputs",
                    str(inputs),
                    "--outputs",
                    str(outputs),
                    "--config",
                    str(config),
                    "--log-level",
                    "error",
                ]
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                started = time.perf_counter()
                subprocess.run(
                    argv, cwd=folder, env=child_env, capture_output=True, check=True, timeout=600
                )
                seconds = time.perf_counter() - started
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
                if not (outputs / "metrics.binproto").is_file():
                    raise RuntimeError(f"{checkout}: stook run wrote no metrics.binproto")
                if round_number:
                    runs[str(checkout)].append((seconds, cpu))
    return {
        name: {
            "seconds": [round(r[0], 3) for r in rows],
            "cpu_seconds": [round(r[1], 3) for r in rows],
            "median_seconds": round(statistics.median(r[0] for r in rows), 3),
            "median_cpu_seconds": round(statistics.median(r[1] for r in rows), 3),
        }
        for name, rows in runs.items()
    }


if __name__ == "__main__":
    if sys.argv[1] == "--whole":
        rounds, jobs, *paths = sys.argv[2:]
        whole = compare_whole_processes([Path(p) for p in paths], int(rounds), int(jobs))
        for name, row in whole.items():
            print(
                f"{name}: {row['median_seconds']} s, {row['median_cpu_seconds']} s of CPU "
                f"(walls {sorted(row['seconds'])}, CPU {sorted(row['cpu_seconds'])})"
            )
        sys.exit(0)
    rounds, jobs, *paths = sys.argv[1:]
    result = compare_checkouts([Path(p) for p in paths], int(rounds), int(jobs))
    for name, row in result.items():
        print(
            f"{name}: {row['median_cpu_us_per_request']} µs a request "
            f"({min(row['cpu_us_per_request'])}-{max(row['cpu_us_per_request'])}), "
            f"{row['median_seconds']} s"
        )
