"""`stook bench --engines` at a small size: one measured run per engine (here in the test's
process, without the fresh process per run), and the table it writes.

Only what the runs did is checked: seconds and memory are measured on a quiet machine.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import structlog

from stook.bench._engines import engine_tables, measure_engine
from stook.emulator import EmulatorConfig, EmulatorInfo, EmulatorProcess


@pytest.fixture(scope="module")
def info() -> Iterator[EmulatorInfo]:
    with EmulatorProcess(EmulatorConfig(seed=11, jobs_per_batch=30, latency_ms=0.0)) as emulator:
        yield emulator.info


@pytest.fixture(autouse=True)
def _fresh_structlog() -> Iterator[None]:
    yield
    structlog.reset_defaults()  # measure_engine logs into a buffer of its own


@pytest.mark.slow
def test_local_and_processes_runs_are_measured_alike(info: EmulatorInfo) -> None:
    local = measure_engine(info, {"kind": "local"})
    sharded = measure_engine(info, {"kind": "processes", "workers": 2, "shards": 3})
    assert local["jobs"] == sharded["jobs"] == 30
    assert local["shards"] is None
    assert sharded["shards"] == 3
    assert sharded["state_bytes_per_shard_max"] > 0
    assert sharded["output_sha256"] == local["output_sha256"]
    table = engine_tables(
        {"jobs": 30, "engines": [local], "shards": [sharded], "identical_outputs": True}
    )
    assert "| local | - | - |" in table
    assert "| processes | 2 | 3 |" in table
