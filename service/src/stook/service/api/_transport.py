"""One aiohttp session that sends a GET and returns the whole answer, any status: timed from
when it holds a slot of its limiter, its body capped after decompression, aiohttp's failures
turned into :class:`TransportError` (here only), and no credentials at all to storage."""

from __future__ import annotations

import asyncio
import logging
import socket
import time
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Final, Protocol, Self

import aiohttp
import structlog
from aiohttp import hdrs
from multidict import CIMultiDictProxy
from yarl import URL

from stook.service.api._config import BodyCap
from stook.service.api._errors import BodyTooLargeError, FailureKind, TransportError
from stook.service.api._limits import ConcurrencyLimit, FixedLimit
from stook.service.api._redact import redact_text, redact_url

_log = structlog.get_logger("stook.service.http")

USER_AGENT: Final = "stook/0.1 (+aiohttp)"
_NO_BODY_STATUSES: Final = frozenset({204, 304})


@dataclass(frozen=True, slots=True)
class Response:
    """A complete answer; ``url`` (after redirects, maybe presigned) is kept out of repr."""

    status: int
    headers: CIMultiDictProxy[str]
    body: bytes
    url: URL = field(repr=False)

    @property
    def ok(self) -> bool:
        return 200 <= self.status < 300


@dataclass(slots=True)
class TrafficCounts:
    """Counters of one client's traffic (one event loop updates them: no lock)."""

    requests: int = 0
    retries: int = 0
    bytes_received: int = 0
    statuses: Counter[int] = field(default_factory=Counter)  # read by `stook bench --probe`


class Transport(Protocol):
    """What a client needs from its transport: :class:`HttpTransport` or a stand-in."""

    stats: TrafficCounts

    async def open(self) -> None: ...

    async def close(self) -> None: ...

    async def get(self, url: URL) -> Response: ...


@dataclass(kw_only=True, eq=False, repr=False)  # no repr: the headers hold the token
class HttpTransport:
    """An aiohttp session for up to ``concurrency`` parallel GETs; ``async with`` opens it.
    ``limiter`` (by default a :class:`FixedLimit` of ``concurrency``) may be shared."""

    name: str
    concurrency: int
    request_timeout: float
    headers: Mapping[str, str] = field(default_factory=dict)
    follow_redirects: bool = True
    credentials_allowed: bool = True  # False (storage): no token, user info or .netrc
    limiter: ConcurrencyLimit | None = None
    proxy_for: URL | None = None
    body_cap: BodyCap | None = None

    def __post_init__(self) -> None:
        if self.concurrency < 1:
            raise ValueError(f"concurrency must be at least 1, got {self.concurrency}")
        names = {name.lower() for name in self.headers}
        if not self.credentials_allowed and names & {"authorization", "proxy-authorization"}:
            raise ValueError(f"{self.name} transport must not carry credential headers")
        self.stats = TrafficCounts()
        self._limit = self.limiter or FixedLimit(self.concurrency)
        self._session: aiohttp.ClientSession | None = None
        self._debug = False

    async def __aenter__(self) -> Self:
        await self.open()
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.close()

    async def open(self) -> None:
        # Asked once: the debug line costs a redact_url per request.
        self._debug = _log.is_enabled_for(logging.DEBUG)
        proxy = self.proxy_for
        self._session = aiohttp.ClientSession(
            connector=aiohttp.TCPConnector(limit=self.concurrency, limit_per_host=0),
            headers=self.headers,
            # The timeout is the slot's (see `get`): aiohttp's would count the wait for one.
            timeout=aiohttp.ClientTimeout(total=None),
            # trust_env would send ~/.netrc credentials to storage and read the environment
            # on every request; the API's proxy is looked up once here instead.
            trust_env=False,
            proxy=None if proxy is None else _env_proxy(proxy),
            cookie_jar=aiohttp.DummyCookieJar(),  # no cookie travels to another host
        )

    async def close(self) -> None:
        session, self._session = self._session, None
        if session is not None:
            await session.close()

    async def get(self, url: URL) -> Response:
        """Send one GET and read the whole body; any status is returned, not raised."""
        session = self._session
        if session is None:
            raise RuntimeError(f"{self.name} transport is not open; use 'async with'")
        if not self.credentials_allowed and (url.raw_user, url.raw_password) != (None, None):
            url = url.with_user(None)  # aiohttp would send user info as Basic auth
        await self._limit.acquire()
        started = time.monotonic()
        status: int | None = None
        try:
            self.stats.requests += 1
            async with asyncio.timeout(self.request_timeout):
                # Awaited, not `async with`: a frame less in every resumption; a body read
                # to its end already gave its connection back.
                answer = await session.get(
                    url, allow_redirects=self.follow_redirects, max_redirects=5
                )
                try:
                    body = await self._read(answer)
                finally:
                    if not answer.closed:
                        answer.release()
                response = Response(answer.status, answer.headers, body, answer.url)
            status = response.status
        except (aiohttp.ClientError, OSError, TimeoutError) as exc:
            raise transport_error(exc, url, self.request_timeout) from None
        finally:
            self._limit.release(status, time.monotonic() - started)  # an AIMD limit learns
        self.stats.statuses[status] += 1
        self.stats.bytes_received += len(body)
        if self._debug:
            ms = round((time.monotonic() - started) * 1000, 1)
            _log.debug("http response", url=redact_url(response.url), status=status, ms=ms)
        return response

    async def _read(self, answer: aiohttp.ClientResponse) -> bytes:
        """The whole body, capped after decompression (a gzip bomb stops at the cap too)."""
        cap = self.body_cap
        declared = answer.content_length
        if answer.status in _NO_BODY_STATUSES or hdrs.CONTENT_ENCODING in answer.headers:
            declared = None  # no body whatever it says, or a count of compressed bytes
        if declared is not None and (cap is None or declared <= cap.max_bytes):
            try:  # aiohttp ends the body at its length: exactly that many bytes, at once
                return await answer.content.readexactly(declared)
            except asyncio.IncompleteReadError as short:
                reason = f"body ended after {len(short.partial)} of {declared} bytes"
                raise TransportError(method="GET", url=answer.url, reason=reason) from None
        chunks: list[bytes] = []
        size = declared or 0  # a declared size past the cap: no read
        while cap is None or size <= cap.max_bytes:
            chunk = await answer.content.readany()
            if not chunk:
                return b"".join(chunks)
            size += len(chunk)
            chunks.append(chunk)
        answer.close()  # not worth reading on: drop the connection instead
        raise BodyTooLargeError(
            method="GET", url=answer.url, cap=cap.max_bytes, setting=cap.setting
        )


def transport_error(exc: BaseException, url: URL, timeout: float) -> TransportError:
    """The one place where what aiohttp and sockets raise becomes stook's error."""
    if isinstance(exc, TimeoutError):
        reason = f"timed out after {timeout:g} s"
        return TransportError(method="GET", url=url, reason=reason, kind="timeout")
    kind: FailureKind = "permanent"  # a certificate, bad URL or redirect loop does not heal
    if isinstance(exc, aiohttp.ClientSSLError | aiohttp.InvalidURL | aiohttp.TooManyRedirects):
        pass
    elif isinstance(exc, aiohttp.ClientConnectorError):
        kind = "dns" if isinstance(exc.os_error, socket.gaierror) else "connect"
    elif isinstance(exc, aiohttp.ClientConnectionError | aiohttp.ClientPayloadError | OSError):
        kind = "broken"  # reset, disconnected, truncated: a connection was made
    text = redact_text(str(exc))
    reason = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return TransportError(method="GET", url=url, reason=reason, kind=kind)


def _env_proxy(url: URL) -> URL | None:
    """The proxy that HTTP(S)_PROXY / NO_PROXY name for `url`, if any."""
    try:
        return aiohttp.helpers.get_env_proxy_for_url(url)[0]
    except LookupError:
        return None
