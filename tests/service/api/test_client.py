"""ApiClient and StorageClient against a real local server with scripted answers."""

from __future__ import annotations

import asyncio
import json
import time
import uuid
from collections.abc import Mapping
from typing import Any

import pytest
from aiohttp import hdrs, web
from aiohttp.test_utils import TestServer
from multidict import CIMultiDict, CIMultiDictProxy
from yarl import URL

from stook.service.api import RetryPolicy
from stook.service.api._client import ApiClient, IdLike
from stook.service.api._errors import (
    ApiResponseError,
    ApiStatusError,
    AuthError,
    NotFoundError,
    OriginUnavailableError,
    PresignedUrlExpiredError,
    RetriesExhaustedError,
    RetryAfterTooLongError,
    StorageError,
    TransportError,
)
from stook.service.api._limits import FixedLimit
from stook.service.api._models import (
    ApiMetricsData,
    ConflatedJobStatus,
    Job,
    JobMetricsPage,
)
from stook.service.api._storage import StorageClient
from stook.service.api._transport import HttpTransport, Response, TrafficCounts
from tests.service.conftest import RecordingSleep
from tests.service.scripted_server import (
    ScriptedServer,
    answer,
    answer_json,
    redirect,
    reset_connection,
    truncated_body,
)

TOKEN = "tok-" + "s3cr3t" * 6
PROJECT = uuid.UUID("11111111-1111-4111-8111-111111111111")
BATCH = uuid.UUID("22222222-2222-4222-8222-222222222222")
JOBS_PATH = f"/v1/projects/{PROJECT}/batches/{BATCH}/jobs"
BATCH_PATH = f"/v1/projects/{PROJECT}/batches/{BATCH}"
SIGNATURE = "deadbeef" * 8


def job_json(index: int) -> dict[str, object]:
    return {
        "jobID": str(uuid.UUID(int=index)),
        "batchID": str(BATCH),
        "conflatedStatus": "PASSED",
        "jobStatus": "SUCCEEDED",
        "experienceName": f"experience {index}",
        "creationTimestamp": "2025-01-02T03:04:05.123456789Z",
        "someFutureField": {"ignored": True},
    }


def batch_json() -> dict[str, object]:
    return {"batchID": str(BATCH), "status": "SUCCEEDED", "conflatedStatus": "COMPLETE"}


def presigned(server: ScriptedServer, path: str) -> str:
    return server.url(path) + f"?X-Amz-Expires=900&X-Amz-Signature={SIGNATURE}"


def client(server: ScriptedServer, policy: RetryPolicy, **kwargs: Any) -> ApiClient:
    return ApiClient(server.base_url, TOKEN, retry=policy, **kwargs)


# -- paging and the token -----------------------------------------------------------------


async def test_paginates_through_every_page_with_bearer_token(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(
        JOBS_PATH,
        answer_json({"jobs": [job_json(1), job_json(2)], "nextPageToken": "p2", "total": 5}),
        answer_json({"jobs": [job_json(3), job_json(4)], "nextPageToken": "p3"}),
        answer_json({"jobs": [job_json(5)], "nextPageToken": ""}),
    )
    async with client(server, fast_policy, page_size=2) as api:
        jobs = [job async for job in api.list_jobs(PROJECT, str(BATCH))]

    assert [job.job_id for job in jobs] == [uuid.UUID(int=i) for i in range(1, 6)]
    assert all(isinstance(job, Job) for job in jobs)
    assert jobs[0].conflated_status == ConflatedJobStatus.PASSED
    assert jobs[0].creation_timestamp is not None
    assert jobs[0].creation_timestamp.tzinfo is not None
    hits = server.hits(JOBS_PATH)
    assert [hit.query.get("pageToken") for hit in hits] == [None, "p2", "p3"]
    assert {hit.query["pageSize"] for hit in hits} == {"2"}
    assert all(hit.headers["Authorization"] == f"Bearer {TOKEN}" for hit in hits)


async def test_a_jobs_listings_as_lists_read_every_page(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    job = uuid.UUID(int=7)
    base = f"/v1/projects/{PROJECT}/batches/{BATCH}/jobs/{job}"

    def metric(i: int) -> dict[str, Any]:
        return {"metricID": str(uuid.UUID(int=100 + i)), "name": f"m{i}", "type": "SCALAR"}

    def data(i: int) -> dict[str, Any]:
        return {"dataID": str(uuid.UUID(int=200 + i)), "name": f"d{i}"}

    pages = [
        answer_json({"metrics": [metric(1), metric(2)], "nextPageToken": "p2"}),
        answer_json({"metrics": [metric(2), metric(3)]}),  # a repeat, dropped
    ]
    server.script(f"{base}/metrics", *pages, *pages)
    server.script(f"{base}/metricsData", answer_json({"metricsData": [data(1)]}))
    async with client(server, fast_policy, page_size=2) as api:
        as_list = await api.list_job_metrics(PROJECT, BATCH, job)
        as_items = [
            m
            async for m in api.paginate(
                f"/projects/{PROJECT}/batches/{BATCH}/jobs/{job}/metrics", JobMetricsPage
            )
        ]
        data_list = await api.list_job_metrics_data(PROJECT, BATCH, job)
    assert as_list == as_items
    assert [m.name for m in as_list] == ["m1", "m2", "m3"]
    assert data_list == [ApiMetricsData(uuid.UUID(int=201), name="d1")]
    hits = server.hits(f"{base}/metrics")
    assert [hit.query.get("pageToken") for hit in hits] == [None, "p2"] * 2
    # Each listing's first page asked for as paginate asks for it.
    asked = [(hit.path, hit.query) for hit in hits]
    assert asked[0] == asked[2]
    assert asked[1] == asked[3]
    assert asked[0][1] == {"pageSize": "2"}
    data_hits = [(hit.path, hit.query) for hit in server.hits(f"{base}/metricsData")]
    assert data_hits == [(f"{base}/metricsData", {"pageSize": "2"})]


@pytest.mark.parametrize(
    "page",
    [
        {},
        {"metrics": None, "nextPageToken": ""},
        {"metrics": [], "nextPageToken": None},
        {"metrics": [{"metricID": "a"}, {"name": "b"}], "total": 2},
        {"metrics": [{"metricID": "a"}], "nextPageToken": 0},
        {"metrics": "many"},
        {"metrics": {"metricID": "a"}},
        {"metrics": [{"metricID": "a"}, ["b"]]},
        {"metrics": [{"metricID": "a"}, None]},
        {"metrics": [{"metricID": "a"}], "nextPageToken": 7},
    ],
)
async def test_a_one_page_listing_as_a_list_reads_as_paginate_reads_it(
    server: ScriptedServer, fast_policy: RetryPolicy, page: dict[str, Any]
) -> None:
    """A job's listing read as a list (`_list_all`) gives paginate's items, or its error."""
    job = uuid.UUID(int=7)
    path = f"/projects/{PROJECT}/batches/{BATCH}/jobs/{job}/metrics"
    server.script(f"/v1{path}", answer_json(page), answer_json(page))
    async with client(server, fast_policy) as api:
        try:
            expected: object = [item async for item in api.paginate(path, JobMetricsPage)]
        except ApiResponseError as exc:
            expected = str(exc)
        try:
            got: object = await api._list_all(path, JobMetricsPage)
        except ApiResponseError as exc:
            got = str(exc)
    assert got == expected


async def test_a_jobs_listings_name_its_own_batch_whatever_came_before(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    """A job's listings name the batch asked for, however its IDs are spelled."""
    other_batch, job = uuid.UUID(int=8), uuid.UUID(int=7)
    asked: list[tuple[IdLike, IdLike]] = [
        (PROJECT, BATCH),
        (str(PROJECT), BATCH),
        (PROJECT, other_batch),
        (PROJECT, str(other_batch).upper()),
        (PROJECT, BATCH),
    ]
    for batch in (BATCH, other_batch):
        path = f"/v1/projects/{PROJECT}/batches/{batch}/jobs/{job}/metrics"
        server.script(path, *[answer_json({"metrics": []})] * 3)
    async with client(server, fast_policy) as api:
        for project_id, batch_id in asked:
            assert await api.list_job_metrics(project_id, batch_id, job) == []
        with pytest.raises(ValueError, match="not a UUID"):
            await api.list_job_metrics(PROJECT, "no batch", job)
    assert len(server.hits(f"/v1/projects/{PROJECT}/batches/{BATCH}/jobs/{job}/metrics")) == 3
    assert len(server.hits(f"/v1/projects/{PROJECT}/batches/{other_batch}/jobs/{job}/metrics")) == 2


async def test_missing_next_page_token_and_missing_items_end_the_list(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(JOBS_PATH, answer_json({}))
    async with client(server, fast_policy) as api:
        assert [job async for job in api.list_jobs(PROJECT, BATCH)] == []
    assert len(server.hits(JOBS_PATH)) == 1


async def test_a_repeated_page_token_is_an_error_not_a_loop(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(JOBS_PATH, answer_json({"jobs": [job_json(1)], "nextPageToken": "same"}))
    async with client(server, fast_policy) as api:
        with pytest.raises(ApiResponseError, match="repeated a page token"):
            _ = [job async for job in api.list_jobs(PROJECT, BATCH)]
    assert len(server.hits(JOBS_PATH)) == 2


async def test_search_parameter_and_single_objects(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    search = f'test_suite_id = "{uuid.UUID(int=9)}" AND created_at > "2025-01-01T00:00:00Z"'
    server.script(f"/v1/projects/{PROJECT}/batches", answer_json({"batches": [batch_json()]}))
    server.script(BATCH_PATH, answer_json(batch_json()))
    async with client(server, fast_policy) as api:
        found = [batch async for batch in api.list_batches(PROJECT, search=search)]
        single = await api.get_batch(PROJECT, BATCH)
    assert found == [single]
    assert server.hits(f"/v1/projects/{PROJECT}/batches")[0].query["search"] == search


async def test_malformed_json_names_the_url_without_secrets(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(BATCH_PATH, answer(200, b"{not json"))
    async with client(server, fast_policy) as api:
        with pytest.raises(ApiResponseError, match="not valid JSON") as caught:
            await api.get_batch(PROJECT, BATCH)
    assert BATCH_PATH in str(caught.value)
    assert len(server.hits(BATCH_PATH)) == 1


@pytest.mark.parametrize(
    "body",
    [
        b'{"value": NaN}',  # not JSON, though Python's parser takes it
        b"[]",
        b'"a string"',
        b"[" * 5_000 + b"]" * 5_000,
        b'{"deep": ' + b"[" * 5_000 + b"]" * 5_000 + b"}",  # in a field nobody reads
    ],
)
async def test_an_answer_that_is_no_json_object_is_an_invalid_answer(
    server: ScriptedServer, fast_policy: RetryPolicy, body: bytes
) -> None:
    server.script(BATCH_PATH, answer(200, body))
    async with client(server, fast_policy) as api:
        with pytest.raises(ApiResponseError) as caught:
            await api.get_json(f"/projects/{PROJECT}/batches/{BATCH}")
    assert str(caught.value).startswith(f"GET {server.url(BATCH_PATH)}: ")


async def test_invalid_field_is_reported_with_the_request_and_its_path(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    bad = job_json(7) | {"conflatedStatus": 3}
    server.script(JOBS_PATH, answer_json({"jobs": [job_json(6), bad]}))
    async with client(server, fast_policy) as api:
        with pytest.raises(ApiResponseError) as caught:
            _ = [job async for job in api.list_jobs(PROJECT, BATCH)]
    assert str(caught.value) == (
        f"GET {server.url(JOBS_PATH)}?pageSize=100: unusable answer: "
        "Expected `str | null`, got `int` - at `$.jobs[1].conflatedStatus`"
    )


@pytest.mark.parametrize(
    "echoed",
    [TOKEN, f"https://storage.example.com/m?X-Amz-Signature={SIGNATURE}"],
)
async def test_an_invalid_value_echoed_in_the_error_is_redacted(
    server: ScriptedServer, fast_policy: RetryPolicy, echoed: str
) -> None:
    """msgspec's message may quote the value (a timestamp that is none): never a secret."""
    bad = job_json(7) | {"creationTimestamp": echoed}
    server.script(JOBS_PATH, answer_json({"jobs": [bad]}))
    async with client(server, fast_policy) as api:
        with pytest.raises(ApiResponseError) as caught:
            _ = [job async for job in api.list_jobs(PROJECT, BATCH)]
    assert "Not an RFC 3339 timestamp" in str(caught.value)
    assert "at `$.jobs[0].creationTimestamp`" in str(caught.value)
    assert TOKEN not in str(caught.value)
    assert SIGNATURE not in str(caught.value)


async def test_a_value_too_large_for_a_double_is_an_invalid_answer(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    """Found by answers generated from the spec: a 400-digit integer as a scalar's value."""
    job = uuid.UUID(int=7)
    path = f"/v1/projects/{PROJECT}/batches/{BATCH}/jobs/{job}/metrics"
    body = b'{"metrics": [{"metricID": "%s", "value": %s}]}' % (
        str(uuid.UUID(int=8)).encode(),
        b"9" * 400,
    )
    server.script(path, answer(200, body))
    async with client(server, fast_policy) as api:
        with pytest.raises(ApiResponseError) as caught:
            await api.list_job_metrics(PROJECT, BATCH, job)
    assert str(caught.value) == (
        f"GET {server.url(path)}?pageSize=100: unusable answer: "
        "Number out of range - at `$.metrics[0].value`"
    )


async def test_ids_must_be_uuids(server: ScriptedServer, fast_policy: RetryPolicy) -> None:
    async with client(server, fast_policy) as api:
        with pytest.raises(ValueError, match="not a UUID"):
            await api.get_batch(PROJECT, "../../admin")
    assert server.seen == []


# -- retries ------------------------------------------------------------------------------


@pytest.mark.parametrize("status", [500, 502, 503, 429])
async def test_transient_statuses_are_retried(
    server: ScriptedServer, fast_policy: RetryPolicy, status: int
) -> None:
    server.script(BATCH_PATH, answer(status), answer(status), answer_json(batch_json()))
    async with client(server, fast_policy) as api:
        batch = await api.get_batch(PROJECT, BATCH)
        assert batch.batch_id == BATCH
        assert api.stats.retries == 2
        assert api.stats.requests == 3
        assert api.stats.statuses[status] == 2
        assert api.stats.statuses[200] == 1
    assert len(server.hits(BATCH_PATH)) == 3


async def test_retry_after_is_honoured(server: ScriptedServer, sleep: RecordingSleep) -> None:
    policy = RetryPolicy(initial_backoff=0, sleep=sleep)
    server.script(
        BATCH_PATH,
        answer(429, headers={"Retry-After": "0.01"}),
        answer(503, headers={"Retry-After": "0.02"}),
        answer(503),
        answer_json(batch_json()),
    )
    async with client(server, policy) as api:
        await api.get_batch(PROJECT, BATCH)
    # Asked-for pauses, then the (injected, zero) backoff.
    assert sleep.waits == [0.01, 0.02, 0.0]


async def test_retry_after_beyond_the_cap_fails_fast(
    server: ScriptedServer, sleep: RecordingSleep
) -> None:
    """`Retry-After: 3600` used to be waited out at the cap, again and again (~15 minutes);
    now the request ends at once, naming the header and the cap."""
    policy = RetryPolicy(sleep=sleep, clock=sleep.now)
    server.script(BATCH_PATH, answer(503, headers={"Retry-After": "3600"}))
    async with client(server, policy) as api:
        with pytest.raises(RetryAfterTooLongError) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert len(server.hits(BATCH_PATH)) == 1
    assert sleep.waits == []
    message = str(caught.value)
    assert "HTTP 503 with Retry-After: 3600" in message
    assert "the 60 s stook waits at most" in message
    assert BATCH_PATH in message


async def test_retry_after_really_waits(server: ScriptedServer) -> None:
    policy = RetryPolicy(initial_backoff=0)
    server.script(
        BATCH_PATH, answer(429, headers={"Retry-After": "0.1"}), answer_json(batch_json())
    )
    started = time.perf_counter()
    async with client(server, policy) as api:
        await api.get_batch(PROJECT, BATCH)
    assert time.perf_counter() - started >= 0.1


async def test_a_failing_request_is_retried_for_the_time_budget(
    server: ScriptedServer, sleep: RecordingSleep
) -> None:
    """Production backoff, on a clock that advances with each pause: far more than the six
    attempts of old, and never a pause past the budget."""
    policy = RetryPolicy(retry_for=60.0, sleep=sleep, clock=sleep.now)
    server.script(BATCH_PATH, answer(500))
    async with client(server, policy) as api:
        with pytest.raises(RetriesExhaustedError) as caught:
            await api.get_batch(PROJECT, BATCH)
        assert api.origin.is_open  # one request failing is not the API failing
    hits = len(server.hits(BATCH_PATH))
    assert hits > 6
    assert caught.value.attempts == hits
    assert sum(sleep.waits) == pytest.approx(60.0)
    assert max(sleep.waits) <= 10.0


async def test_an_api_failing_every_request_is_named_when_the_budget_is_spent(
    server: ScriptedServer, sleep: RecordingSleep
) -> None:
    """Many requests failing and none answered: the API is down, and the error says so."""
    policy = RetryPolicy(retry_for=60.0, sleep=sleep, clock=sleep.now)
    server.script(BATCH_PATH, answer(503))
    async with client(server, policy) as api:
        results = await asyncio.gather(
            *(api.get_batch(PROJECT, BATCH) for _ in range(8)), return_exceptions=True
        )
    assert all(isinstance(r, OriginUnavailableError) for r in results), results
    origin = server.url("/").rstrip("/")
    assert str(results[0]) == (
        f"the API at {origin} was unavailable for 60 s, the whole [fetch] retry_for budget; "
        "last error: HTTP 503"
    )


async def test_connection_reset_is_retried(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(BATCH_PATH, reset_connection(), reset_connection(), answer_json(batch_json()))
    async with client(server, fast_policy) as api:
        batch = await api.get_batch(PROJECT, BATCH)
    assert batch.batch_id == BATCH
    assert len(server.hits(BATCH_PATH)) == 3


async def test_truncated_body_is_retried(server: ScriptedServer, fast_policy: RetryPolicy) -> None:
    server.script(
        BATCH_PATH,
        truncated_body(b'{"batchID": "22', claimed_length=500),
        answer_json(batch_json()),
    )
    async with client(server, fast_policy) as api:
        batch = await api.get_batch(PROJECT, BATCH)
    assert batch.batch_id == BATCH
    assert len(server.hits(BATCH_PATH)) == 2


async def test_timeout_is_retried(server: ScriptedServer, sleep: RecordingSleep) -> None:
    policy = RetryPolicy(initial_backoff=0, sleep=sleep, request_timeout=0.1)
    server.script(BATCH_PATH, answer(200, delay=1.0), answer_json(batch_json()))
    async with client(server, policy) as api:
        await api.get_batch(PROJECT, BATCH)
    assert len(server.hits(BATCH_PATH)) == 2


async def test_a_cookie_an_answer_sets_is_not_sent_back(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(
        BATCH_PATH,
        answer(200, json.dumps(batch_json()).encode(), headers={"Set-Cookie": "session=abc"}),
        answer_json(batch_json()),
    )
    # By name: aiohttp's default jar keeps no cookie from an IP address.
    by_name = server.base_url.replace("127.0.0.1", "localhost")
    async with ApiClient(by_name, TOKEN, retry=fast_policy) as api:
        await api.get_batch(PROJECT, BATCH)
        await api.get_batch(PROJECT, BATCH)
    assert [hdrs.COOKIE in seen.headers for seen in server.hits(BATCH_PATH)] == [False, False]


async def test_a_timeout_takes_back_the_cancellation_it_sent(
    server: ScriptedServer, sleep: RecordingSleep
) -> None:
    policy = RetryPolicy(initial_backoff=0, sleep=sleep, request_timeout=0.1)
    server.script(BATCH_PATH, answer(200, delay=1.0), answer_json(batch_json()))
    async with client(server, policy) as api:
        await api.get_batch(PROJECT, BATCH)
        task = asyncio.current_task()
        assert task is not None
        # A cancellation left counted would turn the caller's next timeout into a
        # CancelledError.
        assert task.cancelling() == 0


async def test_a_request_cancelled_from_outside_stays_cancelled(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    arrived = asyncio.Event()

    async def respond_late(_request: web.Request) -> web.StreamResponse:
        arrived.set()
        await asyncio.sleep(1.0)
        return web.Response()

    server.script(BATCH_PATH, respond_late)
    async with client(server, fast_policy) as api:
        fetch = asyncio.create_task(api.get_batch(PROJECT, BATCH))
        await arrived.wait()
        fetch.cancel()
        with pytest.raises(asyncio.CancelledError):
            await fetch
    assert len(server.hits(BATCH_PATH)) == 1


@pytest.mark.parametrize(
    ("status", "error"),
    [(400, ApiStatusError), (401, AuthError), (403, AuthError), (404, NotFoundError)],
)
async def test_client_errors_are_not_retried(
    server: ScriptedServer,
    fast_policy: RetryPolicy,
    status: int,
    error: type[ApiStatusError],
) -> None:
    server.script(BATCH_PATH, answer(status, f"rejected token {TOKEN}".encode()))
    async with client(server, fast_policy) as api:
        with pytest.raises(error) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert type(caught.value) is error
    assert caught.value.status == status
    assert len(server.hits(BATCH_PATH)) == 1
    message = str(caught.value)
    assert f"answered HTTP {status}" in message
    assert BATCH_PATH in message
    assert TOKEN not in message
    assert TOKEN not in repr(caught.value)
    assert "\n" not in message


@pytest.mark.parametrize("path", ["", "/", "/api"])
async def test_a_404_from_an_api_url_without_v1_says_where_the_api_is(
    server: ScriptedServer, fast_policy: RetryPolicy, path: str
) -> None:
    batch_path = f"{path.rstrip('/')}/projects/{PROJECT}/batches/{BATCH}"
    server.script(batch_path, answer(404, b"Not Found"))
    async with ApiClient(server.url(path), TOKEN, retry=fast_policy) as api:
        with pytest.raises(NotFoundError) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert "answered HTTP 404: Not Found (apiURL should end in /v1" in str(caught.value)
    assert server.url(path) in str(caught.value)


async def test_a_404_under_v1_names_no_api_url(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(BATCH_PATH, answer(404, b"Not Found"))
    async with client(server, fast_policy) as api:
        with pytest.raises(NotFoundError) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert str(caught.value).endswith("answered HTTP 404: Not Found")


async def test_attempts_are_capped(server: ScriptedServer, sleep: RecordingSleep) -> None:
    policy = RetryPolicy(initial_backoff=0, sleep=sleep, max_attempts=3)
    server.script(BATCH_PATH, answer(503))
    async with client(server, policy) as api:
        with pytest.raises(RetriesExhaustedError) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert len(server.hits(BATCH_PATH)) == 3
    assert caught.value.attempts == 3
    assert caught.value.last_status == 503
    assert str(caught.value) == (
        f"GET {server.url(BATCH_PATH)} failed after 3 attempts; last error: HTTP 503"
    )


async def test_exhausted_connection_failures_name_the_cause(
    server: ScriptedServer, sleep: RecordingSleep
) -> None:
    policy = RetryPolicy(initial_backoff=0, sleep=sleep, max_attempts=2)
    server.script(BATCH_PATH, reset_connection())
    async with client(server, policy) as api:
        with pytest.raises(RetriesExhaustedError) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert str(caught.value) == (
        f"GET {server.url(BATCH_PATH)} failed after 2 attempts; "
        "last error: ServerDisconnectedError: Server disconnected"
    )


async def test_requests_in_flight_are_bounded_by_concurrency(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(BATCH_PATH, answer(200, b'{"batchID": "%s"}' % str(BATCH).encode(), delay=0.02))
    async with client(server, fast_policy, concurrency=3) as api:
        await asyncio.gather(*(api.get_batch(PROJECT, BATCH) for _ in range(12)))
    assert server.max_in_flight <= 3
    assert len(server.hits(BATCH_PATH)) == 12


async def test_a_limiter_passed_in_bounds_and_counts_every_request(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(BATCH_PATH, answer(200, b'{"batchID": "%s"}' % str(BATCH).encode(), delay=0.02))
    server.script("/obj", answer(429, b"slow down"), answer(200, b"payload"))
    shared = FixedLimit(3)
    async with client(server, fast_policy, limiter=shared) as api:
        await asyncio.gather(*(api.get_batch(PROJECT, BATCH) for _ in range(12)))
        assert await api.storage.fetch_bytes(server.url("/obj")) == b"payload"
    assert api.limiter is shared
    assert api.limiters == {"shared": shared}
    assert server.max_in_flight <= 3
    # Every request, API and storage alike, took a slot of the shared bound; the 429 came
    # back through it. Twelve requests for three slots: some of them waited.
    assert shared.stats.acquisitions == api.stats.requests + api.storage.stats.requests == 14
    assert shared.stats.in_flight == 0
    assert shared.stats.waits >= 9
    assert (shared.stats.throttled, shared.stats.trips) == (1, 1)


class PagesTransport:
    """A transport without a network: each GET is answered from `pages`, in order."""

    def __init__(self, pages: list[dict[str, object]]) -> None:
        self.stats = TrafficCounts()
        self.pages = pages
        self.sent: list[tuple[URL, dict[str, str | int]]] = []
        self.opened = self.closed = False

    async def open(self) -> None:
        self.opened = True

    async def close(self) -> None:
        self.closed = True

    async def get(
        self,
        url: URL,
        *,
        params: Mapping[str, str | int] | None = None,
        headers: Mapping[str, str] | None = None,
    ) -> Response:
        self.stats.requests += 1
        self.sent.append((url, dict(params or {})))
        body = json.dumps(self.pages.pop(0)).encode()
        return Response(status=200, headers=CIMultiDictProxy(CIMultiDict()), body=body, url=url)


async def test_a_transport_passed_in_carries_every_api_request(fast_policy: RetryPolicy) -> None:
    transport = PagesTransport(
        [
            {"jobs": [job_json(1)], "nextPageToken": "p2"},
            {"jobs": [job_json(2)], "nextPageToken": ""},
        ]
    )
    api = ApiClient("https://api.example.com/v1", TOKEN, retry=fast_policy, transport=transport)
    async with api:
        jobs = [job async for job in api.list_jobs(PROJECT, BATCH)]
        assert transport.opened
    assert transport.closed
    assert [job.job_id for job in jobs] == [uuid.UUID(int=1), uuid.UUID(int=2)]
    # The query comes in the URL, built by the client (see ApiClient._url).
    assert [str(url.with_query(None)) for url, _ in transport.sent] == [
        f"https://api.example.com{JOBS_PATH}"
    ] * 2
    assert [url.query.get("pageToken") for url, _ in transport.sent] == [None, "p2"]
    assert api.stats is transport.stats
    assert api.stats.requests == 2


async def test_a_storage_transport_passed_in_carries_every_storage_request(
    fast_policy: RetryPolicy,
) -> None:
    pages = PagesTransport([{"any": "document"}])
    storage = StorageClient(retry=fast_policy, transport=pages)
    async with storage:
        assert await storage.fetch_bytes("https://bucket.example.com/o?sig=x") == (
            b'{"any": "document"}'
        )
    assert storage.stats is pages.stats
    api = ApiClient("https://api.example.com/v1", TOKEN, adaptive=True, storage_transport=pages)
    # A transport passed in paces itself: only the API, built here, gets a pace.
    assert sorted(api.paces) == ["api"]
    assert api.storage.stats is pages.stats


# -- storage ------------------------------------------------------------------------------


async def test_storage_never_sends_the_token_even_on_the_api_host_and_after_redirect(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script("/v1/store/a", redirect(presigned(server, "/v1/store/b")))
    server.script("/v1/store/b", answer(200, b"payload"))
    async with client(server, fast_policy) as api:
        payload = await api.storage.fetch_bytes(presigned(server, "/v1/store/a"))
    assert payload == b"payload"
    hops = server.hits("/v1/store/a") + server.hits("/v1/store/b")
    assert len(hops) == 2
    for hop in hops:
        assert "Authorization" not in hop.headers
        assert hop.query["X-Amz-Signature"] == SIGNATURE  # signature reached storage intact


async def test_a_transport_reads_whole_bodies_and_reuses_its_connection() -> None:
    # The body is read from the answer's stream (not ClientResponse.read): the connection
    # must still go back to the pool, to be used again by the next request.
    peers: list[object] = []

    async def handler(request: web.Request) -> web.Response:
        assert request.transport is not None
        peers.append(request.transport.get_extra_info("peername"))
        return web.Response(body=b"x" * int(request.query["n"]))

    app = web.Application()
    app.router.add_get("/body", handler)
    async with TestServer(app, host="127.0.0.1", port=0) as test_server:
        url = test_server.make_url("/body")
        async with HttpTransport(name="t", concurrency=1, request_timeout=5.0) as transport:
            sizes = [0, 1, 100_000, 3]
            bodies = [await transport.get(url.with_query(n=n)) for n in sizes]
    assert [len(r.body) for r in bodies] == sizes
    assert len(peers) == 4
    assert len(set(peers)) == 1


async def test_a_transport_reads_a_declared_length_and_no_body_where_none_may_be() -> None:
    # Raw answers: a 304 may declare the length of a body it does not carry; a 200 that
    # closes before its declared length is a failure that may heal, never short data.
    answers = [
        b"HTTP/1.1 304 Not Modified\r\nContent-Length: 10\r\n\r\n",
        b"HTTP/1.1 200 OK\r\nContent-Length: 0\r\n\r\n",
        b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n\r\nhello",
        b"HTTP/1.1 200 OK\r\nContent-Length: 10\r\n\r\npar",
    ]

    async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        while answers:
            if not await reader.readuntil(b"\r\n\r\n"):
                break
            writer.write(answers.pop(0))
            await writer.drain()
            if not answers:
                writer.close()

    raw = await asyncio.start_server(serve, "127.0.0.1", 0)
    port = raw.sockets[0].getsockname()[1]
    url = URL(f"http://127.0.0.1:{port}/x")
    async with raw, HttpTransport(name="t", concurrency=1, request_timeout=5.0) as transport:
        assert [(r.status, r.body) for r in [await transport.get(url) for _ in range(3)]] == [
            (304, b""),
            (200, b""),
            (200, b"hello"),
        ]
        with pytest.raises(TransportError) as caught:
            await transport.get(url)
    assert caught.value.retryable


async def test_storage_follows_five_redirects_and_refuses_a_sixth(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    for hop in range(7):
        server.script(f"/hop/{hop}", redirect(presigned(server, f"/hop/{hop + 1}")))
    server.script("/end/5", answer(200, b"five"))
    for hop in range(5):
        server.script(f"/end/{hop}", redirect(presigned(server, f"/end/{hop + 1}")))
    async with StorageClient(retry=fast_policy) as storage:
        assert await storage.fetch_bytes(presigned(server, "/end/0")) == b"five"
        with pytest.raises(StorageError, match="more than 5 redirects") as caught:
            await storage.fetch_bytes(presigned(server, "/hop/0"))
    assert caught.value.status is None
    assert [len(server.hits(f"/hop/{hop}")) for hop in range(7)] == [1] * 6 + [0]


async def test_storage_maps_a_refusal_after_a_redirect(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script("/moved", redirect(presigned(server, "/gone")))
    server.script("/gone", answer(404, b"<Error><Code>NoSuchKey</Code></Error>"))
    async with StorageClient(retry=fast_policy) as storage:
        with pytest.raises(StorageError, match="no such object") as caught:
            await storage.fetch_bytes(presigned(server, "/moved"))
    assert caught.value.status == 404


async def test_storage_keeps_the_signed_query_byte_for_byte(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script("/obj", answer(200, b"x"))
    url = server.url("/obj") + "?X-Amz-Credential=AKIA%2F20250101%2Fus-east-1&X-Amz-Signature=ab"
    async with StorageClient(retry=fast_policy) as storage:
        await storage.fetch_bytes(url)
    assert server.hits("/obj")[0].query["X-Amz-Credential"] == "AKIA/20250101/us-east-1"


async def test_storage_strips_user_info_from_the_url(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script("/obj", answer(200, b"x"))
    url = server.url("/obj").replace("http://", "http://user:pass@")
    async with StorageClient(retry=fast_policy) as storage:
        await storage.fetch_bytes(url)
    assert "Authorization" not in server.hits("/obj")[0].headers


async def test_storage_403_means_the_presigned_url_expired(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    body = (
        b"<Error><Code>AccessDenied</Code><Message>Request has expired</Message>"
        b"<SignatureProvided>" + SIGNATURE.encode() + b"</SignatureProvided></Error>"
    )
    server.script("/obj", answer(403, body))
    async with StorageClient(retry=fast_policy) as storage:
        with pytest.raises(PresignedUrlExpiredError) as caught:
            await storage.fetch_bytes(presigned(server, "/obj"))
    assert isinstance(caught.value, StorageError)
    assert caught.value.status == 403
    assert len(server.hits("/obj")) == 1
    message = str(caught.value)
    assert "(AccessDenied)" in message
    assert "list again for a fresh URL" in message
    assert SIGNATURE not in message
    assert SIGNATURE not in repr(caught.value)


async def test_storage_retries_transient_failures(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(
        "/obj",
        answer(503),
        reset_connection(),
        truncated_body(b"par", claimed_length=10),
        answer(429, headers={"Retry-After": "0"}),
        answer(200, b"0123456789"),
    )
    async with StorageClient(retry=fast_policy) as storage:
        assert await storage.fetch_bytes(presigned(server, "/obj")) == b"0123456789"
        # aiohttp itself re-sends once when a reused keep-alive connection turns out closed,
        # so the reset may not cost one of our attempts.
        assert storage.stats.retries in (3, 4)
        assert storage.stats.bytes_received >= 10
    assert len(server.hits("/obj")) == 5


async def test_storage_404_is_not_retried(server: ScriptedServer, fast_policy: RetryPolicy) -> None:
    server.script("/obj", answer(404))
    async with StorageClient(retry=fast_policy) as storage:
        with pytest.raises(StorageError, match="no such object") as caught:
            await storage.fetch_bytes(presigned(server, "/obj"))
    assert not isinstance(caught.value, PresignedUrlExpiredError)
    assert len(server.hits("/obj")) == 1


async def test_storage_exhaustion_message_has_no_signature(
    server: ScriptedServer, sleep: RecordingSleep
) -> None:
    policy = RetryPolicy(initial_backoff=0, sleep=sleep, max_attempts=2)
    server.script("/obj", answer(500))
    async with StorageClient(retry=policy) as storage:
        with pytest.raises(RetriesExhaustedError) as caught:
            await storage.fetch_bytes(presigned(server, "/obj"))
    message = str(caught.value)
    assert SIGNATURE not in message
    assert "X-Amz-Signature=***" in message
    assert "X-Amz-Expires=***" in message


def test_client_repr_and_errors_do_not_show_the_token() -> None:
    api = ApiClient("https://api.example.com/v1?key=abc", TOKEN)
    assert TOKEN not in repr(api)
    assert "abc" not in repr(api)
    with pytest.raises(ValueError, match="base URL") as caught:
        ApiClient("ftp://example.com", TOKEN)
    assert TOKEN not in str(caught.value)


# -- the storage transport's own guard ----------------------------------------------------


def test_storage_transport_refuses_credential_headers_at_construction() -> None:
    with pytest.raises(ValueError, match="must not carry credential headers"):
        HttpTransport(
            name="storage",
            concurrency=1,
            request_timeout=1.0,
            headers={"authorization": "Bearer x"},
            credentials_allowed=False,
        )


async def test_storage_transport_sends_no_user_info_of_a_url(server: ScriptedServer) -> None:
    server.script("/obj", answer(200, b"x"))
    transport = HttpTransport(
        name="storage",
        concurrency=1,
        request_timeout=1.0,
        follow_redirects=False,
        credentials_allowed=False,
    )
    async with transport:
        response = await transport.get(URL(server.url("/obj")).with_user("u").with_password("p"))
    assert response.body == b"x"
    assert [request.headers.get("Authorization") for request in server.seen] == [None]


@pytest.mark.parametrize(
    ("path", "params"),
    [
        (f"/projects/{PROJECT}/batches/{BATCH}/jobs", {"pageSize": 100}),
        (f"projects/{PROJECT}/jobs", {"pageSize": 100, "pageToken": "AbC-1_2.3~"}),
        (f"/projects/{PROJECT}/batches", {"pageSize": 5, "search": "name = 'a b' AND x"}),
        ("/projects/a b/ü", {"pageToken": "p/2=+&x%41"}),
        ("/projects/../x/./y", None),
        ("/projects/x y", {"name": "ü"}),
        ("/projects/x", {"pageSize": 1, "pageToken": ""}),
        ("/projects//x/", {}),
    ],
)
@pytest.mark.parametrize("base", ["https://api.example.com/v1", "https://api.example.com/a%20b/"])
def test_a_requests_url_is_its_path_under_the_base_url_quoted_as_yarl_quotes_text(
    base: str, path: str, params: dict[str, str | int] | None
) -> None:
    api = ApiClient(base, TOKEN)
    quoted = URL(str(URL(base)).rstrip("/") + "/" + path.lstrip("/"))
    expected = quoted.extend_query(params) if params else quoted
    got = api._url(path, params)
    assert str(got) == str(expected)
    assert got.raw_path == expected.raw_path
    assert got.raw_query_string == expected.raw_query_string


@pytest.mark.parametrize(
    "base",
    [
        "http://127.0.0.1:8080/v1",
        "https://api.resim.ai/v1/",
        "http://api.test",
        "http://user:secret@api.test:8443/a/b/",
        "HTTPS://API.Example.COM:443/V1",
    ],
)
async def test_a_listings_first_page_is_asked_for_under_the_base_path(base: str) -> None:
    """A listing's first page is asked for at the base URL's path, with the page size."""
    sent: list[URL] = []

    class Recording:
        stats = TrafficCounts()

        async def open(self) -> None: ...

        async def close(self) -> None: ...

        async def get(self, url: URL, **_: object) -> Response:
            sent.append(url)
            body = b'{"metrics": [], "nextPageToken": ""}'
            return Response(200, CIMultiDictProxy(CIMultiDict()), body, url)

    api = ApiClient(base, TOKEN, transport=Recording(), page_size=7)
    job = uuid.uuid4()
    assert await api.list_job_metrics(PROJECT, BATCH, job) == []
    # What the first page's URL was before: the base URL as a string, and the rest.
    text = f"{str(URL(base)).rstrip('/')}/projects/{PROJECT}/batches/{BATCH}/jobs/{job}/metrics"
    want = URL(text + "?pageSize=7", encoded=True)
    (got,) = sent
    assert str(got) == str(want)
    assert (got.scheme, got.host, got.port, got.raw_path, got.raw_query_string) == (
        want.scheme,
        want.host,
        want.port,
        want.raw_path,
        want.raw_query_string,
    )
