"""A run shows its progress a few times a second, not per job, and ends on the full counts."""

from __future__ import annotations

import time
from pathlib import Path

from stook.service.modes import BatchInputs, detect, parse, run_batch
from stook.service.modes._progress import FetchProgress
from stook.testing import emulated_batch

JOBS = 150
CONFIG = """\
[[batch.histogram]]
name = "Speed distribution"
data = "speeds"
lower = 0.0
upper = 40.0
buckets = 20
"""


class Recording:
    def __init__(self) -> None:
        self.snapshots: list[FetchProgress] = []
        self.closed = False

    def update(self, snapshot: FetchProgress) -> None:
        self.snapshots.append(snapshot)

    def close(self) -> None:
        self.closed = True


async def test_progress_is_shown_a_few_times_a_second_and_ends_complete(tmp_path: Path) -> None:
    import tomllib

    shown = Recording()
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=JOBS, seed=5) as emu:
        inputs = detect(tmp_path / "inputs")
        assert isinstance(inputs, BatchInputs)
        started = time.monotonic()
        await run_batch(
            inputs, parse(tomllib.loads(CONFIG), source="test"), tmp_path / "out", progress=shown
        )
        elapsed = time.monotonic() - started
        requests = sum(emu.stats.requests.values())
    # Each job is listed and done: per-job updates would be 2 x JOBS. At most one per
    # 0.05 s is shown, plus the once-a-second ticks and the final one.
    assert len(shown.snapshots) <= elapsed / 0.05 + elapsed + 3
    assert len(shown.snapshots) < 2 * JOBS
    last = shown.snapshots[-1]
    assert (last.jobs_done, last.jobs_listed, last.total) == (JOBS, JOBS, JOBS)
    assert last.requests == requests
    assert shown.closed
