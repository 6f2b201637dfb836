"""What the progress bar's total comes from: every batch's `totalJobs`, and the job
listing's `total` on every page, as the spec has them, quirks or not."""

from __future__ import annotations

import aiohttp
import pytest

from stook.emulator import Emulator
from tests.emulator.support import SMALL, Raw


@pytest.mark.parametrize("quirks", [False, True])
async def test_every_batch_says_its_job_count(quirks: bool) -> None:
    config = SMALL.replace(spec_quirks=quirks)
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        for batch in emu.dataset.batches:
            jobs = len(list(emu.dataset.jobs(batch.id)))
            status, body = await raw.get(f"/batches/{batch.id}")
            assert status == 200
            assert body["totalJobs"] == jobs
            status, page = await raw.get(f"/batches/{batch.id}/jobs", params={"pageSize": 2})
            assert page["total"] == jobs
        status, listed = await raw.get("/batches", params={"pageSize": 2})
        assert listed["total"] == len(emu.dataset.batches)
        assert all("totalJobs" in b for b in listed["batches"])
