"""A job's metric listing served from its page template: the bytes a page built afresh
would have, with freshly signed URLs at every answer."""

from __future__ import annotations

import hashlib
import hmac
import uuid
from datetime import timedelta

import aiohttp
import orjson
import pytest

from stook.emulator import Emulator
from stook.emulator import _json as emulator_json
from stook.emulator._page_templates import PLACEHOLDER, PageTemplate
from stook.emulator._signing import UrlSigner
from stook.emulator._storage import BUCKET
from tests.emulator.support import SMALL, Raw


def test_a_filled_template_is_the_page_serialized_whole() -> None:
    urls = ["http://s/a?X=1&Y=2", 'http://s/"quoted"\\path', "http://s/ünïcode/\u2028"]
    items = [{"name": "n", "metricURL": u, "value": 1.5} for u in urls]
    page = {"metrics": items, "t": ""}
    holes = {"metrics": [{**m, "metricURL": PLACEHOLDER} for m in items], "t": ""}
    template = PageTemplate.of(holes, ["p0", "p1", "p2"])
    assert template is not None
    assert template.paths == ("p0", "p1", "p2")
    assert template.fill(urls) == orjson.dumps(page)


def test_a_page_whose_placeholders_are_not_one_per_path_makes_no_template() -> None:
    stray = {"metrics": [{"metricURL": PLACEHOLDER, "name": PLACEHOLDER}]}
    assert PageTemplate.of(stray, ["p0"]) is None
    assert PageTemplate.of({"metrics": []}, ["p0"]) is None


def test_a_signature_is_the_hmac_of_its_message() -> None:
    signer = UrlSigner(b"secret", 60.0)
    message = b"GET\n/bucket/x\n1700000000000\n60"
    expected = hmac.new(b"secret", message, hashlib.sha256).hexdigest()
    assert signer._signature("/bucket/x", "1700000000000", "60") == expected


def _page_built_afresh(emu: Emulator, job_id: uuid.UUID, answer: bytes) -> bytes:
    """The page as the handler built it before templates, with `answer`'s URLs."""
    state = emu._state
    ds = emu.dataset
    job = ds.job(emu.batch_id, job_id)
    assert job is not None
    output = state.quirks.job_output(ds.job_output(emu.batch_id, job_id))  # type: ignore[arg-type]
    listed = orjson.loads(answer)
    by_id = {m.id: m for m in output.metrics}
    owner = {"jobID": str(job_id), "batchID": str(emu.batch_id)}
    created = job.created + timedelta(minutes=3)
    body = {
        "metrics": [
            state.quirks.metric(
                by_id[uuid.UUID(item["metricID"])],
                emulator_json.metric(
                    ds, by_id[uuid.UUID(item["metricID"])], item["metricURL"], created, owner
                ),
                job,
            )
            for item in listed["metrics"]
        ],
        "nextPageToken": listed.get("nextPageToken", ""),
    }
    return orjson.dumps(state.quirks.page(body))


@pytest.mark.parametrize("quirks", [False, True])
async def test_listings_are_the_bytes_of_pages_built_afresh(quirks: bool) -> None:
    async with (
        Emulator(SMALL.replace(spec_quirks=quirks)) as emu,
        aiohttp.ClientSession() as session,
    ):
        raw = Raw(emu, session)
        job = next(j for j in emu.dataset.jobs(emu.batch_id) if j.has_metrics)
        path = raw.url(f"/batches/{emu.batch_id}/jobs/{job.id}/metrics")
        answers: list[bytes] = []
        for query in ({}, {}, {"pageSize": "2"}, {"pageSize": "2"}):
            async with session.get(path, params=query, headers=raw.auth) as answer:
                assert answer.status == 200
                answers.append(await answer.read())
        body = orjson.loads(answers[2])
        assert body["nextPageToken"]
        async with session.get(
            path, params={"pageSize": "2", "pageToken": body["nextPageToken"]}, headers=raw.auth
        ) as answer:
            answers.append(await answer.read())
        for served in answers:
            assert served == _page_built_afresh(emu, job.id, served)
        # Each URL is signed at its answer, and served.
        urls = [m["metricURL"] for m in orjson.loads(answers[0])["metrics"]]
        assert urls[0].startswith(f"{emu.storage_url}/{BUCKET}/")
        status, _ = await raw.fetch(urls[0])
        assert status == 200


def _jobs_page_built_afresh(emu: Emulator, answer: bytes) -> bytes:
    """A job listing page as the handler built it before it kept pages, for `answer`'s jobs."""
    quirks, ds = emu._state.quirks, emu.dataset
    listed = orjson.loads(answer)
    jobs = {j.id: j for j in ds.jobs(emu.batch_id)}
    body = {
        "jobs": [
            quirks.job(
                jobs[uuid.UUID(item["jobID"])],
                emulator_json.job(ds, jobs[uuid.UUID(item["jobID"])]),
            )
            for item in listed["jobs"]
        ],
        "nextPageToken": listed.get("nextPageToken", ""),
        "total": listed["total"],
    }
    return orjson.dumps(quirks.page(body))


@pytest.mark.parametrize("quirks", [False, True])
async def test_job_listings_kept_are_the_bytes_of_pages_built_afresh(quirks: bool) -> None:
    async with (
        Emulator(SMALL.replace(spec_quirks=quirks)) as emu,
        aiohttp.ClientSession() as session,
    ):
        raw = Raw(emu, session)
        path = raw.url(f"/batches/{emu.batch_id}/jobs")
        answers: list[bytes] = []
        token = ""
        for query in ({}, {}, {"pageSize": "3"}, {"pageSize": "3"}, {"pageSize": "3"}):
            if token:
                query["pageToken"] = token
            async with session.get(path, params=query, headers=raw.auth) as answer:
                assert answer.status == 200
                answers.append(await answer.read())
            token = (
                orjson.loads(answers[-1]).get("nextPageToken", "") if "pageSize" in query else ""
            )
        assert answers[0] == answers[1]
        assert len({*answers[2:]}) == 3  # three pages, each its own jobs
        for served in answers:
            assert served == _jobs_page_built_afresh(emu, served)
