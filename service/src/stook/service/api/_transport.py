"""The transport: one aiohttp session that sends a GET and returns the whole answer.

It knows nothing of JSON, paging, retries or what a status code means; the clients build
those on top. What it guarantees:

* at most as many requests in flight as its limiter allows, and each request's timeout
  starts only once it holds a slot, so queued requests do not time out while they wait;
* a body shorter than its ``Content-Length`` is an error, and one longer than the
  transport's :class:`BodyCap` (counted after decompression) is an error as soon as the
  cap is passed;
* every failure leaves as a :class:`TransportError` with a redacted message, made in one
  place (:func:`transport_error`), never as an aiohttp exception whose text could hold a
  presigned URL;
* a transport built with ``credentials_allowed=False`` (object storage) never sends an
  ``Authorization`` header, URL user info or ``.netrc`` credentials.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import time
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import TracebackType
from typing import Final, Protocol, Self

import aiohttp
from aiohttp import hdrs
from multidict import CIMultiDictProxy
from yarl import URL

from stook.service.api._errors import (
    BodyTooLargeError,
    FailureKind,
    IncompleteBodyError,
    TransportError,
)
from stook.service.api._limits import ConcurrencyLimit, FixedLimit
from stook.service.api._logging import get_logger
from stook.service.api._redact import redact_text, redact_url

__all__ = [
    "USER_AGENT",
    "BodyCap",
    "HttpTransport",
    "Response",
    "TransferStats",
    "Transport",
    "body_cap_mb",
    "transport_error",
]

_log = get_logger("stook.service.http")

USER_AGENT: Final = "stook/0.1 (+aiohttp)"
_MAX_REDIRECTS: Final = 5
_NO_BODY_STATUSES: Final = frozenset({204, 304})
_CREDENTIAL_HEADERS: Final = frozenset({"authorization", "proxy-authorization"})


@dataclass(frozen=True, slots=True)
class BodyCap:
    """The most bytes one answer's body may hold once decompressed, and the setting for it."""

    max_bytes: int
    setting: str  # named in the error, so the reader knows what to raise

    def __post_init__(self) -> None:
        if self.max_bytes < 1:
            raise ValueError(f"a body cap must be at least 1 byte, got {self.max_bytes}")


def body_cap_mb(megabytes: float, setting: str) -> BodyCap:
    """The cap of a ``[fetch]`` setting given in megabytes (MiB)."""
    return BodyCap(max(1, int(megabytes * 2**20)), f"[fetch] {setting}")


@dataclass(frozen=True, slots=True)
class Response:
    """A complete answer: status, headers and the whole body."""

    status: int
    headers: CIMultiDictProxy[str]
    body: bytes
    # The final URL after redirects; kept out of repr because it may be presigned.
    url: URL = field(repr=False)

    @property
    def ok(self) -> bool:
        return 200 <= self.status < 300


@dataclass(slots=True)
class TransferStats:
    """Counters of one client's traffic; one event loop updates them, so no lock."""

    requests: int = 0
    retries: int = 0
    bytes_received: int = 0
    statuses: Counter[int] = field(default_factory=Counter)
    retry_reasons: Counter[str] = field(default_factory=Counter)

    def as_dict(self) -> dict[str, object]:
        return {
            "requests": self.requests,
            "retries": self.retries,
            "bytes_received": self.bytes_received,
            "statuses": dict(sorted(self.statuses.items())),
            "retry_reasons": dict(self.retry_reasons),
        }


class Transport(Protocol):
    """What a client needs from its transport: :class:`HttpTransport`, or a stand-in
    (as httpx takes ``transport=``)."""

    stats: TransferStats

    async def open(self) -> None: ...

    async def close(self) -> None: ...

    async def get(self, url: URL) -> Response: ...


class HttpTransport:
    """An aiohttp session for up to ``concurrency`` parallel GETs; ``async with`` opens it.

    ``limiter`` bounds the requests in flight (a :class:`FixedLimit` of ``concurrency`` by
    default); one shared with another transport makes one bound for both.
    """

    def __init__(
        self,
        *,
        name: str,
        concurrency: int,
        request_timeout: float,
        stats: TransferStats | None = None,
        headers: Mapping[str, str] | None = None,
        follow_redirects: bool = True,
        credentials_allowed: bool = True,
        limiter: ConcurrencyLimit | None = None,
        proxy_for: URL | None = None,
        body_cap: BodyCap | None = None,
    ) -> None:
        if concurrency < 1:
            raise ValueError(f"concurrency must be at least 1, got {concurrency}")
        self._headers = dict(headers or {})
        if not credentials_allowed and _CREDENTIAL_HEADERS & {k.lower() for k in self._headers}:
            raise ValueError(f"{name} transport must not carry credential headers")
        self.name = name
        self.stats = TransferStats() if stats is None else stats
        self.limiter: ConcurrencyLimit = limiter or FixedLimit(concurrency)
        self._concurrency = concurrency
        self._timeout = request_timeout
        self._follow_redirects = follow_redirects
        self._credentials_allowed = credentials_allowed
        self._proxy_for = proxy_for
        self._body_cap = body_cap
        self._session: aiohttp.ClientSession | None = None
        self._debug = False

    async def __aenter__(self) -> Self:
        await self.open()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    async def open(self) -> None:
        """Open the session; `get` needs it open."""
        # Asked once, not per request: the level does not change during a run, and the
        # debug line costs a redact_url per request.
        self._debug = _log.is_enabled_for(logging.DEBUG)
        self._session = aiohttp.ClientSession(
            connector=aiohttp.TCPConnector(limit=self._concurrency, limit_per_host=0),
            headers=self._headers,
            # The timeout is the limiter's slot's (see `get`), not aiohttp's: aiohttp's
            # would count the wait for a pooled connection too.
            timeout=aiohttp.ClientTimeout(total=None),
            # trust_env would attach ~/.netrc credentials to storage requests, and look up
            # netrc and the proxy variables on every request; the API's proxy, if any, is
            # looked up once here instead.
            trust_env=False,
            proxy=_env_proxy(self._proxy_for) if self._proxy_for is not None else None,
            # No request needs a cookie: none is kept, so none travels to another host.
            cookie_jar=aiohttp.DummyCookieJar(),
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
        if not self._credentials_allowed and (
            url.raw_user is not None or url.raw_password is not None
        ):
            # aiohttp would turn user info into a Basic Authorization header.
            url = url.with_user(None)
        await self.limiter.acquire()
        started = time.monotonic()
        status: int | None = None
        try:
            self.stats.requests += 1
            async with asyncio.timeout(self._timeout):
                # Awaited, not entered with `async with`: aiohttp's context manager is a
                # frame more in every resumption of the request, and all a GET's answer
                # needs is a release unless its body was read to the end (which closed it
                # and gave its connection back; releasing it again would still mark its
                # stream with a "connection closed" error, a few µs a request).
                answer = await session.get(
                    url,
                    allow_redirects=self._follow_redirects,
                    max_redirects=_MAX_REDIRECTS,
                )
                try:
                    body = await self._read(answer)
                finally:
                    if not answer.closed:
                        answer.release()
                response = Response(answer.status, answer.headers, body, answer.url)
            status = response.status
        except TransportError:
            raise
        except (aiohttp.ClientError, OSError, TimeoutError) as exc:
            raise transport_error(exc, url, self._timeout) from None
        finally:
            # The outcome goes back with the slot: an adaptive limit learns from it.
            self.limiter.release(status, time.monotonic() - started)
        self.stats.statuses[status] += 1
        self.stats.bytes_received += len(body)
        if self._debug:
            _log.debug(
                "http response",
                transport=self.name,
                url=redact_url(response.url),
                status=status,
                bytes=len(body),
                ms=round((time.monotonic() - started) * 1000, 1),
            )
        return response

    async def _read(self, answer: aiohttp.ClientResponse) -> bytes:
        """The whole body: BodyTooLargeError once more than the cap arrived (counted after
        decompression, so a small gzip bomb stops at the cap too), IncompleteBodyError
        when it ends before its ``Content-Length``."""
        cap = self._body_cap
        declared = answer.content_length
        if answer.status in _NO_BODY_STATUSES or hdrs.CONTENT_ENCODING in answer.headers:
            declared = None  # no body whatever it says, or a count of compressed bytes
        if declared is not None and (cap is None or declared <= cap.max_bytes):
            try:  # aiohttp ends the body at its length: exactly that many bytes, at once
                return await answer.content.readexactly(declared)
            except asyncio.IncompleteReadError as short:
                raise IncompleteBodyError(
                    method="GET", url=answer.url, received=len(short.partial), expected=declared
                ) from None
        chunks: list[bytes] = []
        size = 0 if declared is None else declared  # a declared size past the cap: no read
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
    """The one place where what aiohttp and sockets raise becomes stook's error: a
    redacted reason, and what kind of failure it was (see `FailureKind`)."""
    if isinstance(exc, TimeoutError):
        return TransportError(
            method="GET", url=url, reason=f"timed out after {timeout:g} s", kind="timeout"
        )
    kind: FailureKind
    if isinstance(exc, aiohttp.ClientSSLError | aiohttp.InvalidURL | aiohttp.TooManyRedirects):
        kind = "permanent"  # a certificate, URL or redirect loop does not heal
    elif isinstance(exc, aiohttp.ClientConnectorError) and isinstance(
        exc.os_error, socket.gaierror
    ):
        kind = "dns"
    elif isinstance(exc, aiohttp.ClientConnectorError):
        kind = "connect"  # refused, unreachable: no connection was made
    elif isinstance(exc, aiohttp.ClientConnectionError | aiohttp.ClientPayloadError | OSError):
        kind = "broken"  # reset, disconnected, truncated: a connection was made
    else:
        kind = "permanent"
    text = redact_text(str(exc))
    reason = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return TransportError(method="GET", url=url, reason=reason, kind=kind)


def _env_proxy(url: URL) -> URL | None:
    """The proxy that HTTP(S)_PROXY / NO_PROXY name for `url`, if any."""
    try:
        proxy, _auth = aiohttp.helpers.get_env_proxy_for_url(url)
    except LookupError:
        return None
    return proxy
