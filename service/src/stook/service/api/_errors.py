"""The service's exception types: the API or object storage refused, answered badly, or never
answered.

Every message is one line and safe to print: URLs pass through :func:`redact_url` and any
response text through :func:`redact_text` before it is stored, so neither the bearer token nor
a presigned-URL signature can leak through ``str()``, ``repr()`` or a traceback. For the same
reason third-party exceptions (whose text may hold a full URL) are never chained as
``__cause__``; their class and redacted text are copied into our message instead.
"""

from __future__ import annotations

from typing import Final, Literal

from yarl import URL

from stook.sdk import StookError
from stook.service.api._redact import redact_text, redact_url

__all__ = [
    "ApiError",
    "ApiResponseError",
    "ApiStatusError",
    "AuthError",
    "BodyTooLargeError",
    "FailureKind",
    "IncompleteBodyError",
    "NotFoundError",
    "OriginUnavailableError",
    "OriginUnreachableError",
    "PresignedUrlExpiredError",
    "RedirectedRefusalError",
    "RetriesExhaustedError",
    "RetryAfterTooLongError",
    "StorageError",
    "TransportError",
    "body_excerpt",
    "redact_url",
]

_EXCERPT_CHARS: Final = 200

#: What kind of failure kept an answer from arriving: the host's name did not resolve
#: ("dns"), no connection was made ("connect"), one was made and broke ("broken"), the
#: request timed out ("timeout"), or a failure another attempt cannot fix ("permanent": a
#: certificate, an invalid URL, a redirect loop, a body over its cap).
FailureKind = Literal["dns", "connect", "broken", "timeout", "permanent"]


def body_excerpt(body: bytes, limit: int = _EXCERPT_CHARS) -> str:
    """The start of a response body as one redacted line, for error messages."""
    text = " ".join(body[: limit * 4].decode("utf-8", errors="replace").split())
    if len(text) > limit:
        text = text[: limit - 1] + "…"
    return redact_text(text)


class ApiError(StookError):
    """Base of every error raised while talking to the ReSim API or its object storage."""

    @property
    def summary(self) -> str:
        """The message without what timing decides (attempt counts, signing times): what
        an output may say, so that the same failures write the same bytes."""
        return str(self)


class ApiStatusError(ApiError):
    """The API answered with an HTTP error status."""

    def __init__(
        self,
        *,
        status: int,
        method: str,
        url: str | URL,
        body: bytes = b"",
        retry_after: float | None = None,
    ) -> None:
        self.status = status
        self.retry_after = retry_after
        self.method = method
        self.url = redact_url(url)
        self.body_excerpt = body_excerpt(body)
        message = f"{method} {self.url} answered HTTP {status}"
        if self.body_excerpt:
            message += f": {self.body_excerpt}"
        super().__init__(message)


class AuthError(ApiStatusError):
    """401 or 403 from the API: the token is missing, wrong, expired or lacks access."""


class RedirectedRefusalError(ApiStatusError):
    """401 or 403 from another origin that the API redirected to, which got no token."""

    def __init__(
        self, *, status: int, method: str, url: str | URL, body: bytes, api_origin: str
    ) -> None:
        super().__init__(status=status, method=method, url=url, body=body)
        self.api_origin = api_origin  # scheme, host and port only: nothing secret
        self.args = (
            f"{self.args[0]} (the API at {self.api_origin} redirected there; the token is "
            "not sent to another origin, so this refusal is not about the token)",
        )


class NotFoundError(ApiStatusError):
    """404 from the API: a project, batch, job, report or build ID that does not exist."""


class ApiResponseError(ApiError):
    """The API answered 2xx with JSON that is malformed or lacks what stook needs.

    The message names the object and field, e.g.
    ``Job 1234…: field 'conflatedStatus' has unknown value 'FOO'``.
    """

    def __init__(self, message: str) -> None:
        super().__init__(redact_text(message))


class StorageError(ApiError):
    """Fetching a presigned object-storage URL failed; ``status`` is None without an answer."""

    def __init__(
        self,
        message: str,
        *,
        url: str | URL,
        status: int | None = None,
        retry_after: float | None = None,
    ) -> None:
        self.url = redact_url(url)
        self.status = status
        self.retry_after = retry_after
        super().__init__(redact_text(message))


class PresignedUrlExpiredError(StorageError):
    """Object storage refused a presigned URL (403): it has expired or its signature is stale.

    Retrying the same URL cannot help; list the metrics (or metrics data) again to obtain a
    fresh URL and fetch that.
    """


class TransportError(ApiError):
    """No complete answer arrived: connection refused or reset, timeout, truncated body.

    ``reason`` is the failure without the URL (for retry logs); ``kind`` what kind of
    failure it was (see `FailureKind`), which says whether another attempt may help.
    """

    def __init__(
        self, *, method: str, url: str | URL, reason: str, kind: FailureKind = "broken"
    ) -> None:
        self.url = redact_url(url)
        self.reason = redact_text(reason)
        self.kind: FailureKind = kind
        super().__init__(f"{method} {self.url} failed: {self.reason}")

    @property
    def retryable(self) -> bool:
        return self.kind != "permanent"


class IncompleteBodyError(TransportError):
    """A response body ended before its ``Content-Length``."""

    def __init__(self, *, method: str, url: str | URL, received: int, expected: int) -> None:
        self.received = received
        self.expected = expected
        super().__init__(
            method=method,
            url=url,
            reason=f"body ended after {received} of {expected} bytes",
        )


class BodyTooLargeError(TransportError):
    """An answer's body (decompressed) grew past its cap; asking again would fetch it again."""

    def __init__(self, *, method: str, url: str | URL, cap: int, setting: str) -> None:
        self.cap = cap
        super().__init__(
            method=method,
            url=url,
            reason=f"the answer is larger than {_megabytes(cap)} (the {setting} cap)",
            kind="permanent",
        )


def _megabytes(size: int) -> str:
    return f"{size / 2**20:g} MB" if size >= 2**20 else f"{size:,} bytes"


class RetriesExhaustedError(ApiError):
    """Every attempt allowed by the retry policy failed with a transient error."""

    def __init__(
        self,
        *,
        method: str,
        url: str | URL,
        attempts: int,
        last_reason: str,
        last_status: int | None = None,
    ) -> None:
        self.method = method
        self.url = redact_url(url)
        self.attempts = attempts
        self.last_reason = redact_text(last_reason)
        self.last_status = last_status
        super().__init__(
            f"{method} {self.url} failed after {attempts} attempts; last error: {self.last_reason}"
        )

    @property
    def summary(self) -> str:
        return f"{self.method} {self.url} failed on every attempt; last error: {self.last_reason}"


class OriginUnavailableError(ApiError):
    """An origin (the API, object storage) answered nothing but transient failures for a
    request's whole retry budget, and no other request either: it is down, not one request
    unlucky. Fatal for the run, unlike :class:`RetriesExhaustedError`, which costs one job.
    """

    def __init__(
        self, *, label: str, origin: str | URL, retry_for: float, last_reason: str
    ) -> None:
        self.label = label
        self.origin = redact_url(origin).rstrip("/")
        self.retry_for = retry_for
        self.last_reason = redact_text(last_reason)
        super().__init__(
            f"{label} at {self.origin} was unavailable for {retry_for:g} s, the whole "
            f"[fetch] retry_for budget; last error: {self.last_reason}"
        )


class OriginUnreachableError(ApiError):
    """An origin never answered the first contact: its host name does not resolve, or no
    connection could be made for the short first-contact budget. A wrong URL, most likely:
    the message names the setting it came from."""

    def __init__(self, *, label: str, origin: str | URL, setting: str, reason: str) -> None:
        self.label = label
        self.origin = redact_url(origin).rstrip("/")
        self.reason = redact_text(reason)
        super().__init__(
            f"{label} at {self.origin} cannot be reached ({self.reason}); check {setting}"
        )


class RetryAfterTooLongError(ApiError):
    """A server asked to wait (``Retry-After``) longer than stook waits: the request ends now
    instead of sleeping through its budget for an answer that cannot come in time."""

    def __init__(
        self,
        *,
        method: str,
        url: str | URL,
        status: int | None,
        retry_after: float,
        limit: str,
    ) -> None:
        self.url = redact_url(url)
        self.status = status
        self.retry_after = retry_after
        answered = f"answered HTTP {status}" if status is not None else "answered"
        super().__init__(
            f"{method} {self.url} {answered} with Retry-After: {retry_after:g} (seconds), "
            f"longer than {limit}; not waiting"
        )
