"""`stook bench --probe` against the emulator in its own process: the issue's acceptance.

With a server-side limit of 24 requests in flight (and 10 ms latency) the probe must
recommend 12 to 24 and end within its time bound; with no limit, the level where the
throughput stops growing. Short levels keep them to seconds, but they are still slow.
"""

from __future__ import annotations

import asyncio
import io
import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import structlog

from stook.bench import probe, read_plan
from stook.bench._probe_results import NEAR_BEST, P95_GROWTH
from stook.emulator import EmulatorConfig, EmulatorProcess
from stook.service.modes import configure_logging

pytestmark = pytest.mark.slow

SECONDS = 1.5
LEVELS = (4, 8, 16, 32, 64, 128)
TOML = '[[batch.histogram]]\nname = "Speeds"\ndata = "speeds"\nlower = 0.0\nupper = 40.0\n'


@pytest.fixture(autouse=True)
def _quiet_logs() -> Iterator[None]:
    # Unconfigured, structlog prints a debug line per request: the client's own CPU.
    configure_logging(json=True, level="warning")
    yield
    structlog.reset_defaults()


def run_probe(tmp_path: Path, emulator: EmulatorConfig) -> tuple[dict[str, Any], float, str]:
    (tmp_path / "stook.toml").write_text(TOML)
    printed = io.StringIO()
    with EmulatorProcess(emulator) as emu:
        emu.write_batch_config(tmp_path / "inputs")
        plan = read_plan(tmp_path / "inputs", tmp_path / "stook.toml", None)
        started = time.monotonic()
        asyncio.run(
            probe(
                plan,
                tmp_path / "out",
                levels=LEVELS,
                seconds_per_level=SECONDS,
                max_requests=800,
                stream=printed,
            )
        )
        elapsed = time.monotonic() - started
    doc = json.loads((tmp_path / "out" / "probe.json").read_text())
    return doc, elapsed, printed.getvalue()


def test_under_a_limit_of_24_in_flight_it_recommends_12_to_24(tmp_path: Path) -> None:
    config = EmulatorConfig(jobs_per_batch=200, latency_ms=10, max_in_flight=24)
    doc, elapsed, printed = run_probe(tmp_path, config)
    levels = doc["levels"]
    assert isinstance(levels, list)
    recommended = doc["recommended_concurrency"]
    assert isinstance(recommended, int)
    assert 12 <= recommended <= 24, printed
    # Levels at or below the limit are never refused; the first above it is, and is the last.
    assert [lv["throttled"] for lv in levels if lv["concurrency"] <= 24] == [0, 0, 0]
    assert levels[-1]["concurrency"] == 32, printed
    assert levels[-1]["throttled"] > 0, printed
    assert "throttled at concurrency 32" in str(doc["stopped"])
    # Within its time bound: every level, and the whole probe (listing and plot included).
    assert all(lv["seconds"] <= SECONDS + 0.25 for lv in levels)
    assert elapsed <= len(LEVELS) * SECONDS + 10
    assert (tmp_path / "out" / "probe.png").is_file()


def test_without_a_limit_it_recommends_where_the_throughput_stops_growing(
    tmp_path: Path,
) -> None:
    doc, _, printed = run_probe(tmp_path, EmulatorConfig(jobs_per_batch=200, latency_ms=10))
    levels = doc["levels"]
    assert isinstance(levels, list)
    assert [lv["concurrency"] for lv in levels] == list(LEVELS)  # nothing stopped the climb
    assert all(lv["throttled"] == 0 and lv["errors"] == 0 for lv in levels)
    # Of the levels whose p95 has not doubled (past them requests queue), the throughput
    # grew up to the recommended one, and by no more than 10 % after it.
    calm = [lv for lv in levels if lv["p95_ms"] <= P95_GROWTH * levels[0]["p95_ms"]]
    best = max(lv["requests_per_s"] for lv in calm)
    recommended = doc["recommended_concurrency"]
    chosen = next(lv for lv in calm if lv["concurrency"] == recommended)
    assert chosen["requests_per_s"] >= NEAR_BEST * best, printed
    below = [lv for lv in calm if lv["concurrency"] < recommended]
    assert all(lv["requests_per_s"] < NEAR_BEST * best for lv in below), printed
    # At 10 ms, 4 workers cannot be the most the server gives: the throughput grew past them.
    assert recommended > LEVELS[0], printed
