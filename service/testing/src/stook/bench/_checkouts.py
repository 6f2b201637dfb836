"""Client CPU per request of several checkouts of stook, interleaved on one emulator.

What a speed change is measured by (docs/performance.md): each round runs
every checkout once, each a fresh process running `measure_stook` (batch mode, the sweep's
plan) with ``PYTHONPATH`` pointing at that checkout's sources, against one emulator. A
plain subprocess, not `in_fresh_process`: multiprocessing's spawn hands the child the
parent's ``sys.path``, which overrides ``PYTHONPATH``, so every "checkout" would run the
installed one.

    python -m stook.bench._checkouts 5 1000 . /path/to/other/checkout
"""

from __future__ import annotations

import compileall
import json
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from stook.bench._sweep import emulator_for

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
    for checkout in checkouts:  # as pip compiles an installed wheel (see _startup)
        for part in _SOURCES:
            compileall.compile_dir(checkout / part / "src", quiet=1)
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


if __name__ == "__main__":
    rounds, jobs, *paths = sys.argv[1:]
    result = compare_checkouts([Path(p) for p in paths], int(rounds), int(jobs))
    for name, row in result.items():
        print(
            f"{name}: {row['median_cpu_us_per_request']} µs a request "
            f"({min(row['cpu_us_per_request'])}-{max(row['cpu_us_per_request'])}), "
            f"{row['median_seconds']} s"
        )
