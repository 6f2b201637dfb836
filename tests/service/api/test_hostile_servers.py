"""Servers that are hostile or broken: bodies without end, listings without end, redirects
to other origins. Each against a real local server (tests/service/scripted_server.py)."""

from __future__ import annotations

import asyncio
import functools
import gzip
import itertools
import json
import os
import sys
import time
import tracemalloc
import uuid
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
from aiohttp import web
from aiohttp.test_utils import TestServer

from stook.service.api import RetryPolicy, body_cap_mb
from stook.service.api._client import ApiClient
from stook.service.api._errors import (
    ApiResponseError,
    AuthError,
    BodyTooLargeError,
    RedirectedRefusalError,
)
from stook.service.api._storage import StorageClient
from stook.service.cli._run import exit_code_for, explain
from tests.failures import failure_lines
from tests.service.scripted_server import (
    Responder,
    ScriptedServer,
    answer,
    answer_json,
    redirect,
)

TOKEN = "tok-" + "hostile" * 6
PROJECT = uuid.UUID(int=1)
BATCH = uuid.UUID(int=2)
JOBS_PATH = f"/v1/projects/{PROJECT}/batches/{BATCH}/jobs"
BATCH_PATH = f"/v1/projects/{PROJECT}/batches/{BATCH}"
SIGNATURE = "5ec12e7" * 8
MB = 2**20
INFLATED = 50 * MB


def presigned(server: ScriptedServer, path: str) -> str:
    return server.url(path) + f"?X-Amz-Expires=900&X-Amz-Signature={SIGNATURE}"


def job(index: int) -> dict[str, object]:
    return {"jobID": str(uuid.UUID(int=index)), "conflatedStatus": "PASSED"}


@functools.cache
def gzip_bomb() -> bytes:
    """A JSON page padded with 50 MB of spaces: about 50 kB on the wire."""
    return gzip.compress(b'{"jobs": []' + b" " * INFLATED + b"}", compresslevel=9)


def one_mb_api(server: ScriptedServer, policy: RetryPolicy) -> ApiClient:
    return ApiClient(
        server.base_url,
        TOKEN,
        retry=policy,
        body_cap=body_cap_mb(1, "max_api_body_mb"),
        storage_body_cap=body_cap_mb(1, "max_body_mb"),
    )


# -- bodies are capped --------------------------------------------------------------------


async def test_a_gzip_bomb_is_stopped_at_the_cap_not_inflated(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    bomb = gzip_bomb()
    assert len(bomb) < MB // 4  # small on the wire, 50 MB once inflated
    server.script(JOBS_PATH, answer(200, bomb, headers={"Content-Encoding": "gzip"}))
    tracemalloc.start()
    try:
        async with one_mb_api(server, fast_policy) as api:
            with pytest.raises(BodyTooLargeError) as caught:
                _ = [j async for j in api.list_jobs(PROJECT, BATCH)]
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 16 * MB  # never near the 50 MB the answer inflates to
    assert len(server.hits(JOBS_PATH)) == 1  # not retried: it would be just as large
    message = str(caught.value)
    assert message.startswith(f"GET {server.url(JOBS_PATH)}?pageSize=100 failed")
    assert "larger than 1 MB (the [fetch] max_api_body_mb cap)" in message
    assert exit_code_for(caught.value) == 3


async def test_an_over_long_storage_body_is_refused_without_its_signature(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    async def endless_chunks(request: web.Request) -> web.StreamResponse:
        # Chunked, so no Content-Length warns the client: it must count what arrives.
        response = web.StreamResponse()
        response.enable_chunked_encoding()
        await response.prepare(request)
        chunk = b"\0" * (64 * 1024)
        for _ in range(3 * MB // len(chunk)):
            await response.write(chunk)
        await response.write_eof()
        return response

    server.script("/obj", endless_chunks)
    async with StorageClient(retry=fast_policy, body_cap=body_cap_mb(1, "max_body_mb")) as storage:
        with pytest.raises(BodyTooLargeError) as caught:
            await storage.fetch_bytes(presigned(server, "/obj"))
    assert len(server.hits("/obj")) == 1
    message = str(caught.value)
    assert SIGNATURE not in message
    assert "X-Amz-Signature=***" in message
    assert "larger than 1 MB (the [fetch] max_body_mb cap)" in message


async def test_a_declared_length_over_the_cap_is_refused_before_reading(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script("/obj", answer(200, b"x" * (2 * MB)))
    async with StorageClient(retry=fast_policy, body_cap=body_cap_mb(1, "max_body_mb")) as storage:
        with pytest.raises(BodyTooLargeError, match="max_body_mb"):
            await storage.fetch_bytes(presigned(server, "/obj"))
        assert storage.stats.bytes_received == 0


async def test_a_body_at_the_cap_is_read_whole(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    payload = bytes(range(256)) * (MB // 256)
    server.script("/obj", answer(200, payload))
    server.script("/gz", answer(200, gzip.compress(payload), headers={"Content-Encoding": "gzip"}))
    async with StorageClient(retry=fast_policy, body_cap=body_cap_mb(1, "max_body_mb")) as storage:
        assert await storage.fetch_bytes(presigned(server, "/obj")) == payload
        assert await storage.fetch_bytes(presigned(server, "/gz")) == payload


# -- paging ends --------------------------------------------------------------------------


def endless(page: object) -> Responder:
    """Every page the same but for a fresh nextPageToken."""
    tokens = itertools.count(1)

    async def respond(_request: web.Request) -> web.StreamResponse:
        assert isinstance(page, dict)
        return web.json_response({**page, "nextPageToken": f"t{next(tokens)}"})

    return respond


async def list_all(api: ApiClient, into: list[uuid.UUID] | None = None) -> list[uuid.UUID]:
    """Every job ID listed; `into` also gets those listed before a failure."""
    listed = [] if into is None else into
    async for j in api.list_jobs(PROJECT, BATCH):
        listed.append(j.job_id)
    return listed


async def test_endless_empty_pages_stop_after_a_run_of_them(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(JOBS_PATH, endless({}))
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy) as api:
        with pytest.raises(ApiResponseError) as caught:
            await list_all(api)
    assert len(server.hits(JOBS_PATH)) == 50
    assert str(caught.value) == (
        f"GET {server.url(JOBS_PATH)}: the listing does not end "
        "(50 empty pages in a row, each with a new page token)"
    )
    assert exit_code_for(caught.value) == 3


async def test_the_same_jobs_again_stop_on_the_second_page(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(JOBS_PATH, endless({"jobs": [job(1), job(2)]}))
    seen: list[uuid.UUID] = []
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy) as api:
        with pytest.raises(ApiResponseError, match="page 2 holds only items listed on earlier"):
            await list_all(api, into=seen)
    assert seen == [uuid.UUID(int=1), uuid.UUID(int=2)]  # the repeats are never handed on
    assert len(server.hits(JOBS_PATH)) == 2


async def test_an_empty_page_past_the_total_stops_at_once(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(JOBS_PATH, endless({"jobs": [], "total": 0}))
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy) as api:
        with pytest.raises(ApiResponseError, match="all 0 items of the listing's total"):
            await list_all(api)
    assert len(server.hits(JOBS_PATH)) == 1


async def test_new_items_far_past_the_total_stop(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    counter = itertools.count(1)

    async def fresh_jobs(_request: web.Request) -> web.StreamResponse:
        n = next(counter)
        return web.json_response(
            {"jobs": [job(2 * n), job(2 * n + 1)], "total": 3, "nextPageToken": f"t{n}"}
        )

    server.script(JOBS_PATH, fresh_jobs)
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy, page_size=2) as api:
        with pytest.raises(
            ApiResponseError, match="6 items listed, more than the listing's total of 3"
        ):
            await list_all(api)
    assert len(server.hits(JOBS_PATH)) == 3


def total_then_none(total: int, pages_with_total: int) -> Responder:
    """Pages of two fresh jobs each, for ever: the first few carry `total`, the rest none."""
    counter = itertools.count(1)

    async def respond(_request: web.Request) -> web.StreamResponse:
        n = next(counter)
        page: dict[str, object] = {"jobs": [job(2 * n), job(2 * n + 1)], "nextPageToken": f"t{n}"}
        if n <= pages_with_total:
            page["total"] = total
        return web.json_response(page)

    return respond


async def test_the_first_total_bounds_later_pages_that_leave_it_out(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(JOBS_PATH, total_then_none(total=3, pages_with_total=1))
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy, page_size=2) as api:
        with pytest.raises(ApiResponseError) as caught:
            await list_all(api)
    assert "6 items listed, more than the listing's total of 3" in str(caught.value)
    assert len(server.hits(JOBS_PATH)) == 3
    assert exit_code_for(caught.value) == 3


async def test_the_batch_job_count_bounds_a_listing_that_never_says_its_total(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(JOBS_PATH, total_then_none(total=0, pages_with_total=0))
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy, page_size=2) as api:
        with pytest.raises(ApiResponseError, match="more than the listing's total of 4"):
            async for _ in api.list_jobs(PROJECT, BATCH, expected=4):
                pass
    assert len(server.hits(JOBS_PATH)) == 4


@pytest.mark.parametrize(
    ("body", "why"),
    [
        (b"[" * 5_000 + b"]" * 5_000, "unusable answer: Expected `object`, got `array`"),
        # msgspec's parser recurses even over a field it skips.
        (b'{"deep": ' + b"[" * 5_000 + b"]" * 5_000 + b"}", "answer is nested too deeply"),
        (b'{"batchID": ' + b"7" * 5_000 + b"}", "Number out of range - at `$.batchID`"),
    ],
)
async def test_an_answer_json_cannot_hold_is_an_invalid_answer(
    server: ScriptedServer, fast_policy: RetryPolicy, body: bytes, why: str
) -> None:
    server.script(BATCH_PATH, answer(200, body, headers={"Content-Type": "application/json"}))
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy) as api:
        with pytest.raises(ApiResponseError) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert str(caught.value).startswith(f"GET {server.url(BATCH_PATH)}: ")
    assert why in str(caught.value)
    assert exit_code_for(caught.value) == 3


async def test_a_token_on_the_last_full_page_and_an_empty_final_page_are_fine(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(
        JOBS_PATH,
        answer_json({"jobs": [job(1), job(2)], "total": 4, "nextPageToken": "a"}),
        answer_json({"jobs": [job(3), job(4)], "total": 4, "nextPageToken": "b"}),
        answer_json({"jobs": [], "total": 4}),
    )
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy, page_size=2) as api:
        assert await list_all(api) == [uuid.UUID(int=i) for i in range(1, 5)]


async def test_a_job_repeated_on_a_later_page_is_handed_on_once(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    # Offset paging over a listing that changed meanwhile repeats job 2 on page 2 (and
    # job 3 on the last page): each job is fetched and folded once, not twice.
    server.script(
        JOBS_PATH,
        answer_json({"jobs": [job(1), job(2)], "nextPageToken": "a"}),
        answer_json({"jobs": [job(2), job(3)], "nextPageToken": "b"}),
        answer_json({"jobs": [job(3), job(4)]}),
    )
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy, page_size=2) as api:
        assert await list_all(api) == [uuid.UUID(int=i) for i in range(1, 5)]


async def test_a_few_empty_pages_within_a_listing_are_fine(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(
        JOBS_PATH,
        answer_json({"jobs": [job(1)], "nextPageToken": "a"}),
        *(answer_json({"nextPageToken": f"e{i}"}) for i in range(10)),
        answer_json({"jobs": [job(2)]}),
    )
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy) as api:
        assert await list_all(api) == [uuid.UUID(int=1), uuid.UUID(int=2)]


# -- redirects to another origin ----------------------------------------------------------


@pytest.fixture
async def other_origin() -> AsyncIterator[ScriptedServer]:
    """A second server: another port on 127.0.0.1 is another origin."""
    scripted = ScriptedServer()
    app = web.Application()
    app.router.add_route("GET", "/{tail:.*}", scripted.handle)
    test_server = TestServer(app, host="127.0.0.1", port=0)
    await test_server.start_server()
    scripted.server = test_server
    try:
        yield scripted
    finally:
        await test_server.close()


async def test_a_redirect_to_another_origin_carries_no_token_and_is_not_blamed_on_it(
    server: ScriptedServer, other_origin: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(BATCH_PATH, redirect(other_origin.url("/elsewhere")))
    other_origin.script("/elsewhere", answer(401, b'{"error": "no credentials"}'))
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy) as api:
        with pytest.raises(RedirectedRefusalError) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert server.hits(BATCH_PATH)[0].headers["Authorization"] == f"Bearer {TOKEN}"
    (hop,) = other_origin.hits("/elsewhere")
    assert "Authorization" not in hop.headers
    error = caught.value
    assert not isinstance(error, AuthError)
    line = explain(error)
    assert "refused the token" not in line
    assert line.startswith(f"GET {other_origin.url('/elsewhere')} answered HTTP 401")
    api_origin = server.url("/").rstrip("/")
    assert f"the API at {api_origin} redirected there" in line
    assert "not about the token" in line
    assert exit_code_for(error) == 3


async def test_a_refusal_after_a_same_origin_redirect_is_still_about_the_token(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    server.script(BATCH_PATH, redirect(server.url("/v1/moved")))
    server.script("/v1/moved", answer(401))
    async with ApiClient(server.base_url, TOKEN, retry=fast_policy) as api:
        with pytest.raises(AuthError) as caught:
            await api.get_batch(PROJECT, BATCH)
    assert server.hits("/v1/moved")[0].headers["Authorization"] == f"Bearer {TOKEN}"
    assert "refused the token" in explain(caught.value)


# -- the whole run, as a process ----------------------------------------------------------


@pytest.mark.parametrize(
    "hostile", ["endless-listing", "gzip-bomb", "total-dropped", "deep-nesting"]
)
async def test_stook_run_ends_with_exit_3_naming_the_listing(
    server: ScriptedServer, tmp_path: Path, hostile: str
) -> None:
    """Today's failures, end to end: an endless listing ran for ever, and a gzip bomb took
    the client to gigabytes and exited 0 as an empty batch."""
    if hostile == "endless-listing":
        server.script(JOBS_PATH, endless({}))
    elif hostile == "total-dropped":  # found by answers generated from the spec
        server.script(JOBS_PATH, total_then_none(total=3, pages_with_total=2))
    elif hostile == "deep-nesting":
        # Where the job listing has an unknown key: msgspec's parser recurses into it.
        server.script(JOBS_PATH, answer(200, b'{"x": ' + b"[" * 5_000 + b"]" * 5_000 + b"}"))
    else:
        server.script(JOBS_PATH, answer(200, gzip_bomb(), headers={"Content-Encoding": "gzip"}))
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    inputs.mkdir()
    (inputs / "batch_metrics_config.json").write_text(
        json.dumps(
            {
                "authToken": TOKEN,
                "apiURL": server.base_url,
                "batchID": str(BATCH),
                "projectID": str(PROJECT),
            }
        )
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
    started = time.monotonic()
    process = await asyncio.create_subprocess_exec(
        str(Path(sys.executable).parent / "stook"),
        "run",
        "--inputs",
        str(inputs),
        "--outputs",
        str(outputs),
        cwd=tmp_path,
        env=env,
        stdout=asyncio.subprocess.DEVNULL,
        stderr=asyncio.subprocess.PIPE,
    )
    _, stderr_bytes = await asyncio.wait_for(process.communicate(), timeout=60)
    stderr = stderr_bytes.decode()
    assert process.returncode == 3, stderr
    assert time.monotonic() - started < 60
    errors = failure_lines(stderr)
    assert len(errors) == 1, stderr
    assert f"GET {server.url(JOBS_PATH)}" in errors[0]
    if hostile == "endless-listing":
        assert "the listing does not end (50 empty pages in a row" in errors[0]
        assert len(server.hits(JOBS_PATH)) == 50
    elif hostile == "total-dropped":
        assert "the listing does not end" in errors[0]
        assert "more than the listing's total of 3" in errors[0]
    elif hostile == "deep-nesting":
        assert "answer is nested too deeply to read" in errors[0]
    else:
        assert "larger than 16 MB (the [fetch] max_api_body_mb cap)" in errors[0]
        assert len(server.hits(JOBS_PATH)) == 1
    assert "Traceback" not in stderr
    assert TOKEN not in stderr
    assert not outputs.exists() or os.listdir(outputs) == []
