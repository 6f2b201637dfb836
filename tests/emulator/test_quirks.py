"""The emulator's spec_quirks and status settings: what its answers hold, read raw."""

from __future__ import annotations

import re
import uuid
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import pytest

from stook.emulator import BatchKind, Emulator
from stook.emulator._quirks import LEAP_SECOND
from stook.proto import metrics_pb2 as pb
from tests.emulator.support import SMALL, Raw

NANOS = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{9}Z")
# What a batch's first job carries as its creation time instead.
LEAP = {"creationTimestamp": LEAP_SECOND}


@pytest.fixture
async def quirky() -> AsyncIterator[Raw]:
    config = SMALL.replace(spec_quirks=True, future_status_jobs=(1,), unreported_status_jobs=(2,))
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        yield Raw(emu, session)


def _no_empty_values(obj: dict[str, Any], *, allowed: frozenset[str] = frozenset()) -> None:
    for key, value in obj.items():
        if key not in allowed:
            assert value not in (None, "", [], {}, False), (key, obj)
        if isinstance(value, str) and (key.endswith("Timestamp") or key == "updatedAt"):
            assert NANOS.fullmatch(value) or LEAP.get(key) == value, (key, value)


async def test_jobs_and_batches_leave_out_empty_fields_and_carry_future_enum_values(
    quirky: Raw,
) -> None:
    emu = quirky.emu
    jobs, _ = await quirky.all_pages(f"/batches/{emu.batch_id}/jobs", "jobs")
    for job in jobs:
        _no_empty_values(job)
        for entry in job["statusHistory"]:
            _no_empty_values(entry)
        assert (job["jobStatus"], job["jobMetricsStatus"]) == ("RETRIED", "FAIL_SOFT")
    by_index = {j.id: j.index for j in emu.dataset.jobs(emu.batch_id)}
    statuses = {by_index[uuid.UUID(j["jobID"])]: j.get("conflatedStatus") for j in jobs}
    assert statuses[1] == "FLAKY"
    assert statuses[2] is None
    assert all(s is not None for i, s in statuses.items() if i != 2)
    _, batch = await quirky.get(f"/batches/{emu.batch_id}")
    _no_empty_values(batch)
    assert batch["status"] == batch["conflatedStatus"] == "ARCHIVED"
    assert "description" not in batch


async def test_scalar_values_are_listed_as_null_and_served_in_the_message(quirky: Raw) -> None:
    emu = quirky.emu
    nulls = numbers = 0
    for job in emu.dataset.jobs(emu.batch_id):
        base = f"/batches/{emu.batch_id}/jobs/{job.id}"
        metrics, _ = await quirky.all_pages(f"{base}/metrics", "metrics")
        for metric in metrics:
            _no_empty_values(metric, allowed=frozenset({"value"}))
            if job.index == 1:
                assert metric["status"] == "FAIL_SOFT"
            elif job.index == 2:
                assert "status" not in metric
            if metric["type"] != "SCALAR":
                assert "value" not in metric
                continue
            if metric["value"] is not None:
                numbers += 1
                continue
            nulls += 1
            status, body = await quirky.fetch(metric["metricURL"])
            assert status == 200
            message = pb.Metric.FromString(body)
            assert message.metric_values.scalar_metric_values.HasField("value")
    assert nulls > 5
    assert numbers > 5


async def test_every_job_lists_unnamed_data_and_data_of_an_unknown_type(quirky: Raw) -> None:
    emu = quirky.emu
    job = emu.dataset.jobs(emu.batch_id)[0]
    path = f"/batches/{emu.batch_id}/jobs/{job.id}"
    data, _ = await quirky.all_pages(f"{path}/metricsData", "metricsData")
    unnamed = [d for d in data if "name" not in d]
    assert len(unnamed) == 1
    assert "metricsDataType" not in unnamed[0]
    status, body = await quirky.fetch(unnamed[0]["metricsDataURL"])
    assert status == 200
    message = pb.MetricsData.FromString(body)  # a valid MetricsData, just without a name
    assert (message.name, list(message.series.doubles.series)) == ("", [1.0, 2.0, 3.0])
    (cloud,) = [d for d in data if d.get("metricsDataType") == "POINT_CLOUD"]
    assert cloud["name"] == "Point cloud"
    for item in data:
        _no_empty_values(item)


async def test_a_clean_emulator_answers_as_before() -> None:
    async with Emulator(SMALL) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        job = emu.dataset.jobs(emu.batch_id)[0]
        path = f"/batches/{emu.batch_id}/jobs/{job.id}"
        metrics, _ = await raw.all_pages(f"{path}/metrics", "metrics")
        assert all(m["value"] is not None for m in metrics if m["type"] == "SCALAR")
        assert all("fileLocation" in m and "status" in m for m in metrics)
        data, _ = await raw.all_pages(f"{path}/metricsData", "metricsData")
        assert all(d["name"] for d in data)


async def test_events_keep_their_required_fields_and_jobs_without_parameters_omit_them(
    quirky: Raw,
) -> None:
    emu, ds = quirky.emu, quirky.emu.dataset
    lane_departures = 0
    for job in ds.jobs(emu.batch_id):
        events, _ = await quirky.all_pages(
            f"/batches/{emu.batch_id}/jobs/{job.id}/events", "events"
        )
        for event in events:
            # The spec requires every field of an event: none is left out, even if empty.
            assert set(event) == {
                "eventID",
                "name",
                "description",
                "creationTimestamp",
                "timestampType",
                "timestamp",
                "tags",
                "status",
                "metricsIDs",
            }
            assert NANOS.fullmatch(event["timestamp"])
            assert NANOS.fullmatch(event["creationTimestamp"])
            lane_departures += event["metricsIDs"] == []
    assert lane_departures > 0
    jobs, _ = await quirky.all_pages(f"/batches/{emu.batch_id}/jobs", "jobs")
    assert all(j["parameters"] for j in jobs)
    decoy = ds.batches_of(BatchKind.DECOY)[0]
    decoy_jobs, _ = await quirky.all_pages(f"/batches/{decoy.id}/jobs", "jobs")
    assert decoy_jobs
    assert all("parameters" not in j for j in decoy_jobs)
