"""The object-storage client: presigned URLs fetched with retries and no credentials at all;
it follows redirects itself, each hop through its transport, so that no host gets a token."""

from __future__ import annotations

import re
from typing import Final, Self

from yarl import URL

from stook.service.api._config import (
    DEFAULT_CONCURRENCY,
    DEFAULT_MAX_BODY_MB,
    BodyCap,
    RetryPolicy,
    body_cap_mb,
)
from stook.service.api._errors import PresignedUrlExpiredError, StorageError
from stook.service.api._limits import ConcurrencyLimit
from stook.service.api._redact import redact_url
from stook.service.api._retry import (
    RETRYABLE_STATUSES,
    Origin,
    parse_retry_after,
    send,
)
from stook.service.api._transport import (
    USER_AGENT,
    HttpTransport,
    Response,
    TrafficCounts,
    Transport,
)

_REDIRECT_STATUSES: Final = frozenset({301, 302, 303, 307, 308})
_MAX_REDIRECTS: Final = 5
_ERROR_CODE: Final = re.compile(rb"<Code>\s*([A-Za-z0-9_.-]{1,64})\s*</Code>")
_EXPIRED_CODES: Final = frozenset({b"ExpiredToken", b"AccessDenied", b"RequestExpired"})


class StorageClient:
    """Fetches presigned object-storage URLs, with retries and without any credentials.

    Usually an :class:`ApiClient`'s (``api.storage``); alone, ``async with StorageClient() as
    storage: await storage.fetch_bytes(url)``. ``limiter`` bounds the fetches in flight; a
    ``transport`` passed in brings its own limiter, timeout and body cap, and no credentials.
    """

    def __init__(
        self,
        *,
        concurrency: int = DEFAULT_CONCURRENCY,
        retry: RetryPolicy | None = None,
        limiter: ConcurrencyLimit | None = None,
        body_cap: BodyCap | None = None,
        transport: Transport | None = None,
    ) -> None:
        policy = retry or RetryPolicy()
        # Shared by every storage request: when storage fails, they wait together.
        self.origin = Origin("object storage", policy, setting="the URLs the API listed")
        self._transport = transport or HttpTransport(
            name="storage",
            body_cap=body_cap or body_cap_mb(DEFAULT_MAX_BODY_MB, "max_body_mb"),
            concurrency=concurrency,
            request_timeout=policy.request_timeout,
            headers={"User-Agent": USER_AGENT},
            follow_redirects=False,
            credentials_allowed=False,
            limiter=limiter,
        )
        self.stats: TrafficCounts = self._transport.stats

    async def __aenter__(self) -> Self:
        await self._transport.open()
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self._transport.close()

    async def fetch_bytes(self, url: str) -> bytes:
        """The whole object behind a presigned URL; :class:`PresignedUrlExpiredError` when
        storage refuses the signature (list again for a fresh URL)."""
        # encoded=True: re-quoting would alter the signed query string and void the signature.
        target = URL(url, encoded=True)
        if target.scheme not in ("http", "https") or not target.raw_host:
            raise StorageError("not an http(s) URL", url=url)
        return await send(
            lambda: self._fetch_once(target), self.origin, url=target, stats=self.stats
        )

    async def _fetch_once(self, url: URL) -> bytes:
        hops = 0  # redirects followed, each hop sent through the transport to be checked
        while True:
            response = await self._transport.get(url)
            if response.ok:
                return response.body
            location = response.headers.get("Location")
            if response.status not in _REDIRECT_STATUSES or not location:
                raise _storage_error(response)
            if hops == _MAX_REDIRECTS:
                raise StorageError(f"more than {hops} redirects from object storage", url=url)
            url = url.join(URL(location, encoded=True))
            hops += 1


def answer_retry_after(response: Response) -> float | None:
    """The pause a throttling or failing answer asked for (``Retry-After``), if any."""
    if response.status not in RETRYABLE_STATUSES:
        return None
    return parse_retry_after(response.headers.get("Retry-After"))


def _storage_error(response: Response) -> StorageError:
    """A storage refusal; of its body only the error code is kept (S3's echo the signature)."""
    match = _ERROR_CODE.search(response.body[:4096])
    code = match.group(1) if match else None
    status = response.status
    said = f"GET {redact_url(response.url)} answered HTTP {status}"
    if code:
        said += f" ({code.decode()})"
    if status == 403 or (status == 400 and code in _EXPIRED_CODES):
        return PresignedUrlExpiredError(
            f"{said}: the presigned URL has expired or its signature is invalid; list again "
            "for a fresh URL",
            url=response.url,
            status=status,
        )
    if status == 404:
        message = "no such object"
    elif status in RETRYABLE_STATUSES:
        message = "object storage is unavailable or throttling"
    else:
        message = "object storage refused the request"
    retry_after = answer_retry_after(response)
    return StorageError(
        f"{said}: {message}", url=response.url, status=status, retry_after=retry_after
    )
