from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Iterator

import pytest
import structlog
from aiohttp import web
from aiohttp.test_utils import TestServer
from tenacity import wait_none

from stook.service._retry import RetryPolicy
from tests.service.scripted_server import ScriptedServer


@pytest.fixture
async def server() -> AsyncIterator[ScriptedServer]:
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


class RecordingSleep:
    """Stands in for asyncio.sleep: remembers each requested pause, waits only a tick."""

    def __init__(self) -> None:
        self.waits: list[float] = []

    async def __call__(self, seconds: float) -> None:
        self.waits.append(seconds)
        await asyncio.sleep(0)


@pytest.fixture
def sleep() -> RecordingSleep:
    return RecordingSleep()


@pytest.fixture
def fast_policy(sleep: RecordingSleep) -> RetryPolicy:
    """The production rules (6 attempts, Retry-After honoured) without the waiting."""
    return RetryPolicy(backoff=wait_none(), sleep=sleep, request_timeout=2.0)


@pytest.fixture(autouse=True)
def _fresh_structlog() -> Iterator[None]:
    structlog.reset_defaults()
    yield
    structlog.reset_defaults()
