"""stook's errors for the API and object storage, the only ones this layer raises.

Every message is one line and safe to print: URLs and response text are redacted when the
error is made, and no third-party exception (whose text may hold a full URL) is chained as
``__cause__``. The hierarchy::

    StookError (stook.sdk)
    └── ApiError ·························· the API or object storage failed
        ├── ApiStatusError ················ the API answered an HTTP error status
        │   ├── AuthError ················· 401 / 403: the token
        │   ├── RedirectedRefusalError ···· 401 / 403 from where the API redirected to
        │   └── NotFoundError ············· 404: an ID, or an apiURL without /v1
        ├── ApiResponseError ·············· 2xx with JSON that lacks what stook needs
        ├── StorageError ·················· a presigned object-storage URL failed
        │   └── PresignedUrlExpiredError ·· 403 from storage: list again for a fresh URL
        ├── TransportError ················ no complete answer (connect, reset, timeout)
        │   └── BodyTooLargeError ········· an answer past its cap
        ├── RetriesExhaustedError ········· transient failures for the whole budget
        ├── OriginUnavailableError ········ every request to an origin failed: it is down
        ├── OriginUnreachableError ········ an origin never answered: a wrong URL
        └── RetryAfterTooLongError ········ asked to wait longer than stook waits

Which exit code each ends `stook run` with is decided once, in the CLI
(``stook.service.cli._run.exit_code_for``), not here.
"""

from __future__ import annotations

from typing import Literal

from yarl import URL

from stook.sdk import StookError
from stook.service.api._redact import redact_text, redact_url

#: Why no answer arrived: the host name did not resolve, no connection was made, one was
#: made and broke, the request timed out, or another attempt cannot help ("permanent": a
#: certificate, an invalid URL, a redirect loop, a body over its cap).
FailureKind = Literal["dns", "connect", "broken", "timeout", "permanent"]


def body_excerpt(body: bytes, limit: int = 200) -> str:
    """The start of a response body as one redacted line, for error messages."""
    text = " ".join(body[: limit * 4].decode("utf-8", errors="replace").split())
    return redact_text(text if len(text) <= limit else text[: limit - 1] + "…")


class ApiError(StookError):
    """Base of every error raised while talking to the ReSim API or its object storage."""

    @property
    def summary(self) -> str:
        """The message without what timing decides (attempt counts): what an output may say,
        so that the same failures write the same bytes."""
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
        self.status, self.method, self.url = status, method, redact_url(url)
        self.retry_after = retry_after
        self.body_excerpt = body_excerpt(body)
        excerpt = f": {self.body_excerpt}" if self.body_excerpt else ""
        super().__init__(f"{method} {self.url} answered HTTP {status}{excerpt}")


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
            f"{self.args[0]} (the API at {api_origin} redirected there; the token is not sent "
            "to another origin, so this refusal is not about the token)",
        )


class NotFoundError(ApiStatusError):
    """404 from the API: a project, batch, job, report or build ID that does not exist, or
    an ``apiURL`` without ReSim's ``/v1`` (``api_url`` given: the message says so)."""

    def __init__(
        self,
        *,
        status: int,
        method: str,
        url: str | URL,
        body: bytes = b"",
        api_url: str | URL = "",
    ) -> None:
        super().__init__(status=status, method=method, url=url, body=body)
        if api_url:
            self.args = (
                f"{self.args[0]} (apiURL should end in /v1, where ReSim serves its API; "
                f"it is {redact_url(api_url)})",
            )


class ApiResponseError(ApiError):
    """The API answered 2xx with JSON that is malformed or lacks what stook needs; the
    message names the object and field."""

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
        self.url, self.status, self.retry_after = redact_url(url), status, retry_after
        super().__init__(redact_text(message))


class PresignedUrlExpiredError(StorageError):
    """Object storage refused a presigned URL (403): expired or a stale signature. Retrying
    cannot help; list again for a fresh URL."""


class TransportError(ApiError):
    """No complete answer arrived: connection refused or reset, timeout, truncated body.
    ``reason`` is the failure without the URL; ``kind`` says whether retrying may help."""

    def __init__(
        self, *, method: str, url: str | URL, reason: str, kind: FailureKind = "broken"
    ) -> None:
        self.url, self.reason, self.kind = redact_url(url), redact_text(reason), kind
        super().__init__(f"{method} {self.url} failed: {self.reason}")

    @property
    def retryable(self) -> bool:
        return self.kind != "permanent"


class BodyTooLargeError(TransportError):
    """An answer's body (decompressed) grew past its cap; asking again would fetch it again."""

    def __init__(self, *, method: str, url: str | URL, cap: int, setting: str) -> None:
        self.cap = cap
        size = f"{cap / 2**20:g} MB" if cap >= 2**20 else f"{cap:,} bytes"
        reason = f"the answer is larger than {size} (the {setting} cap)"
        super().__init__(method=method, url=url, reason=reason, kind="permanent")


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
        self.method, self.url, self.attempts = method, redact_url(url), attempts
        self.last_reason, self.last_status = redact_text(last_reason), last_status
        super().__init__(
            f"{method} {self.url} failed after {attempts} attempts; last error: {self.last_reason}"
        )

    @property
    def summary(self) -> str:
        return f"{self.method} {self.url} failed on every attempt; last error: {self.last_reason}"


class OriginUnavailableError(ApiError):
    """An origin answered nothing but transient failures, to this request and every other,
    for the whole retry budget: it is down. Fatal for the run, unlike
    :class:`RetriesExhaustedError`, which costs one job."""

    def __init__(
        self, *, label: str, origin: str | URL, retry_for: float, last_reason: str
    ) -> None:
        self.label, self.origin = label, redact_url(origin).rstrip("/")
        self.retry_for, self.last_reason = retry_for, redact_text(last_reason)
        super().__init__(
            f"{label} at {self.origin} was unavailable for {retry_for:g} s, the whole "
            f"[fetch] retry_for budget; last error: {self.last_reason}"
        )


class OriginUnreachableError(ApiError):
    """An origin never answered the first contact (its name does not resolve, or no
    connection for the first-contact budget): a wrong URL, most likely, so the message names
    the setting it came from."""

    def __init__(self, *, label: str, origin: str | URL, setting: str, reason: str) -> None:
        self.label, self.origin = label, redact_url(origin).rstrip("/")
        self.reason = redact_text(reason)
        super().__init__(
            f"{label} at {self.origin} cannot be reached ({self.reason}); check {setting}"
        )


class RetryAfterTooLongError(ApiError):
    """A server asked to wait (``Retry-After``) longer than stook waits: the request ends now
    rather than sleep through its budget for an answer that cannot come in time."""

    def __init__(
        self, *, method: str, url: str | URL, status: int | None, retry_after: float, limit: str
    ) -> None:
        self.url, self.status, self.retry_after = redact_url(url), status, retry_after
        answered = f"answered HTTP {status}" if status is not None else "answered"
        super().__init__(
            f"{method} {self.url} {answered} with Retry-After: {retry_after:g} (seconds), "
            f"longer than {limit}; not waiting"
        )
