"""EmulatorConfig.corrupt_data_jobs and revoke_token_after_requests: faults no retry fixes."""

from __future__ import annotations

import aiohttp
import pytest

from stook.emulator import Emulator, EmulatorConfig
from stook.sdk import read_metrics_data
from stook.sdk._errors import ReadError
from tests.emulator.support import SMALL, Raw


async def _data_blobs(raw: Raw, emu: Emulator, index: int) -> list[bytes]:
    job = emu.dataset.jobs(emu.batch_id)[index]
    items, _ = await raw.all_pages(
        f"/batches/{emu.batch_id}/jobs/{job.id}/metricsData", "metricsData"
    )
    assert items
    blobs = []
    for item in items:
        status, body = await raw.fetch(item["metricsDataURL"])
        assert status == 200
        blobs.append(body)
    return blobs


async def test_corrupt_data_jobs_serve_garbage_for_their_data_only() -> None:
    config = SMALL.replace(corrupt_data_jobs=(4,))
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        for blob in await _data_blobs(raw, emu, 4):
            with pytest.raises(ReadError, match="not a valid protobuf message"):
                read_metrics_data(blob, source="corrupt")
        for blob in await _data_blobs(raw, emu, 5):
            assert read_metrics_data(blob, source="healthy").name


async def test_the_token_is_refused_after_the_given_number_of_requests() -> None:
    async with Emulator(SMALL.replace(revoke_token_after_requests=3)) as emu:
        async with aiohttp.ClientSession() as session:
            raw = Raw(emu, session)
            statuses = [(await raw.get(f"/batches/{emu.batch_id}"))[0] for _ in range(5)]
        assert statuses == [200, 200, 200, 401, 401]
        assert emu.stats.unauthorized == 2


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"corrupt_data_jobs": (-1,)}, "corrupt_data_jobs"),
        ({"revoke_token_after_requests": -1}, "revoke_token_after_requests"),
    ],
)
def test_the_knobs_are_checked(changes: dict[str, object], name: str) -> None:
    with pytest.raises(ValueError, match=name):
        EmulatorConfig(**changes)  # type: ignore[arg-type]


def test_the_knobs_survive_the_round_trip_through_a_dict() -> None:
    config = EmulatorConfig(corrupt_data_jobs=(1, 7), revoke_token_after_requests=9)
    assert EmulatorConfig.from_dict(config.to_dict()) == config
