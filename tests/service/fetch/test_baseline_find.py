"""Finding the baseline and reading metric directions, against the emulator."""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator
from typing import Any

import pytest

from stook.emulator import BatchKind, Emulator
from stook.service.api import ApiClient
from stook.service.fetch import failure_directions, find_baseline
from stook.testing import emulator_config

PAIR: dict[str, Any] = {
    "baseline_pair": True,
    "jobs_per_batch": 12,
    "report_batches": 3,
    "decoy_batches": 2,
}


@pytest.fixture
async def emu() -> AsyncIterator[Emulator]:
    async with Emulator(emulator_config(**PAIR)) as emulator:
        yield emulator


def client(emu: Emulator) -> ApiClient:
    return ApiClient(emu.api_url, emu.token, page_size=10)


def baseline_id(emu: Emulator) -> uuid.UUID:
    return emu.dataset.batches_of(BatchKind.BASELINE)[0].id


async def test_previous_finds_the_latest_finished_batch_of_the_suite_and_branch(
    emu: Emulator,
) -> None:
    async with client(emu) as api:
        found = await find_baseline(api, emu.project_id, emu.batch_id, previous=True)
    assert found.baseline is not None
    assert found.baseline.batch_id == baseline_id(emu)
    assert found.candidate.batch_id == emu.batch_id
    assert found.build == "planner 1.3.0-rc"
    assert "on this batch's branch" in found.chosen_as


async def test_branch_by_name_or_id(emu: Emulator) -> None:
    ds = emu.dataset
    async with client(emu) as api:
        by_name = await find_baseline(api, emu.project_id, emu.batch_id, branch="main")
        by_id = await find_baseline(api, emu.project_id, emu.batch_id, branch=str(ds.branch_id))
        feature = await find_baseline(
            api, emu.project_id, emu.batch_id, branch="feature/planner-tuning"
        )
        unknown = await find_baseline(api, emu.project_id, emu.batch_id, branch="nope")
    assert by_name.baseline is not None
    assert by_id.baseline is not None
    assert by_name.baseline.batch_id == by_id.baseline.batch_id == baseline_id(emu)
    # The feature branch's latest decoy: same suite, finished, earlier.
    decoys = [b for b in ds.batches_of(BatchKind.DECOY) if b.branch_id == ds.feature_branch_id]
    assert feature.baseline is not None
    assert feature.baseline.batch_id == max(decoys, key=lambda b: b.created).id
    assert unknown.baseline is None
    assert unknown.reason == "project has no branch named 'nope'"


async def test_a_named_batch_and_the_ways_it_can_be_wrong(emu: Emulator) -> None:
    report_batch = emu.dataset.batches_of(BatchKind.REPORT)[0].id
    missing = uuid.UUID(int=12345)
    async with client(emu) as api:
        named = await find_baseline(api, emu.project_id, emu.batch_id, batch=report_batch)
        itself = await find_baseline(api, emu.project_id, emu.batch_id, batch=emu.batch_id)
        absent = await find_baseline(api, emu.project_id, emu.batch_id, batch=missing)
        with pytest.raises(ValueError, match="one of batch, branch or previous"):
            await find_baseline(api, emu.project_id, emu.batch_id)
    assert named.baseline is not None
    assert named.baseline.batch_id == report_batch
    assert named.chosen_as == "as named in [batch.baseline]"
    assert itself.baseline is None
    assert itself.reason == "[batch.baseline] batch is this batch"
    assert absent.baseline is None
    assert "does not exist" in absent.reason


async def test_no_earlier_batch_is_no_baseline_not_an_error() -> None:
    config = emulator_config(jobs_per_batch=4, report_batches=0, decoy_batches=0)
    async with Emulator(config) as emu, client(emu) as api:
        found = await find_baseline(api, emu.project_id, emu.batch_id, previous=True)
    assert found.baseline is None
    assert found.reason.startswith("no finished batch of test suite")


async def test_directions_come_from_the_failure_definitions(emu: Emulator) -> None:
    jobs = emu.dataset.jobs(emu.batch_id)
    probes = {
        "Localization error": jobs[0].id,  # fails above 0.3: lower is better
        "Max speed": jobs[1].id,  # no failure definition: no direction
        "Lane departures": jobs[0].id,
    }
    async with client(emu) as api:
        directions = await failure_directions(api, emu.project_id, emu.batch_id, probes)
    assert directions == {
        "Localization error": "lower",
        "Max speed": None,
        "Lane departures": "lower",
    }


async def test_a_probe_that_fails_leaves_the_metric_two_sided(emu: Emulator) -> None:
    async with client(emu) as api:
        directions = await failure_directions(
            api, emu.project_id, emu.batch_id, {"Localization error": uuid.UUID(int=99)}
        )
    assert directions == {"Localization error": None}


@pytest.mark.parametrize(
    ("above", "below", "expected"),
    [(True, False, "lower"), (False, True, "higher"), (True, True, None), (False, False, None)],
)
def test_a_direction_from_each_kind_of_failure_definition(
    above: bool, below: bool, expected: str | None
) -> None:
    from stook.service.fetch._baseline_find import direction_of

    assert direction_of(above, below) == expected
