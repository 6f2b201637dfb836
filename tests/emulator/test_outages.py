"""EmulatorConfig.outages: one origin answers 503 to everything for a while."""

from __future__ import annotations

import asyncio
import json
import time

import aiohttp
import pytest

from stook.emulator import Emulator, EmulatorConfig, Outage
from stook.emulator._faults import OutageSchedule
from tests.emulator.support import SMALL, Raw


def test_an_outage_begins_after_its_requests_and_lasts_its_duration() -> None:
    schedule = OutageSchedule((Outage("api", duration_s=2.0, after_requests=3),), now=100.0)
    assert schedule.refuses("api", answered=2, now=101.0) is None
    assert schedule.refuses("api", answered=3, now=101.0) == ("api", 101.0, 103.0)
    assert schedule.refuses("storage", answered=50, now=101.5) is None  # the other origin
    assert schedule.refuses("api", answered=4, now=102.9) == ("api", 101.0, 103.0)
    assert schedule.refuses("api", answered=5, now=103.0) is None  # over, for good
    assert schedule.refuses("api", answered=6, now=150.0) is None


def test_an_outage_can_begin_after_a_time() -> None:
    schedule = OutageSchedule((Outage("storage", duration_s=1.0, after_s=5.0),), now=0.0)
    assert schedule.refuses("storage", answered=100, now=4.9) is None
    assert schedule.refuses("storage", answered=101, now=5.2) == ("storage", 5.2, 6.2)


@pytest.mark.parametrize(
    ("outage", "message"),
    [
        ({"origin": "db", "duration_s": 1.0}, "origin"),
        ({"origin": "api", "duration_s": 0.0}, "duration_s"),
        ({"origin": "api", "duration_s": 1.0, "after_requests": -1}, "after_requests"),
    ],
)
def test_bad_outages_are_refused(outage: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Outage(**outage)  # type: ignore[arg-type]


def test_outages_survive_the_round_trip_through_a_dict_and_json() -> None:
    config = EmulatorConfig(outages=(Outage("storage", 8.0, after_requests=20),))
    back = EmulatorConfig.from_dict(json.loads(json.dumps(config.to_dict())))
    assert back == config


async def test_every_request_of_the_origin_answers_503_during_the_outage() -> None:
    config = SMALL.replace(outages=(Outage("api", duration_s=0.5, after_requests=1),))
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        assert (await raw.get(f"/batches/{emu.batch_id}"))[0] == 200
        began = time.monotonic()
        for _ in range(3):
            assert (await raw.get(f"/batches/{emu.batch_id}"))[0] == 503
        # The wrong token gets the same answer: nothing is behind the load balancer.
        answer = await raw.get(f"/batches/{emu.batch_id}", headers={"Authorization": "x"})
        assert answer[0] == 503
        await asyncio.sleep(0.5 - (time.monotonic() - began) + 0.05)
        assert (await raw.get(f"/batches/{emu.batch_id}"))[0] == 200
        stats = emu.stats
    assert stats.outage_refusals == {"api": 4}
    assert len(stats.outage_windows) == 1
    origin, start, end = stats.outage_windows[0]
    assert origin == "api"
    assert end - start == pytest.approx(0.5)
    assert stats.to_dict()["outage_refusals"] == {"api": 4}
