"""The report's batch metrics: stable series, the seeded regression, gaps, batches
without metrics, empty and single-batch windows, and the ground-truth helpers."""

from __future__ import annotations

import asyncio
import json
import statistics
from collections import Counter

import aiohttp
import pytest
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics

from stook.emulator import BatchKind, Dataset, Emulator, EmulatorConfig, EmulatorProcess
from tests.emulator.support import SMALL, Raw

LOC = "Mean localization error"
DIST = "Mean distance driven"
BASE = {"Failed tests", "Errored tests", "Pass rate", DIST, LOC}


def _series(ds: Dataset, name: str) -> list[float]:
    return [s[name][0] for _, s in ds.report_batch_scalars() if name in s]


def test_report_batches_carry_two_stable_series_with_units() -> None:
    ds = Dataset(EmulatorConfig(report_batches=12, report_jobs_per_batch=20, seed=4))
    scalars = ds.report_batch_scalars()
    assert [b for b, _ in scalars] == ds.report_batches()
    assert len(scalars) == 12
    for batch, by_name in scalars:
        assert batch.kind is BatchKind.REPORT
        assert set(by_name) == BASE
        assert by_name[LOC][1] == "m"
        assert by_name[DIST][1] == "m"
        assert by_name["Pass rate"][1] == "%"
        assert by_name["Failed tests"][1] == ""
        assert by_name[DIST][2] == "RAW"
        # What the API lists agrees with the ground truth.
        output = ds.batch_output(batch.id)
        assert output is not None
        listed = {
            m.name: (m.value, m.unit or "", m.status)
            for m in output.metrics
            if m.api_type == "SCALAR"
        }
        assert listed == by_name
    # Stable: every earlier value within 1% of the median; the distance also in the last.
    for name, values in ((LOC, _series(ds, LOC)[:-1]), (DIST, _series(ds, DIST))):
        median = statistics.median(values)
        assert all(abs(v - median) <= 0.021 * median for v in values), name
        assert len(set(values)) == len(values), f"{name}: no noise at all"
    assert 0.17 < statistics.median(_series(ds, LOC)) < 0.23


def test_the_latest_batch_regresses_only_when_asked() -> None:
    seeded = Dataset(EmulatorConfig(report_batches=10, report_jobs_per_batch=12, seed=9))
    calm = Dataset(
        EmulatorConfig(report_batches=10, report_jobs_per_batch=12, seed=9, report_regression=False)
    )
    loc, calm_loc = _series(seeded, LOC), _series(calm, LOC)
    assert loc[:-1] == calm_loc[:-1]
    assert loc[-1] == pytest.approx(2 * calm_loc[-1], rel=1e-12)
    assert loc[-1] > 1.9 * statistics.median(loc[:-1])
    assert _series(seeded, DIST) == _series(calm, DIST)
    # The regressed value fails its limit; the usual ones pass.
    statuses = [s[LOC][2] for _, s in seeded.report_batch_scalars()]
    assert statuses == ["PASSED"] * 9 + ["FAIL_WARN"]
    assert {s[LOC][2] for _, s in calm.report_batch_scalars()} == {"PASSED"}
    # Batch metrics with the regression still pass ReSim's validator.
    last = seeded.report_batches()[-1]
    validate_job_metrics(
        resim_pb.JobMetrics.FromString(seeded.batch_metrics(last.id).SerializeToString())
    )


def test_other_seeds_give_other_levels() -> None:
    a, b = (Dataset(EmulatorConfig(report_batches=4, seed=s)) for s in (1, 2))
    assert _series(a, DIST) != _series(b, DIST)
    assert _series(a, DIST) == _series(Dataset(EmulatorConfig(report_batches=4, seed=1)), DIST)


@pytest.mark.parametrize("count", [0, 1, 2])
def test_small_windows_hold_exactly_their_report_batches(count: int) -> None:
    ds = Dataset(EmulatorConfig(report_batches=count, seed=3))
    found = ds.report_batches()
    assert [b.kind for b in found] == [BatchKind.REPORT] * count
    assert all(ds.report.start < b.created < ds.report.end for b in found)
    main = ds.batch(ds.main_batch_id)
    assert main is not None
    assert not ds.report.start < main.created < ds.report.end
    assert [b for b, _ in ds.report_batch_scalars()] == found


def test_batches_without_metrics_and_gaps() -> None:
    ds = Dataset(
        EmulatorConfig(
            report_batches=8,
            report_jobs_per_batch=10,
            report_batches_without_metrics=(0, 5),
            report_partial_metric_batches=(2, 5, 7),
        )
    )
    scalars = ds.report_batch_scalars()
    statuses = ds.report_batch_metric_statuses()
    for k, ((batch, by_name), (same, by_status)) in enumerate(zip(scalars, statuses, strict=True)):
        assert batch is same
        assert batch.index == k
        output = ds.batch_output(batch.id)
        assert output is not None
        if k in (0, 5):
            assert by_name == {}
            assert by_status == {}
            assert output.metrics == ()
            assert output.data == ()
        elif k in (2, 7):
            assert set(by_name) == BASE - {LOC}
            assert LOC not in {m.name for m in output.metrics}
        else:
            assert set(by_name) == BASE
        assert set(by_status) == {m.name for m in output.metrics}
        assert set(by_status) >= set(by_name)
    # The regression falls in the latest batch, which here has no localization error.
    assert LOC not in scalars[-1][1]


def test_job_statuses_per_experience_follow_the_jobs() -> None:
    ds = Dataset(EmulatorConfig(report_batches=3, report_jobs_per_batch=50, experiences=20))
    for batch, per_experience in ds.report_job_statuses():
        jobs = ds.jobs(batch.id)
        assert sum(len(v) for v in per_experience.values()) == len(jobs) == 50
        assert len(per_experience) == 20
        assert Counter(s for v in per_experience.values() for s in v) == Counter(
            j.conflated_status for j in jobs
        )


def test_report_knobs_are_checked_and_cross_processes() -> None:
    config = EmulatorConfig(
        report_regression=False,
        report_batches_without_metrics=(1, 3),
        report_partial_metric_batches=(2,),
    )
    round_trip = EmulatorConfig.from_dict(json.loads(json.dumps(config.to_dict())))
    assert round_trip == config
    assert round_trip.report_batches_without_metrics == (1, 3)
    for name in ("report_batches_without_metrics", "report_partial_metric_batches"):
        for bad in ((-1,), (True,)):
            with pytest.raises(ValueError, match=name):
                EmulatorConfig.from_dict({name: bad})


async def test_the_api_serves_the_knobs() -> None:
    config = SMALL.replace(
        report_batches=4, report_batches_without_metrics=(1,), report_partial_metric_batches=(2,)
    )
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        batches = emu.dataset.report_batches()
        listings = [
            (await raw.all_pages(f"/batches/{batch.id}/metrics", "batchMetrics"))[0]
            for batch in batches
        ]
        names = [{m["name"] for m in listed} for listed in listings]
        assert names[1] == set()
        assert LOC not in names[2]
        assert DIST in names[2]
        assert {LOC, DIST} <= names[0] & names[3]
        last = {m["name"]: m for m in listings[3]}
        assert last[LOC]["value"] == emu.dataset.report_batch_scalars()[-1][1][LOC][0]
        assert last[LOC]["unit"] == "m"
        assert last[LOC]["status"] == "FAIL_WARN"


def test_the_knobs_reach_an_emulator_in_another_process() -> None:
    config = SMALL.replace(report_batches=3, report_batches_without_metrics=(0,))

    async def first_batch_metrics(emu: EmulatorProcess) -> list[object]:
        batch = Dataset(config).report_batches()[0]
        url = f"{emu.api_url}/projects/{emu.project_id}/batches/{batch.id}/metrics"
        headers = {"Authorization": f"Bearer {emu.token}"}
        async with aiohttp.ClientSession() as s, s.get(url, headers=headers) as answer:
            assert answer.status == 200
            body = await answer.json()
        metrics: list[object] = body["batchMetrics"]
        return metrics

    with EmulatorProcess(config) as emu:
        assert asyncio.run(first_batch_metrics(emu)) == []
