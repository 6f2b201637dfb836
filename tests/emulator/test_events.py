"""The emulated jobs' events, event metrics, event tags, parameters and experience tags,
read raw and through ReSim's generated client (the oracle for the API's shapes)."""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator
from datetime import UTC, datetime, timedelta
from typing import Any

import aiohttp
import pytest
from resim.sdk.client import AuthenticatedClient
from resim.sdk.client.api.batches import (
    get_event_for_job,
    get_job,
    list_event_metrics_for_job,
    list_event_tags_for_job,
    list_events_for_job,
    list_jobs,
)
from resim.sdk.client.models import (
    Event,
    Job,
    ListJobEventsOutput,
    ListJobEventTagsOutput,
    ListJobMetricsOutput,
    ListJobsOutput,
)

from stook.emulator import BatchKind, Dataset, Emulator, EmulatorConfig, JobSpec
from stook.emulator._world import SWEEP_PARAMETERS
from tests.emulator.support import SMALL, Raw


@pytest.fixture
async def raw() -> AsyncIterator[Raw]:
    async with Emulator(SMALL) as emu, aiohttp.ClientSession() as session:
        yield Raw(emu, session)


def _with_events(emu: Emulator) -> list[JobSpec]:
    ds = emu.dataset
    return [j for j in ds.jobs(emu.batch_id) if ds.truth(emu.batch_id, j.id).events]


def _ns(text: str) -> int:
    moment = datetime.fromisoformat(text)
    return int(moment.timestamp()) * 1_000_000_000 + moment.microsecond * 1000


def _without_urls(items: list[Any]) -> list[Any]:
    """The items without their presigned URLs, whose signing time moves with the clock."""
    return [
        {k: v for k, v in i.items() if k != "metricURL"} if isinstance(i, dict) else i
        for i in items
    ]


# ---- events ----


async def test_events_list_what_each_job_wrote(raw: Raw) -> None:
    emu, ds = raw.emu, raw.emu.dataset
    seen_names: set[str] = set()
    for job in ds.jobs(emu.batch_id):
        truth = ds.truth(emu.batch_id, job.id)
        base = f"/batches/{emu.batch_id}/jobs/{job.id}"
        events, _ = await raw.all_pages(f"{base}/events", "events", page_size=1)
        metrics, _ = await raw.all_pages(f"{base}/metrics", "metrics")
        names_by_id = {m["metricID"]: m["name"] for m in metrics}
        assert [e["name"] for e in events] == [e.name for e in truth.events]
        for listed, written in zip(events, truth.events, strict=True):
            assert listed["status"] == written.status
            assert listed["tags"] == list(written.tags)
            assert listed["description"] == written.description
            assert listed["timestampType"] == "ABSOLUTE"
            assert _ns(listed["timestamp"]) == written.timestamp_ns
            assert [names_by_id[m] for m in listed["metricsIDs"]] == list(written.metrics)
            seen_names.add(written.name)
        if not job.has_metrics:
            assert events == []
    assert seen_names == {"Hard brake", "Lane departure", "Near miss"}


async def test_event_metrics_are_the_job_metrics_flagged_as_events(raw: Raw) -> None:
    emu, ds = raw.emu, raw.emu.dataset
    for job in _with_events(emu):
        truth = ds.truth(emu.batch_id, job.id)
        base = f"/batches/{emu.batch_id}/jobs/{job.id}"
        listed, _ = await raw.all_pages(f"{base}/eventMetrics", "metrics", page_size=1)
        every, _ = await raw.all_pages(f"{base}/metrics", "metrics")
        assert _without_urls(listed) == _without_urls([m for m in every if m["eventMetric"]])
        assert {m["name"]: m["value"] for m in listed} == truth.event_scalars
        events, _ = await raw.all_pages(f"{base}/events", "events")
        assert {i for e in events for i in e["metricsIDs"]} == {m["metricID"] for m in listed}


async def test_event_tags_are_the_distinct_tags_of_the_events(raw: Raw) -> None:
    emu, ds = raw.emu, raw.emu.dataset
    for job in ds.jobs(emu.batch_id):
        truth = ds.truth(emu.batch_id, job.id)
        path = f"/batches/{emu.batch_id}/jobs/{job.id}/eventTags"
        tags, requests = await raw.all_pages(path, "eventTags", page_size=2)
        expected = sorted({t for e in truth.events for t in e.tags})
        assert tags == expected
        assert requests == max(1, -(-len(expected) // 2))


async def test_one_event_by_id_and_unknown_ones_404(raw: Raw) -> None:
    emu = raw.emu
    job = _with_events(emu)[0]
    base = f"/batches/{emu.batch_id}/jobs/{job.id}"
    _, body = await raw.get(f"{base}/events")
    first = body["events"][0]
    status, one = await raw.get(f"{base}/events/{first['eventID']}")
    assert (status, one) == (200, first)
    status, answer = await raw.get(f"{base}/events/{uuid.uuid4()}")
    assert status == 404
    assert "event" in answer["message"]
    status, _ = await raw.get(f"{base}/events/not-a-uuid")
    assert status == 400


@pytest.mark.parametrize("endpoint", ["events", "eventMetrics", "eventTags"])
async def test_event_lists_refuse_bad_paging_and_unknown_jobs(raw: Raw, endpoint: str) -> None:
    emu = raw.emu
    job = _with_events(emu)[0]
    path = f"/batches/{emu.batch_id}/jobs/{job.id}/{endpoint}"
    assert (await raw.get(path, params={"pageSize": 100}))[0] == 200
    status, body = await raw.get(path, params={"pageSize": 101})
    assert status == 400
    assert "pageSize" in body["message"]
    assert (await raw.get(path, params={"pageToken": "garbage"}))[0] == 400
    other = f"/batches/{emu.batch_id}/jobs/{_with_events(emu)[1].id}/{endpoint}"
    _, first = await raw.get(other, params={"pageSize": 1})
    if first["nextPageToken"]:  # a token of another job's list is refused
        params = {"pageToken": first["nextPageToken"]}
        assert (await raw.get(path, params=params))[0] == 400
    status, body = await raw.get(f"/batches/{emu.batch_id}/jobs/{uuid.uuid4()}/{endpoint}")
    assert status == 404
    assert "job" in body["message"]
    status, _ = await raw.get(f"/batches/{uuid.uuid4()}/jobs/{job.id}/{endpoint}")
    assert status == 404
    assert (await raw.get(f"/batches/{emu.batch_id}/jobs/nope/{endpoint}"))[0] == 400


@pytest.mark.parametrize(
    ("endpoint", "name"),
    [("events", "eventTags"), ("eventMetrics", "text"), ("eventTags", "name")],
)
async def test_filters_the_emulator_lacks_are_refused(raw: Raw, endpoint: str, name: str) -> None:
    job = _with_events(raw.emu)[0]
    path = f"/batches/{raw.emu.batch_id}/jobs/{job.id}/{endpoint}"
    status, body = await raw.get(path, params={name: "braking"})
    assert status == 400
    assert name in body["message"]


async def test_a_broken_job_answers_500_for_its_events() -> None:
    async with Emulator(SMALL.replace(broken_jobs=(0,))) as emu, aiohttp.ClientSession() as s:
        raw = Raw(emu, s)
        job = emu.dataset.jobs(emu.batch_id)[0]
        for endpoint in ("events", "eventMetrics", "eventTags"):
            status, _ = await raw.get(f"/batches/{emu.batch_id}/jobs/{job.id}/{endpoint}")
            assert status == 500


# ---- parameters ----


async def test_jobs_carry_their_sweep_parameters(raw: Raw) -> None:
    emu, ds = raw.emu, raw.emu.dataset
    jobs, _ = await raw.all_pages(f"/batches/{emu.batch_id}/jobs", "jobs")
    for listed, spec in zip(jobs, ds.jobs(emu.batch_id), strict=True):
        assert listed["parameters"] == ds.truth(emu.batch_id, spec.id).parameters
        _, one = await raw.get(f"/batches/{emu.batch_id}/jobs/{spec.id}")
        assert one["parameters"] == listed["parameters"]
    # Twelve jobs cover the sweep's 4 x 2 combinations; the jobs have all parameters.
    combos = {tuple(sorted(j["parameters"].items())) for j in jobs}
    assert len(combos) == 8
    assert all(set(j["parameters"]) == set(SWEEP_PARAMETERS) for j in jobs)
    decoy = ds.batches_of(BatchKind.DECOY)[0]
    decoy_jobs, _ = await raw.all_pages(f"/batches/{decoy.id}/jobs", "jobs")
    assert all(j["parameters"] == {} for j in decoy_jobs)


def test_braking_distance_rises_with_max_speed() -> None:
    ds = Dataset(EmulatorConfig(jobs_per_batch=80))
    by_speed: dict[float, list[float]] = {}
    for job in ds.jobs(ds.main_batch_id):
        truth = ds.truth(ds.main_batch_id, job.id)
        if "Braking distance" in truth.scalars:
            speed = float(truth.parameters["max_speed"])
            by_speed.setdefault(speed, []).append(truth.scalars["Braking distance"])
    speeds = sorted(by_speed)
    means = [sum(by_speed[s]) / len(by_speed[s]) for s in speeds]
    assert speeds == [10.0, 15.0, 20.0, 25.0]
    assert means == sorted(means)
    assert means[-1] > 5 * means[0]


# ---- determinism ----


async def _event_answers(config: EmulatorConfig) -> list[Any]:
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        out: list[Any] = []
        for job in emu.dataset.jobs(emu.batch_id)[:6]:
            base = f"/batches/{emu.batch_id}/jobs/{job.id}"
            for endpoint, key in (
                ("events", "events"),
                ("eventMetrics", "metrics"),
                ("eventTags", "eventTags"),
            ):
                items, _ = await raw.all_pages(f"{base}/{endpoint}", key)
                out.append(_without_urls(items))
            out.append((await raw.get(base))[1]["parameters"])
        return out


async def test_same_seed_same_events_and_parameters() -> None:
    first = await _event_answers(SMALL)
    assert first == await _event_answers(SMALL)
    assert first != await _event_answers(SMALL.replace(seed=3))
    assert any(first)


# ---- ReSim's generated client parses every answer ----


def _known_keys(obj: Any) -> None:
    assert obj.additional_properties == {}, type(obj).__name__


async def test_resims_generated_client_reads_events_tags_and_parameters() -> None:
    async with Emulator(SMALL) as emu:
        ds = emu.dataset
        project, batch = str(emu.project_id), str(emu.batch_id)
        client = AuthenticatedClient(base_url=emu.api_url, token=emu.token)
        async with client:
            jobs = await list_jobs.asyncio(project, batch, client=client, page_size=100)
            assert isinstance(jobs, ListJobsOutput)
            for listed in jobs.jobs:
                _known_keys(listed)
                spec_id = uuid.UUID(listed.job_id)
                assert listed.parameters.to_dict() == ds.truth(emu.batch_id, spec_id).parameters
            checked = 0
            for job in _with_events(emu):
                job_id = str(job.id)
                truth = ds.truth(emu.batch_id, job.id)
                one = await get_job.asyncio(project, batch, job_id, client=client)
                assert isinstance(one, Job)
                assert one.parameters.to_dict() == truth.parameters
                events = await list_events_for_job.asyncio(project, batch, job_id, client=client)
                assert isinstance(events, ListJobEventsOutput)
                assert [e.name for e in events.events] == [e.name for e in truth.events]
                for event, written in zip(events.events, truth.events, strict=True):
                    _known_keys(event)
                    assert event.status.value == written.status
                    assert event.tags == list(written.tags)
                    assert event.timestamp.tzinfo is not None
                    seconds, nanos = divmod(written.timestamp_ns, 1_000_000_000)
                    assert event.timestamp == datetime.fromtimestamp(seconds, UTC) + timedelta(
                        microseconds=nanos // 1000
                    )
                    again = await get_event_for_job.asyncio(
                        project, batch, job_id, event.event_id, client=client
                    )
                    assert isinstance(again, Event)
                    assert again.to_dict() == event.to_dict()
                metrics = await list_event_metrics_for_job.asyncio(
                    project, batch, job_id, client=client
                )
                assert isinstance(metrics, ListJobMetricsOutput)
                assert all(m.event_metric for m in metrics.metrics)
                assert {m.name: m.value for m in metrics.metrics} == truth.event_scalars
                tags = await list_event_tags_for_job.asyncio(project, batch, job_id, client=client)
                assert isinstance(tags, ListJobEventTagsOutput)
                assert tags.event_tags == sorted({t for e in truth.events for t in e.tags})
                checked += 1
            assert checked >= 5


# ---- experience tags and requests per path ----


async def test_every_experience_serves_its_tags_and_requests_are_counted_per_path(
    raw: Raw,
) -> None:
    emu, ds = raw.emu, raw.emu.dataset
    for experience in ds.experiences:
        tags, _ = await raw.all_pages(
            f"/experiences/{experience.id}/experienceTags", "experienceTags"
        )
        assert [t["name"] for t in tags] == [t.name for t in experience.tags]
        assert tags
    first = ds.experiences[0]
    await raw.get(f"/experiences/{first.id}/experienceTags")
    counted = emu.stats.path_requests("/experienceTags")
    prefix = f"/v1/projects/{emu.project_id}/experiences"
    assert counted == {
        f"{prefix}/{e.id}/experienceTags": 2 if e is first else 1 for e in ds.experiences
    }
    assert sum(counted.values()) == emu.stats.endpoints["api:list_experience_tags"]
    # The counts cross process boundaries with the rest of the statistics.
    again = type(emu.stats).from_dict(emu.stats.to_dict())
    assert again.api_paths == emu.stats.api_paths


def test_the_bucket_mismatch_setting_takes_indices_only() -> None:
    config = EmulatorConfig.from_dict({"histogram_bucket_mismatch_jobs": [1, 2]})
    assert config.histogram_bucket_mismatch_jobs == (1, 2)
    with pytest.raises(ValueError, match="histogram_bucket_mismatch_jobs"):
        EmulatorConfig(histogram_bucket_mismatch_jobs=(-1,))
