"""The candidate/baseline pair: same suite and branch, the seeded regressions and shift
only, found by the status search clause and the branches listing."""

from __future__ import annotations

from collections.abc import AsyncIterator

import aiohttp
import pytest

from stook.emulator import BatchKind, Emulator, EmulatorConfig
from stook.emulator._dataset import Dataset
from tests.emulator.support import SMALL, Raw

REGRESSED = (2, 5)
PAIR = SMALL.replace(
    baseline_pair=True,
    jobs_per_batch=30,
    experiences=15,
    baseline_regressed_experiences=REGRESSED,
    baseline_shift_metric="Max speed",
    baseline_shift=0.1,
)


@pytest.fixture
async def raw() -> AsyncIterator[Raw]:
    async with Emulator(PAIR) as emu, aiohttp.ClientSession() as session:
        yield Raw(emu, session)


def test_the_baseline_is_a_finished_batch_of_the_same_suite_and_branch_just_before() -> None:
    ds = Dataset(PAIR)
    main = ds.batch(ds.main_batch_id)
    (baseline,) = ds.batches_of(BatchKind.BASELINE)
    assert main is not None
    assert (baseline.test_suite_id, baseline.branch_id) == (main.test_suite_id, main.branch_id)
    assert baseline.status == "SUCCEEDED"
    assert main.status != "SUCCEEDED"
    assert max(b.created for b in ds.batches if b is not main) == baseline.created < main.created
    assert baseline not in ds.report_batches()  # the report's window is untouched
    assert not Dataset(SMALL).batches_of(BatchKind.BASELINE)


def test_only_the_chosen_experiences_flip_and_only_the_chosen_metric_moves() -> None:
    ds = Dataset(PAIR)
    (baseline,) = ds.batches_of(BatchKind.BASELINE)
    before, after = ds.jobs(baseline.id), ds.jobs(ds.main_batch_id)
    flipped = set()
    for old, new in zip(before, after, strict=True):
        assert old.experience == new.experience
        if old.conflated_status != new.conflated_status:
            assert (old.conflated_status, new.conflated_status) == ("PASSED", "WARNING")
            flipped.add(new.experience.index)
    assert flipped == set(REGRESSED)
    for old, new in zip(before, after, strict=True):
        was = ds.truth(baseline.id, old.id).scalars
        now = ds.truth(ds.main_batch_id, new.id).scalars
        # The level is the experience's; what differs is a run's noise (and the shift).
        assert now["Localization error"] == pytest.approx(was["Localization error"], abs=0.08)
        assert now["Max speed"] / 1.1 == pytest.approx(was["Max speed"], abs=4.0)
        if new.experience.index not in REGRESSED:
            assert now["Lane departures"] == was["Lane departures"]
            assert now["Collisions"] == was["Collisions"]
    speeds = [ds.truth(ds.main_batch_id, j.id).scalars["Max speed"] for j in after]
    unshifted = [ds.truth(baseline.id, j.id).scalars["Max speed"] for j in before]
    assert sum(speeds) / sum(unshifted) == pytest.approx(1.1, abs=0.01)


def test_pair_jobs_write_failure_definitions_that_agree_with_their_statuses() -> None:
    ds = Dataset(PAIR)
    for job in ds.jobs(ds.main_batch_id):
        statuses = ds.truth(ds.main_batch_id, job.id).statuses
        expected = {"PASSED": "PASSED", "WARNING": "FAIL_WARN", "BLOCKER": "FAIL_BLOCK"}
        worst = (
            "FAIL_BLOCK"
            if "FAIL_BLOCK" in statuses.values()
            else ("FAIL_WARN" if "FAIL_WARN" in statuses.values() else "PASSED")
        )
        assert worst == expected[job.conflated_status]


async def test_the_status_clause_and_the_branches_listing(raw: Raw) -> None:
    ds = raw.emu.dataset
    finished, _ = await raw.all_pages("/batches", "batches", search='status = "SUCCEEDED"')
    assert str(ds.main_batch_id) not in {b["batchID"] for b in finished}
    assert len(finished) == len(ds.batches) - 1
    branches, _ = await raw.all_pages("/branches", "branches")
    assert {(b["name"], b["branchID"]) for b in branches} == {
        ("main", str(ds.branch_id)),
        ("feature/planner-tuning", str(ds.feature_branch_id)),
    }
    named, _ = await raw.all_pages("/branches", "branches", name="main")
    assert [b["branchID"] for b in named] == [str(ds.branch_id)]
    none, _ = await raw.all_pages("/branches", "branches", name="release")
    assert none == []
    status, _ = await raw.get("/branches", params={"pageSize": 1000})
    assert status == 400
    async with raw.session.get(
        f"{raw.emu.api_url}/projects/00000000-0000-0000-0000-000000000000/branches",
        headers=raw.auth,
    ) as answer:
        assert answer.status == 404


def test_regressed_experiences_must_be_indices() -> None:
    with pytest.raises(ValueError, match="baseline_regressed_experiences"):
        EmulatorConfig(baseline_regressed_experiences=(-1,))
    config = EmulatorConfig.from_dict({"baseline_regressed_experiences": [1, 2]})
    assert config.baseline_regressed_experiences == (1, 2)
