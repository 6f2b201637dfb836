"""Batch mode over the jobs' emissions logs: `stook run` with `[metrics_config]`, timed as a
whole process against the emulator (in its own process, with latency).

Issue 30's size: 1,000 jobs, each emitting about 1,000 rows (`emission_frames` = 500: two
rows a frame, plus a few), at 10 ms. stook's own batch metrics are off, so the run is the
jobs' listing, their log listings and downloads, the tables and the config's batch queries.
The first run is untimed (the emulator makes each job's log on first request).
"""

from __future__ import annotations

import statistics
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

from stook.bench._sweep import emulator_for
from stook.bench._whole_process import time_stook_run
from stook.emulator import write_emissions_config

__all__ = ["measure_emissions_batch"]

JOBS: Final = 1000
QUICK_JOBS: Final = 100
FRAMES: Final = 500
LATENCY_MS: Final = 10.0
RUNS: Final = 3
QUICK_RUNS: Final = 1

CONFIG_TOML: Final = """\
[batch]
defaults = false

[output]
summary = false

[metrics_config]
paths = ["config.resim.yml"]
"""


def _time_run(info: Any, folder: Path) -> float:
    inputs = folder / "inputs"
    inputs.mkdir(parents=True)
    info.write_batch_config(inputs)
    write_emissions_config(folder)
    return time_stook_run(folder, CONFIG_TOML)


def measure_emissions_batch(
    jobs: int = JOBS,
    latency_ms: float = LATENCY_MS,
    runs: int = RUNS,
    *,
    frames: int = FRAMES,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Every timed run's seconds, their median, and the rows the jobs emitted."""
    seconds: list[float] = []
    with (
        emulator_for(jobs, latency_ms, emission_frames=frames) as emulator,
        tempfile.TemporaryDirectory() as tmp,
    ):
        _time_run(emulator.info, Path(tmp) / "warm")
        before = sum(emulator.stats().requests.values())
        for i in range(runs):
            seconds.append(_time_run(emulator.info, Path(tmp) / f"run-{i}"))
        requests = (sum(emulator.stats().requests.values()) - before) // runs
    # The rows come from the seed alone: counted here, in this process, untimed.
    from stook.emulator import Dataset, EmulatorConfig

    dataset = Dataset(EmulatorConfig(seed=11, jobs_per_batch=jobs, emission_frames=frames))
    rows = sum(len(r) for _, r in dataset.emitted_rows(dataset.main_batch_id) if r is not None)
    median = statistics.median(seconds)
    result = {
        "jobs": jobs,
        "rows": rows,
        "latency_ms": latency_ms,
        "runs_s": [round(s, 3) for s in seconds],
        "median_s": round(median, 3),
        "rows_per_s": round(rows / median),
        "requests": requests,
    }
    say(
        f"  batch mode over emissions logs: {jobs:,} jobs, {rows:,} rows at {latency_ms:g} ms: "
        f"{median:.2f} s ({result['rows_per_s']:,} rows/s; whole process, median of {runs})"
    )
    return result
