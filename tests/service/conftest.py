from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Iterator

import pytest
import structlog
from aiohttp import web
from aiohttp.test_utils import TestServer

from stook.service.api import RetryPolicy
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
    """Stands in for asyncio.sleep: remembers each requested pause, waits only a tick.

    `now` is a clock that advances by each pause instead, for a policy's ``clock``: a
    request then spends its time budget without the time passing.
    """

    def __init__(self) -> None:
        self.waits: list[float] = []
        self.slept = 0.0

    async def __call__(self, seconds: float) -> None:
        self.waits.append(seconds)
        self.slept += seconds
        await asyncio.sleep(0)

    def now(self) -> float:
        return self.slept


@pytest.fixture
def sleep() -> RecordingSleep:
    return RecordingSleep()


@pytest.fixture
def fast_policy(sleep: RecordingSleep) -> RetryPolicy:
    """The production rules (Retry-After honoured) without the waiting; as no time passes,
    six attempts stand in for the time budget."""
    return RetryPolicy(initial_backoff=0, sleep=sleep, request_timeout=2.0, max_attempts=6)


@pytest.fixture(autouse=True)
def _fresh_structlog() -> Iterator[None]:
    structlog.reset_defaults()
    yield
    structlog.reset_defaults()
