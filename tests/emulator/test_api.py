"""The emulated API: paging, auth, errors, presigned storage, search, and ReSim's models."""

from __future__ import annotations

import json
import uuid
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import pytest
from resim.sdk.client.models import (
    Batch,
    Build,
    Experience,
    ListBatchesOutput,
    ListBatchMetricsDataOutput,
    ListBatchMetricsOutput,
    ListExperienceTagsOutput,
    ListJobMetricsDataOutput,
    ListJobMetricsOutput,
    ListJobsOutput,
    Report,
)
from resim.sdk.client.types import Unset

from stook.emulator import BatchKind, Emulator, EmulatorConfig
from stook.proto import metrics_pb2 as pb
from tests.emulator.support import SMALL, Raw


@pytest.fixture
async def raw() -> AsyncIterator[Raw]:
    async with Emulator(SMALL) as emu, aiohttp.ClientSession() as session:
        yield Raw(emu, session)


def _report_batch(emu: Emulator) -> uuid.UUID:
    return emu.dataset.batches_of(BatchKind.REPORT)[-1].id


# ---- paging ----


async def test_jobs_are_paged_with_default_and_capped_sizes(raw: Raw) -> None:
    path = f"/batches/{raw.emu.batch_id}/jobs"
    expected = [str(j.id) for j in raw.emu.dataset.jobs(raw.emu.batch_id)]
    assert len(expected) == 12

    jobs, requests = await raw.all_pages(path, "jobs")  # default page size 5
    assert [j["jobID"] for j in jobs] == expected
    assert requests == 3

    jobs, requests = await raw.all_pages(path, "jobs", page_size=3)
    assert [j["jobID"] for j in jobs] == expected
    assert requests == 4

    jobs, requests = await raw.all_pages(path, "jobs", page_size=100)  # served 8 at a time
    assert [j["jobID"] for j in jobs] == expected
    assert requests == 2

    status, body = await raw.get(path)
    assert status == 200
    assert body["total"] == 12
    assert body["nextPageToken"]


async def test_last_page_has_an_empty_next_token(raw: Raw) -> None:
    status, body = await raw.get(f"/batches/{raw.emu.batch_id}/jobs", params={"pageSize": 8})
    status, body = await raw.get(
        f"/batches/{raw.emu.batch_id}/jobs",
        params={"pageSize": 8, "pageToken": body["nextPageToken"]},
    )
    assert status == 200
    assert len(body["jobs"]) == 4
    assert body["nextPageToken"] == ""


@pytest.mark.parametrize(
    "params",
    [
        {"pageSize": "-1"},
        {"pageSize": "many"},
        {"pageSize": "101"},  # the spec's maximum is 100
        {"pageToken": "%%%not-a-token"},
        {"pageToken": "MTI6MDAwMDAwMDA"},  # well-formed base64, but not for this list
    ],
)
async def test_bad_paging_parameters_are_400(raw: Raw, params: dict[str, str]) -> None:
    status, body = await raw.get(f"/batches/{raw.emu.batch_id}/jobs", params=params)
    assert status == 400
    assert body["code"] == 400


async def test_a_page_token_is_bound_to_its_list(raw: Raw) -> None:
    jobs = raw.emu.dataset.jobs(raw.emu.batch_id)
    _, body = await raw.get(f"/batches/{raw.emu.batch_id}/jobs", params={"pageSize": 2})
    status, _ = await raw.get(
        f"/batches/{raw.emu.batch_id}/jobs/{jobs[0].id}/metrics",
        params={"pageToken": body["nextPageToken"]},
    )
    assert status == 400


async def test_metrics_and_data_lists_are_paged(raw: Raw) -> None:
    ds = raw.emu.dataset
    job = next(j for j in ds.jobs(raw.emu.batch_id) if j.has_metrics)
    output = ds.job_output(raw.emu.batch_id, job.id)
    assert output is not None
    base = f"/batches/{raw.emu.batch_id}/jobs/{job.id}"
    metrics, requests = await raw.all_pages(f"{base}/metrics", "metrics", page_size=2)
    assert [m["metricID"] for m in metrics] == [str(m.id) for m in output.metrics]
    assert requests == (len(output.metrics) + 1) // 2
    data, _ = await raw.all_pages(f"{base}/metricsData", "metricsData", page_size=2)
    assert [d["dataID"] for d in data] == [str(d.id) for d in output.data]


# ---- auth and errors ----


@pytest.mark.parametrize(
    "headers",
    [{}, {"Authorization": "Bearer wrong"}, {"Authorization": "stook-emulator-token"}],
)
async def test_api_requests_need_the_bearer_token(raw: Raw, headers: dict[str, str]) -> None:
    status, body = await raw.get(f"/batches/{raw.emu.batch_id}/jobs", headers=headers)
    assert status == 401
    assert body["code"] == 401
    assert raw.emu.stats.unauthorized == 1


@pytest.mark.parametrize(
    "path",
    [
        "/batches/{unknown}",
        "/batches/{unknown}/jobs",
        "/batches/{batch}/jobs/{unknown}/metrics",
        "/batches/{batch}/jobs/{unknown}/metricsData",
        "/batches/{unknown}/metrics",
        "/reports/{unknown}",
        "/builds/{unknown}",
        "/experiences/{unknown}/experienceTags",
        "/experiences/{unknown}",
    ],
)
async def test_unknown_ids_are_404_with_a_json_body(raw: Raw, path: str) -> None:
    path = path.format(unknown=uuid.uuid4(), batch=raw.emu.batch_id)
    status, body = await raw.get(path)
    assert status == 404
    assert body["code"] == 404
    assert "not found" in body["message"]


async def test_unknown_project_is_404(raw: Raw) -> None:
    url = f"{raw.emu.api_url}/projects/{uuid.uuid4()}/batches/{raw.emu.batch_id}"
    async with raw.session.get(url, headers=raw.auth) as answer:
        assert answer.status == 404
        assert (await answer.json())["code"] == 404


@pytest.mark.parametrize(
    "path", ["/batches/not-a-uuid", "/batches/{batch}/jobs/123/metrics", "/reports/xyz"]
)
async def test_malformed_ids_are_400(raw: Raw, path: str) -> None:
    status, body = await raw.get(path.format(batch=raw.emu.batch_id))
    assert status == 400
    assert "UUID" in body["message"]


# ---- presigned storage ----


async def _first_metric(raw: Raw) -> dict[str, Any]:
    job = next(j for j in raw.emu.dataset.jobs(raw.emu.batch_id) if j.has_metrics)
    status, body = await raw.get(f"/batches/{raw.emu.batch_id}/jobs/{job.id}/metrics")
    assert status == 200
    first: dict[str, Any] = body["metrics"][0]
    return first


async def test_storage_serves_each_metric_alone_without_the_token(raw: Raw) -> None:
    metric = await _first_metric(raw)
    assert metric["metricURL"].startswith(raw.emu.storage_url)
    assert "X-Amz-Signature=" in metric["metricURL"]
    status, body = await raw.fetch(metric["metricURL"])
    assert status == 200
    message = pb.Metric.FromString(body)
    assert message.metric_id.id.data == metric["metricID"]
    assert message.name == metric["name"]
    assert raw.emu.stats.leaked_tokens == 0


async def test_storage_refuses_and_records_an_authorization_header(raw: Raw) -> None:
    metric = await _first_metric(raw)
    status, body = await raw.fetch(metric["metricURL"], headers=raw.auth)
    assert status == 400
    assert b"InvalidArgument" in body
    assert raw.emu.stats.leaked_tokens == 1
    assert raw.emu.stats.storage_authorization[0].endswith(metric["metricID"])


async def test_expired_url_is_403_and_a_fresh_listing_works(tmp_path: Path) -> None:
    async with (
        Emulator(SMALL.replace(url_lifetime_s=60)) as emu,
        aiohttp.ClientSession() as session,
    ):
        raw = Raw(emu, session)
        metric = await _first_metric(raw)
        assert (await raw.fetch(metric["metricURL"]))[0] == 200
        emu.advance_clock(61)
        status, body = await raw.fetch(metric["metricURL"])
        assert status == 403
        assert b"expired" in body
        assert emu.stats.expired_urls == 1
        fresh = await _first_metric(raw)
        assert fresh["metricURL"] != metric["metricURL"]
        assert (await raw.fetch(fresh["metricURL"]))[0] == 200


async def test_tampered_url_is_403(raw: Raw) -> None:
    metric = await _first_metric(raw)
    url = metric["metricURL"].replace("X-Amz-Expires=3600", "X-Amz-Expires=999999")
    assert (await raw.fetch(url))[0] == 403
    assert (await raw.fetch(metric["metricURL"].split("?")[0]))[0] == 403
    assert raw.emu.stats.bad_signatures == 2


# ---- search ----


async def test_report_search_finds_exactly_the_report_batches(raw: Raw) -> None:
    ds = raw.emu.dataset
    report = ds.report
    search = " AND ".join(
        [
            f'test_suite_id = "{report.test_suite_id}"',
            f'branch_id = "{report.branch_id}"',
            f'created_at > "{report.start}"',  # Python's str(datetime), as ReSim sends it
            f'created_at < "{report.end.isoformat().replace("+00:00", "Z")}"',
        ]
    )
    batches, _ = await raw.all_pages("/batches", "batches", search=search)
    found = sorted(batches, key=lambda b: b["creationTimestamp"])
    assert [b["batchID"] for b in found] == [str(b.id) for b in ds.report_batches()]
    assert len(found) == 5  # no decoys, not the main batch

    with_revision = f"{search} AND test_suite_revision = 2"
    batches, _ = await raw.all_pages("/batches", "batches", search=with_revision)
    assert {b["testSuiteRevision"] for b in batches} == {2}
    assert 0 < len(batches) < 5


async def test_no_search_lists_every_batch_with_a_total(raw: Raw) -> None:
    batches, _ = await raw.all_pages("/batches", "batches")
    assert len(batches) == len(raw.emu.dataset.batches)
    _, body = await raw.get("/batches")
    assert body["total"] == len(raw.emu.dataset.batches)


@pytest.mark.parametrize(
    "search",
    [
        'name = "x"',
        'test_suite_id = "not-a-uuid"',
        'created_at > "yesterday"',
        'branch_id = "00000000-0000-0000-0000-000000000000" OR 1',
        "test_suite_revision >= 2",
    ],
)
async def test_unsupported_search_is_400(raw: Raw, search: str) -> None:
    status, body = await raw.get("/batches", params={"search": search})
    assert status == 400
    assert body["code"] == 400


# ---- batch metrics ----


async def test_batch_metrics_of_a_report_batch_are_served(raw: Raw) -> None:
    batch_id = _report_batch(raw.emu)
    output = raw.emu.dataset.batch_output(batch_id)
    assert output is not None
    metrics, _ = await raw.all_pages(f"/batches/{batch_id}/metrics", "batchMetrics")
    assert [m["name"] for m in metrics] == [m.name for m in output.metrics]
    by_name = {m["name"]: m for m in metrics}
    assert by_name["Pass rate"]["type"] == "SCALAR"
    assert by_name["Pass rate"]["value"] == output.truth.scalars["Pass rate"]
    assert by_name["Pass rate by experience"]["type"] == "COMPOSITE"
    status, body = await raw.fetch(by_name["Pass rate"]["metricURL"])
    assert status == 200
    assert pb.Metric.FromString(body).metric_values.scalar_metric_values.value == pytest.approx(
        output.truth.scalars["Pass rate"]
    )
    data, _ = await raw.all_pages(f"/batches/{batch_id}/metricsData", "batchMetricsData")
    assert {d["name"] for d in data} == set(output.truth.data_names)
    for item in data:
        status, body = await raw.fetch(item["metricsDataURL"])
        assert status == 200
        assert pb.MetricsData.FromString(body).name == item["name"]


async def test_the_main_batch_has_no_batch_metrics_yet(raw: Raw) -> None:
    status, body = await raw.get(f"/batches/{raw.emu.batch_id}/metrics")
    assert status == 200
    assert body == {"batchMetrics": [], "nextPageToken": ""}


# ---- ReSim's own models parse every answer ----


def _no_unknown_keys(obj: Any) -> None:
    assert obj.additional_properties == {}, type(obj).__name__


async def test_every_answer_parses_with_resims_models(raw: Raw) -> None:
    emu, ds = raw.emu, raw.emu.dataset
    # Jobs: every job of the main batch, all statuses present.
    _, body = await raw.get(f"/batches/{emu.batch_id}/jobs", params={"pageSize": 8})
    jobs = ListJobsOutput.from_dict(body)
    assert jobs.total == 12
    for job in jobs.jobs:
        _no_unknown_keys(job)
        assert not isinstance(job.conflated_status, Unset)
        assert not isinstance(job.job_status, Unset)
        assert not isinstance(job.job_metrics_status, Unset)
        assert not isinstance(job.creation_timestamp, Unset)
        assert job.experience_name.split()[-1].isdigit()

    for job_spec in ds.jobs(emu.batch_id):
        _, body = await raw.get(f"/batches/{emu.batch_id}/jobs/{job_spec.id}/metrics")
        metrics = ListJobMetricsOutput.from_dict(body)
        for metric in metrics.metrics:
            _no_unknown_keys(metric)
            assert metric.metric_url.startswith(emu.storage_url)
            assert metric.type_.value in ("SCALAR", "COMPOSITE")
            assert (metric.value is None) == (metric.type_.value == "COMPOSITE")
        _, body = await raw.get(f"/batches/{emu.batch_id}/jobs/{job_spec.id}/metricsData")
        data = ListJobMetricsDataOutput.from_dict(body)
        for item in data.metrics_data:
            _no_unknown_keys(item)
            assert item.metrics_data_type.value in ("STANDARD", "EXTERNAL_FILE")

    _, body = await raw.get(f"/batches/{emu.batch_id}")
    batch = Batch.from_dict(body)
    _no_unknown_keys(batch)
    assert batch.total_jobs == 12
    assert batch.status.value == "BATCH_METRICS_RUNNING"
    build = Build.from_dict((await raw.get(f"/builds/{batch.build_id}"))[1])
    _no_unknown_keys(build)

    _, body = await raw.get("/batches", params={"pageSize": 8})
    listed = ListBatchesOutput.from_dict(body)
    for b in listed.batches:
        _no_unknown_keys(b)
    assert listed.total == len(ds.batches)

    report_batch = _report_batch(emu)
    _, body = await raw.get(f"/batches/{report_batch}/metrics")
    for m in ListBatchMetricsOutput.from_dict(body).batch_metrics:
        _no_unknown_keys(m)
        assert m.batch_id == str(report_batch)
    _, body = await raw.get(f"/batches/{report_batch}/metricsData")
    for d in ListBatchMetricsDataOutput.from_dict(body).batch_metrics_data:
        _no_unknown_keys(d)

    _, body = await raw.get(f"/reports/{emu.report_id}")
    report = Report.from_dict(body)
    _no_unknown_keys(report)
    assert report.test_suite_id == str(ds.test_suite_id)
    assert report.start_timestamp < report.end_timestamp

    experience = ds.experiences[0]
    _, body = await raw.get(f"/experiences/{experience.id}/experienceTags")
    tags = ListExperienceTagsOutput.from_dict(body)
    assert [t.name for t in tags.experience_tags] == [t.name for t in experience.tags]
    for t in tags.experience_tags:
        _no_unknown_keys(t)
    _, body = await raw.get(f"/experiences/{experience.id}", params={"includeCustomFields": "true"})
    parsed = Experience.from_dict(body)
    _no_unknown_keys(parsed)
    assert parsed.name == experience.name
    assert [(f.name, f.type_.value, f.values) for f in parsed.custom_fields] == [
        (f.name, f.type, list(f.values)) for f in experience.custom_fields
    ]
    assert {f.type_.value for f in parsed.custom_fields} == {"text", "number", "timestamp", "json"}


async def test_a_missing_experience_is_404_while_its_jobs_name_it() -> None:
    config = EmulatorConfig(jobs_per_batch=4, experiences=4, missing_experiences=(1,))
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        gone = emu.dataset.experiences[1]
        assert any(j.experience.id == gone.id for j in emu.dataset.jobs(emu.batch_id))
        for path in (f"/experiences/{gone.id}", f"/experiences/{gone.id}/experienceTags"):
            status, body = await raw.get(path)
            assert (status, body["code"]) == (404, 404)
        status, _ = await raw.get(f"/experiences/{emu.dataset.experiences[0].id}")
        assert status == 200


async def test_batches_carry_the_configured_metrics_set_name() -> None:
    config = EmulatorConfig(jobs_per_batch=2, metrics_set_name="nightly")
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        _, body = await Raw(emu, session).get(f"/batches/{emu.batch_id}")
    assert Batch.from_dict(body).metrics_set_name == "nightly"


# ---- determinism and inputs ----


async def _snapshot(config: EmulatorConfig) -> tuple[list[dict[str, Any]], list[bytes]]:
    async with Emulator(config) as emu, aiohttp.ClientSession() as session:
        raw = Raw(emu, session)
        jobs, _ = await raw.all_pages(f"/batches/{emu.batch_id}/jobs", "jobs")
        bodies: list[bytes] = []
        for job in jobs[:4]:
            base = f"/batches/{emu.batch_id}/jobs/{job['jobID']}"
            metrics, _ = await raw.all_pages(f"{base}/metrics", "metrics")
            data, _ = await raw.all_pages(f"{base}/metricsData", "metricsData")
            for url in [m["metricURL"] for m in metrics] + [d["metricsDataURL"] for d in data]:
                status, body = await raw.fetch(url)
                assert status == 200
                bodies.append(body)
        return jobs, bodies


async def test_same_seed_same_answers_and_bytes() -> None:
    first = await _snapshot(SMALL)
    again = await _snapshot(SMALL)
    other = await _snapshot(SMALL.replace(seed=1))
    assert first == again
    assert first[1]
    assert first[0] != other[0]
    assert first[1] != other[1]


async def test_write_batch_and_report_config(tmp_path: Path) -> None:
    async with Emulator(SMALL) as emu:
        batch = json.loads(emu.write_batch_config(tmp_path).read_text())
        report = json.loads(emu.write_report_config(tmp_path).read_text())
        api_url = emu.api_url
    assert batch == {
        "authToken": emu.token,
        "apiURL": api_url,
        "batchID": str(emu.batch_id),
        "projectID": str(emu.project_id),
    }
    assert api_url.startswith("http://127.0.0.1:")
    assert api_url.endswith("/v1")
    assert report == {
        "authToken": emu.token,
        "apiURL": api_url,
        "projectID": str(emu.project_id),
        "reportID": str(emu.report_id),
    }
