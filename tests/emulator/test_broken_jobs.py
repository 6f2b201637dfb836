"""EmulatorConfig.broken_jobs: listings of chosen jobs answer 500, every time."""

from __future__ import annotations

import json

import aiohttp
import pytest

from stook.emulator import Emulator, EmulatorConfig
from tests.emulator.support import SMALL, Raw


async def test_broken_jobs_answer_500_on_every_attempt_and_others_do_not() -> None:
    # A streak cap of 1 would let a transient fault through on the second try; not these.
    config = SMALL.replace(broken_jobs=(2, 5), max_consecutive_faults=1)
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        jobs = emu.dataset.jobs(emu.batch_id)
        for index in (2, 5):
            job = jobs[index]
            base = f"/batches/{emu.batch_id}/jobs/{job.id}"
            for path in (f"{base}/metrics", f"{base}/metricsData"):
                statuses = [(await raw.get(path))[0] for _ in range(4)]
                assert statuses == [500] * 4, path
            # The job itself is still listed and readable.
            status, body = await raw.get(base)
            assert (status, body["jobID"]) == (200, str(job.id))
        healthy = jobs[3]
        status, body = await raw.get(f"/batches/{emu.batch_id}/jobs/{healthy.id}/metrics")
        assert status == 200
        assert body["metrics"]
        assert emu.stats.broken_job_answers == 16
        assert emu.stats.statuses["api:500"] == 16


async def test_broken_jobs_only_concern_the_main_batch() -> None:
    config = SMALL.replace(broken_jobs=(0,))
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        report_batch = emu.dataset.report_batches()[0]
        job = emu.dataset.jobs(report_batch.id)[0]
        status, _ = await raw.get(f"/batches/{report_batch.id}/jobs/{job.id}/metrics")
        assert status == 200
        assert emu.stats.broken_job_answers == 0


def test_broken_jobs_survive_the_round_trip_through_a_dict_and_json() -> None:
    config = EmulatorConfig(broken_jobs=(1, 7))
    assert EmulatorConfig.from_dict(config.to_dict()) == config
    assert EmulatorConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config
    assert EmulatorConfig.from_dict(json.loads(json.dumps(config.to_dict()))).broken_jobs == (1, 7)


@pytest.mark.parametrize("bad", [(-1,), (True,), (1.5,)])
def test_broken_jobs_must_be_job_indices(bad: tuple[object, ...]) -> None:
    with pytest.raises(ValueError, match="broken_jobs"):
        EmulatorConfig(broken_jobs=bad)  # type: ignore[arg-type]
