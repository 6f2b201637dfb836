"""Transient faults and expired presigned URLs change nothing in the output."""

from __future__ import annotations

import asyncio
import tomllib
from pathlib import Path
from typing import Any

import pytest

from stook.emulator import Emulator
from stook.service.api import RetryPolicy
from stook.service.modes._batch import BatchResult, run_batch
from stook.service.modes._config import parse
from stook.service.modes._inputs import BatchInputs, detect
from stook.testing import emulated_batch
from tests.e2e.support import BATCH_TOML, assert_matches_truth, expected_from_truth, read_output

JOBS = 80
SEED = 23
FAST = RetryPolicy(initial_backoff=0, request_timeout=5.0)
FAULTS: dict[str, Any] = {
    "fault_5xx": 0.10,
    "fault_429": 0.03,
    "fault_reset": 0.01,
    "retry_after_max_s": 0,
}


async def _run(tmp: Path, emu: Emulator) -> BatchResult:
    inputs = tmp / "inputs"
    emu.write_batch_config(inputs)
    config = parse(tomllib.loads(BATCH_TOML), source="stook.toml")
    batch = detect(inputs)
    assert isinstance(batch, BatchInputs)
    return await run_batch(batch, config, tmp / "outputs", retry=FAST)


@pytest.fixture(scope="module")
def fault_free_output(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    tmp = tmp_path_factory.mktemp("fault-free")

    async def go() -> bytes:
        async with emulated_batch(tmp / "inputs", jobs_per_batch=JOBS, seed=SEED) as emu:
            result = await _run(tmp, emu)
            assert result.retries == 0
            assert emu.stats.fault_count() == 0
            view = read_output(result.output)
            assert_matches_truth(view, expected_from_truth(emu))
            return result.output.read_bytes()

    return asyncio.run(go())


async def test_transient_faults_leave_the_output_byte_identical(
    tmp_path: Path, fault_free_output: bytes
) -> None:
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=JOBS, seed=SEED, **FAULTS) as emu:
        result = await _run(tmp_path, emu)
        stats = emu.stats
    assert result.output.read_bytes() == fault_free_output
    assert not result.outcome.missing
    # Faults of every configured kind were injected, on both origins, and each was retried.
    assert stats.fault_count("5xx") > 0
    assert stats.fault_count("429") > 0
    assert stats.fault_count(origin="api") > 0
    assert stats.fault_count(origin="storage") > 0
    assert stats.fault_count() >= 20
    assert result.retries == stats.fault_count()
    assert stats.leaked_tokens == 0


async def test_expired_presigned_urls_are_listed_again(
    tmp_path: Path, fault_free_output: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every metrics-data URL is already expired when first handed out (as if the client
    had been slow); the client must list the job's data again for fresh URLs."""
    lifetime = 30.0
    async with emulated_batch(
        tmp_path / "inputs", jobs_per_batch=JOBS, seed=SEED, url_lifetime_s=lifetime
    ) as emu:
        state = emu._state
        first_signed: set[str] = set()

        def presign(path: str) -> str:
            issued = state.now()
            if "/metricsData/" in path and path not in first_signed:
                first_signed.add(path)
                issued -= 2 * lifetime
            return state.signer.sign(state.storage_url, path, issued)

        monkeypatch.setattr(state, "presign", presign)
        result = await _run(tmp_path, emu)
        stats = emu.stats
        speeds = emu.dataset.series_values(emu.batch_id, "speeds")
        downloaded = len(speeds)
        # Requests a job's metrics-data listing takes (the emulator serves short pages).
        page = emu.config.max_page_size
        pages = {
            job.id: max(1, -(-len(output.data) // page))
            for job, output in emu.dataset.iter_outputs(emu.batch_id)
        }
    assert result.output.read_bytes() == fault_free_output
    # Each downloaded item ("speeds", one per job with metrics) was refused once.
    assert downloaded > 0
    assert stats.expired_urls == downloaded
    assert stats.bad_signatures == 0
    assert stats.endpoints["api:list_job_metrics_data"] == sum(pages.values()) + sum(
        pages[job_id] for job_id in speeds
    )


async def test_urls_that_expire_with_the_clock_are_listed_again(
    tmp_path: Path, fault_free_output: bytes
) -> None:
    """The emulator's clock jumps past the URL lifetime while the client works."""
    lifetime = 5.0
    async with emulated_batch(
        tmp_path / "inputs",
        jobs_per_batch=JOBS,
        seed=SEED,
        url_lifetime_s=lifetime,
        latency_ms=2.0,
    ) as emu:

        async def jump_once() -> None:
            # Polled: the emulator has no hook to wait on, and a tick is cheap here.
            while True:
                if emu.stats.endpoints["api:list_job_metrics_data"] >= JOBS // 2:
                    break
                await asyncio.sleep(0.001)
            emu.advance_clock(lifetime + 1)

        jumper = asyncio.create_task(jump_once())
        result = await _run(tmp_path, emu)
        await jumper
        stats = emu.stats
    assert result.output.read_bytes() == fault_free_output
    assert stats.bad_signatures == 0
    # Downloads in flight at the jump were refused (timing decides how many, not whether).
    assert stats.expired_urls > 0


async def test_the_run_says_what_its_limiter_did(tmp_path: Path) -> None:
    # Every request of the run, API and storage, passes the shared bound, and every
    # throttling answer comes back through it: the run's traffic shows both, unpatched.
    async with emulated_batch(
        tmp_path / "inputs", jobs_per_batch=20, seed=SEED, fault_429=0.05, retry_after_max_s=0
    ) as emu:
        result = await _run(tmp_path, emu)
        refused = sum(n for key, n in emu.stats.statuses.items() if key.endswith(":429"))
    stats = result.traffic.limit_stats
    assert set(stats) == {"shared"}
    assert stats["shared"].acquisitions == result.requests
    assert stats["shared"].in_flight == 0
    assert stats["shared"].throttled == refused > 0
