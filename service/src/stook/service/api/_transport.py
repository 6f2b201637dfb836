"""The transport layer: one aiohttp session that sends a GET and returns the whole answer.

It knows nothing of JSON, paging, retries or what a status code means; the clients in
:mod:`stook.service.api._client` build those on top. What it does guarantee:

* at most ``concurrency`` requests in flight (or what a shared limiter allows), and the
  per-attempt timeout starts only once a request holds one of those slots, so thousands of
  queued fetches do not time out while waiting for a pooled connection;
* a body shorter than its ``Content-Length`` is an error, not silently short data;
* a body longer than the transport's :class:`BodyCap` (counted after decompression) is an
  error as soon as the cap is passed, so a hostile or broken server cannot fill memory;
* every failure leaves as a :class:`TransportError` with a redacted message, never as an
  aiohttp exception whose text could hold a presigned URL, and with ``retryable`` saying
  whether it may heal (:func:`is_transient_transport_failure`): the retry policy above
  asks the error, it does not classify aiohttp's exceptions itself;
* a transport built with ``credentials_allowed=False`` (object storage) refuses to send any
  ``Authorization`` header, URL user info, or ``.netrc`` credentials.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import TracebackType
from typing import TYPE_CHECKING, Any, Final, Protocol, Self

from multidict import CIMultiDictProxy
from yarl import URL

from stook.service.api._deadlines import Deadlines
from stook.service.api._errors import BodyTooLargeError, IncompleteBodyError, TransportError
from stook.service.api._limits import ConcurrencyLimit, FixedLimit
from stook.service.api._logging import get_logger
from stook.service.api._redact import redact_text, redact_url
from stook.service.api._stats import TransferStats
from stook.service.api._tls import transport_tls

if TYPE_CHECKING:
    # aiohttp (~0.1 s to import) is imported by the functions that use it, so that
    # importing stook.service (`stook --help`) does not pay for it.
    import aiohttp

__all__ = [
    "USER_AGENT",
    "BodyCap",
    "HttpTransport",
    "Response",
    "Transport",
    "body_cap_mb",
    "is_transient_transport_failure",
]

_log = get_logger("stook.service.http")

USER_AGENT: Final = "stook/0.1 (+aiohttp)"

_KEEPALIVE_S: Final = 30.0
_DNS_CACHE_S: Final = 300
_MAX_API_REDIRECTS: Final = 5
_NO_BODY_STATUSES: Final = frozenset({204, 304})
_CREDENTIAL_HEADERS: Final = ("Authorization", "Proxy-Authorization")


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


class Transport(Protocol):
    """What a client needs from its transport: :class:`HttpTransport`, or a stand-in.

    A client takes one as ``transport=`` (as httpx takes ``transport=`` and aiohttp
    ``connector=``); it opens it, sends its GETs through it and closes it. ``stats`` are
    the counters the client reports (the retry loop adds its retries there). The API
    client sends each request's query in its URL, not as ``params``.
    """

    stats: TransferStats

    async def open(self) -> None: ...

    async def close(self) -> None: ...

    async def get(
        self,
        url: URL,
        *,
        params: Mapping[str, str | int] | None = None,
        headers: Mapping[str, str] | None = None,
    ) -> Response: ...


class HttpTransport:
    """An aiohttp session sized for ``concurrency`` parallel GETs, opened as a context manager.

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
        if not credentials_allowed and any(
            key.lower() in {"authorization", "proxy-authorization"} for key in self._headers
        ):
            raise ValueError(f"{name} transport must not carry credential headers")
        self.name = name
        self.stats = TransferStats() if stats is None else stats
        self._concurrency = concurrency
        self._timeout = request_timeout
        self._follow_redirects = follow_redirects
        self._credentials_allowed = credentials_allowed
        # A limiter shared with another transport makes one bound for both.
        self._limiter: ConcurrencyLimit = limiter or FixedLimit(concurrency)
        self._session: aiohttp.ClientSession | None = None
        self._deadlines: Deadlines | None = None  # while open
        self._loop: asyncio.AbstractEventLoop | None = None  # the loop it was opened on
        self._debug = False
        self._proxy = _env_proxy(proxy_for) if proxy_for is not None else None
        self._body_cap = body_cap
        # What every GET passes aiohttp, fixed per transport (written out in `get` for a GET
        # without params or headers). Only options that differ from aiohttp's defaults: each
        # keyword is bound again on every request.
        self._options: dict[str, Any] = (
            {"max_redirects": _MAX_API_REDIRECTS}
            if follow_redirects
            else {"allow_redirects": False}
        )
        # A fixed limit's free slot is taken without a coroutine (see FixedLimit.try_acquire).
        self._fixed_limit = self._limiter if type(self._limiter) is FixedLimit else None

    @property
    def limiter(self) -> ConcurrencyLimit:
        """The bound on this transport's requests in flight; its ``stats`` say what it did."""
        return self._limiter

    async def __aenter__(self) -> Self:
        await self.open()
        return self

    async def open(self) -> None:
        """Open the session; `get` needs it open. ``async with`` opens and closes it."""
        # Asked once per session, not per request: structlog's lazy logger binds a new
        # logger on every call (2% of the client's CPU at 0 ms), and debug logging costs a
        # redact_url per request. The log level does not change during a run.
        import aiohttp

        self._debug = _log.is_enabled_for(logging.DEBUG)
        self._loop = asyncio.get_running_loop()
        self._deadlines = Deadlines(self._loop, self._timeout)
        connector = aiohttp.TCPConnector(
            limit=self._concurrency,
            # No bound per host: one as large as the total could never bind first, and
            # aiohttp would count each host's connections on every request.
            limit_per_host=0,
            keepalive_timeout=_KEEPALIVE_S,
            ttl_dns_cache=_DNS_CACHE_S,
            # aiohttp's default, or stook's own context when the `stook` command imported
            # aiohttp without its defaults (see _tls): the same verification either way.
            ssl=transport_tls(),
        )
        self._session = aiohttp.ClientSession(
            connector=connector,
            headers=self._headers,
            # The total per attempt is enforced around the request (see get), and it covers
            # a stalled connect or read too: aiohttp's sock_connect and sock_read at the same
            # length could never fire first, and cost a timer per read (~2% of the CPU).
            timeout=aiohttp.ClientTimeout(total=None),
            raise_for_status=False,
            # trust_env would read ~/.netrc and attach its credentials to storage requests,
            # and, on every request, look up netrc and the proxy variables in a thread
            # (measured: over half of the client's CPU per request). The API's proxy, if
            # any, is looked up once below instead.
            trust_env=False,
            proxy=self._proxy,
            auto_decompress=True,
            # No API or presigned storage request needs a cookie: none is kept, so none
            # can travel to another host or request.
            cookie_jar=aiohttp.DummyCookieJar(),
        )

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    async def close(self) -> None:
        if self._deadlines is not None:
            self._deadlines.close()
            self._deadlines = None
        session, self._session = self._session, None
        if session is not None:
            await session.close()

    async def get(
        self,
        url: URL,
        *,
        params: Mapping[str, str | int] | None = None,
        headers: Mapping[str, str] | None = None,
    ) -> Response:
        """Send one GET and read the whole body; any status is returned, not raised."""
        import aiohttp

        session = self._session
        deadlines = self._deadlines
        if session is None or deadlines is None:
            raise RuntimeError(f"{self.name} transport is not open; use 'async with'")
        # The session's own headers were checked when the transport was built; per request
        # only what can vary: headers passed in, and user info in the URL.
        if not self._credentials_allowed and (
            headers is not None or url.raw_user is not None or url.raw_password is not None
        ):
            url = self._without_credentials(url, headers)
        started = time.perf_counter() if self._debug else 0.0  # only the debug line says
        fixed = self._fixed_limit
        if fixed is None or not fixed.try_acquire():
            await self._limiter.acquire()
        # How long the slot was held: what an adaptive limit learns from; a fixed one, nothing.
        held_from = 0.0 if fixed is not None else time.perf_counter()
        status: int | None = None
        # The per-attempt timeout, in this frame rather than a coroutine of its own (one
        # layer fewer for every resumption of the request). What ``asyncio.timeout`` does,
        # on the transport's one timer (see _deadlines): when the deadline passes it
        # cancels this task, and the cancellation it sent, and only that one, becomes a
        # TimeoutError.
        try:
            self.stats.requests += 1
            task = asyncio.current_task(self._loop)  # the loop passed: one lookup fewer
            assert task is not None  # a transport is used from a task
            cancelling = task.cancelling()
            deadlines.start(task)
            try:
                # Awaited, not entered: `async with` adds three coroutines a request and a
                # layer to every resumption; leaving it only releases the answer (a GET has
                # no body writer to wait for), as the `finally` below does. The clients
                # send their queries in the URL: no params or headers to pass on, and the
                # option written out (a dict unpacked into the call costs 1,300 instructions).
                if params is not None or headers is not None:
                    answer = await session.get(url, params=params, headers=headers, **self._options)
                elif self._follow_redirects:
                    answer = await session.get(url, max_redirects=_MAX_API_REDIRECTS)
                else:
                    answer = await session.get(url, allow_redirects=False)
                try:
                    # Read once: aiohttp parses the header on each read.
                    declared = answer.content_length
                    cap = self._body_cap
                    if (
                        declared is not None
                        and (cap is None or declared <= cap.max_bytes)
                        and answer.status not in _NO_BODY_STATUSES
                        and "Content-Encoding" not in answer.headers
                    ):
                        # The length counts what the body holds, and aiohttp's parser ends
                        # the body there: exactly that many bytes, read from the stream in
                        # one call. Not ClientResponse.read: it reads until the end, in two
                        # coroutines more, to keep the body on the answer (the Response
                        # keeps it) and return the connection (the end of the body does).
                        try:
                            body = await answer.content.readexactly(declared)
                        except asyncio.IncompleteReadError as short:
                            raise _incomplete(answer, short, declared) from None
                    elif cap is None:
                        body = await answer.content.read()
                    else:
                        body = await self._read_capped(answer, declared, cap)
                    response = Response(answer.status, answer.headers, body, answer.url)
                finally:
                    # An answer read to its end is closed already: aiohttp gave its
                    # connection back as the body ended. Any other is released here.
                    if not answer.closed:
                        answer.release()
            except BaseException as exc:
                # As asyncio.timeout: take back the cancellation the timer sent, and make it
                # a TimeoutError unless the task was also cancelled from outside.
                if (
                    deadlines.end(task)
                    and task.uncancel() <= cancelling
                    and isinstance(exc, asyncio.CancelledError)
                ):
                    raise TimeoutError from None
                raise
            if deadlines.end(task):  # fired, but the cancellation never arrived
                task.uncancel()
            status = response.status
        except TimeoutError:
            raise TransportError(
                method="GET", url=url, reason=f"timed out after {self._timeout:g} s"
            ) from None
        except aiohttp.ClientError as exc:
            raise TransportError(
                method="GET",
                url=url,
                reason=_describe(exc),
                retryable=is_transient_transport_failure(exc),
            ) from None
        except OSError as exc:
            raise TransportError(method="GET", url=url, reason=_describe(exc)) from None
        finally:
            # The outcome goes back with the slot: an adaptive limit learns from it.
            if fixed is not None:
                fixed.release(status, 0.0)
            else:
                self._limiter.release(status, time.perf_counter() - held_from)
        stats = self.stats
        stats.statuses[response.status] += 1
        stats.bytes_received += len(response.body)
        if self._debug:
            _log.debug(
                "http response",
                transport=self.name,
                url=redact_url(response.url),
                status=response.status,
                bytes=len(response.body),
                ms=round((time.perf_counter() - started) * 1000, 1),
            )
        return response

    async def _read_capped(
        self, answer: aiohttp.ClientResponse, declared: int | None, cap: BodyCap
    ) -> bytes:
        """The whole body, or BodyTooLargeError once more than the cap has arrived (or as
        soon as the answer declares more, when its ``Content-Length`` counts what it holds).

        aiohttp decompresses as it streams, so what is counted here is the decompressed
        size: a small gzip answer that inflates without end is stopped at the cap too.
        """
        if (
            declared is not None
            and declared > cap.max_bytes
            and "Content-Encoding" not in answer.headers
        ):
            answer.close()  # not worth reading: drop the connection instead
            raise BodyTooLargeError(
                method="GET", url=answer.url, cap=cap.max_bytes, setting=cap.setting
            )
        chunks: list[bytes] = []
        size = 0
        async for chunk in answer.content.iter_any():
            size += len(chunk)
            if size > cap.max_bytes:
                answer.close()
                raise BodyTooLargeError(
                    method="GET", url=answer.url, cap=cap.max_bytes, setting=cap.setting
                )
            chunks.append(chunk)
        return chunks[0] if len(chunks) == 1 else b"".join(chunks)

    def _without_credentials(self, url: URL, headers: Mapping[str, str] | None) -> URL:
        """Refuse, before anything is sent, a storage request that would carry credentials.

        This guards the one property that matters most for storage: the API token never
        leaves for another host. A violation is a programming error, so it stops the run.
        """
        if headers is not None:
            for name in _CREDENTIAL_HEADERS:
                if _has_header(headers, name):
                    raise RuntimeError(f"refusing to send {name} to object storage ({self.name})")
        if url.raw_user is not None or url.raw_password is not None:
            # aiohttp would turn user info into a Basic Authorization header.
            return url.with_user(None)
        return url


def _incomplete(
    answer: aiohttp.ClientResponse, short: asyncio.IncompleteReadError, expected: int
) -> IncompleteBodyError:
    """A body that ended before its ``Content-Length``: an error, never short data."""
    return IncompleteBodyError(
        method="GET", url=answer.url, received=len(short.partial), expected=expected
    )


def _env_proxy(url: URL) -> URL | None:
    """The proxy that HTTP(S)_PROXY / NO_PROXY name for `url`, if any."""
    import aiohttp

    try:
        proxy, _auth = aiohttp.helpers.get_env_proxy_for_url(url)
    except LookupError:
        return None
    return proxy


def _has_header(headers: Mapping[str, str], name: str) -> bool:
    lowered = name.lower()
    return any(key.lower() == lowered for key in headers)


def _describe(exc: BaseException) -> str:
    text = redact_text(str(exc))
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def is_transient_transport_failure(exc: BaseException) -> bool:
    """Whether an aiohttp or socket failure is the kind that heals: reset, refused, timeout."""
    import aiohttp

    if isinstance(exc, aiohttp.ClientSSLError | aiohttp.InvalidURL | aiohttp.TooManyRedirects):
        # A certificate, URL or redirect-loop problem does not heal between attempts.
        return False
    return isinstance(
        exc,
        aiohttp.ClientConnectionError | aiohttp.ClientPayloadError | ConnectionError | TimeoutError,
    )
