"""The steps of a request that both origins share, around their own checks and handlers.

`admit` (outage, latency, rate limit) comes before an origin's own checks (token,
signature); then the handler runs, through `apply_fault` when a fault is due; and
`record_response` counts what the client sees last. JSON answers live here too: an
outage or a rate limit answers in JSON on either origin.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Awaitable, Callable
from typing import Any

import orjson
from aiohttp import web
from aiohttp.typedefs import Middleware

from stook.emulator import _json
from stook.emulator._config import Origin
from stook.emulator._faults import Fault, FaultKind
from stook.emulator._state import EmulatorState
from stook.emulator._stats import EmulatorStats

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


def json_response(
    body: Any, status: int = 200, headers: dict[str, str] | None = None
) -> web.Response:
    # orjson: the stdlib encoder was a quarter of the emulator's CPU per listing, and the
    # emulator shares the benchmark machine's two cores with the client it serves.
    return json_bytes_response(orjson.dumps(body), status, headers)


def json_bytes_response(
    body: bytes, status: int = 200, headers: dict[str, str] | None = None
) -> web.Response:
    """An answer of JSON already serialized (`body`), as `json_response` sends it."""
    return web.Response(
        body=body,
        status=status,
        content_type="application/json",
        headers=headers,
    )


def error_response(
    status: int, message: str, headers: dict[str, str] | None = None
) -> web.Response:
    return json_response(_json.error(status, message), status, headers)


async def apply_fault(
    request: web.Request, fault: Fault, handler: Handler, stats: EmulatorStats, origin: str
) -> web.StreamResponse:
    """The answer a request meets under `fault`, the handler's only if it is truncated."""
    stats.faults[f"{origin}:{fault.kind.value}"] += 1
    if fault.kind is FaultKind.SERVER_ERROR:
        return error_response(fault.status, "injected transient server error")
    if fault.kind is FaultKind.RATE_LIMITED:
        return error_response(429, "injected rate limit", {"Retry-After": str(fault.retry_after_s)})
    if fault.kind is FaultKind.RESET:
        if request.transport is not None:
            request.transport.abort()
        # Nothing reaches the client any more; this only ends the handler.
        return web.Response(status=500)
    # Truncated: promise the whole body, send half of it, then drop the connection.
    full = await handler(request)
    body = full.body if isinstance(full, web.Response) and isinstance(full.body, bytes) else b""
    if full.status != 200 or not body:
        return full
    partial = web.StreamResponse(status=200, headers={"Content-Type": full.content_type})
    partial.content_length = len(body)
    await partial.prepare(request)
    await partial.write(body[: len(body) // 2])
    stats.bytes_served[origin] += len(body) // 2
    if request.transport is not None:
        request.transport.close()
    return partial


def route_name(request: web.Request) -> str:
    route = request.match_info.route
    return route.name or ("unknown" if route.resource is None else route.resource.canonical)


async def admit(state: EmulatorState, request: web.Request, origin: Origin) -> web.Response | None:
    """Outages, latency and rate limits, common to both origins; an answer if refused."""
    now = time.monotonic()
    stats = state.stats
    if stats.first_request_at is None:
        stats.first_request_at = now
    stats.requests[origin] += 1
    stats.endpoints[f"{origin}:{route_name(request)}"] += 1
    if origin == "api":
        stats.api_paths[request.path] += 1
    window = state.outages.refuses(origin, stats.requests[origin] - 1, now)
    if window is not None:
        # Before the latency: a load balancer with nothing behind it answers at once.
        stats.outage_refusals[origin] += 1
        if window not in stats.outage_windows:
            stats.outage_windows.append(window)
        return error_response(503, "service unavailable (emulated outage)")
    delay = state.latency.next_delay()
    if delay > 0:
        state.in_latency[origin] += 1
        stats.peak_in_latency[origin] = max(stats.peak_in_latency[origin], state.in_latency[origin])
        try:
            await asyncio.sleep(delay)
        finally:
            state.in_latency[origin] -= 1
    bucket = state.buckets.get(origin)
    if bucket is not None:
        wait = bucket.take(state.now())
        if wait > 0:
            stats.rate_limited[origin] += 1
            return error_response(429, "rate limit exceeded", {"Retry-After": str(math.ceil(wait))})
    return None


def record_response(
    stats: EmulatorStats, origin: str, response: web.StreamResponse, fault: Fault | None = None
) -> web.StreamResponse:
    """Counts `response` in the origin's statistics and returns it."""
    # A reset or truncated answer never arrives whole; count it as what the client sees.
    broken = fault is not None and fault.kind in (FaultKind.RESET, FaultKind.TRUNCATED)
    label = fault.kind.value if broken and fault is not None else str(response.status)
    stats.statuses[f"{origin}:{label}"] += 1
    if broken:
        return response
    if isinstance(response, web.Response) and isinstance(response.body, bytes):
        stats.bytes_served[origin] += len(response.body)
    return response


def in_flight_limit(state: EmulatorState, origin: Origin) -> tuple[Middleware, ...]:
    """`max_in_flight`'s middleware for `origin`'s app, outermost; none when unlimited.

    The count is shared by both origins (one server's capacity) and covers a request from
    its arrival to its answer, latency included: beyond the limit the answer is a 429 with
    Retry-After, at once.
    """
    limit = state.config.max_in_flight
    if limit is None:
        return ()

    @web.middleware
    async def limited(request: web.Request, handler: Handler) -> web.StreamResponse:
        if state.in_flight >= limit:
            state.stats.requests[origin] += 1
            state.stats.rate_limited[origin] += 1
            refused = error_response(429, "too many requests in flight", {"Retry-After": "1"})
            return record_response(state.stats, origin, refused)
        state.in_flight += 1
        try:
            return await handler(request)
        finally:
            state.in_flight -= 1

    return (limited,)
