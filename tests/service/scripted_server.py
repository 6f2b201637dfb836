"""A real aiohttp server on 127.0.0.1 whose answers each test scripts, path by path.

Every request is recorded (path, query, headers) so tests can count attempts and check
exactly which headers went over the wire.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from aiohttp import web
from aiohttp.test_utils import TestServer
from multidict import CIMultiDictProxy

Responder = Callable[[web.Request], Awaitable[web.StreamResponse]]


@dataclass(frozen=True)
class Seen:
    path: str
    query: dict[str, str]
    headers: CIMultiDictProxy[str]


@dataclass
class ScriptedServer:
    """Answers each path with its responders in order; the last one repeats."""

    server: TestServer | None = None
    routes: dict[str, list[Responder]] = field(default_factory=dict)
    seen: list[Seen] = field(default_factory=list)
    in_flight: int = 0
    max_in_flight: int = 0

    def script(self, path: str, *responders: Responder) -> None:
        self.routes[path] = list(responders)

    def url(self, path: str) -> str:
        assert self.server is not None
        return str(self.server.make_url(path))

    @property
    def base_url(self) -> str:
        return self.url("/v1")

    def hits(self, path: str) -> list[Seen]:
        return [seen for seen in self.seen if seen.path == path]

    async def handle(self, request: web.Request) -> web.StreamResponse:
        self.seen.append(Seen(request.path, dict(request.query), request.headers))
        responders = self.routes.get(request.path)
        if not responders:
            return web.Response(status=404, text=f"unscripted path {request.path}")
        responder = responders.pop(0) if len(responders) > 1 else responders[0]
        self.in_flight += 1
        self.max_in_flight = max(self.max_in_flight, self.in_flight)
        try:
            return await responder(request)
        finally:
            self.in_flight -= 1


# -- responders ------------------------------------------------------------------------


def answer_json(document: Any, *, status: int = 200) -> Responder:
    async def respond(_request: web.Request) -> web.StreamResponse:
        return web.json_response(document, status=status)

    return respond


def answer(
    status: int = 200,
    body: bytes = b"",
    headers: Mapping[str, str] | None = None,
    delay: float = 0.0,
) -> Responder:
    async def respond(_request: web.Request) -> web.StreamResponse:
        if delay:
            await asyncio.sleep(delay)
        return web.Response(status=status, body=body, headers=dict(headers or {}))

    return respond


def redirect(location: str, status: int = 302) -> Responder:
    return answer(status, headers={"Location": location})


def reset_connection() -> Responder:
    """Close the socket without answering: the client sees the server disconnect."""

    async def respond(request: web.Request) -> web.StreamResponse:
        assert request.transport is not None
        request.transport.close()
        # The response is never written; the handler must still return one.
        return web.Response(status=500)

    return respond


def truncated_body(body: bytes, *, claimed_length: int) -> Responder:
    """Promise ``claimed_length`` bytes, send ``body``, then close the connection."""

    async def respond(request: web.Request) -> web.StreamResponse:
        response = web.StreamResponse(status=200)
        response.content_length = claimed_length
        await response.prepare(request)
        await response.write(body)
        assert request.transport is not None
        request.transport.close()
        return response

    return respond


def json_bytes(document: Any) -> bytes:
    return json.dumps(document).encode()
