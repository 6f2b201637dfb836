"""The clients: the ReSim API (JSON, bearer token, paging) and object storage (presigned URLs).

Two sessions, on purpose. The API session carries ``Authorization: Bearer <token>`` on every
request; the storage session is built without it, does not read ``.netrc``, follows
redirects itself so that each hop is checked, and so cannot hand the token to whichever host
a presigned URL (or a redirect from it) names.
"""

from __future__ import annotations

import json
import re
import uuid
from collections.abc import AsyncIterator, Callable, Mapping
from types import TracebackType
from typing import Any, Final, NoReturn, Self, TypeVar

from aiohttp import hdrs
from yarl import URL

from stook.service.api._errors import (
    ApiError,
    ApiResponseError,
    ApiStatusError,
    AuthError,
    NotFoundError,
    PresignedUrlExpiredError,
    RedirectedRefusalError,
    StorageError,
)
from stook.service.api._limits import AimdLimiter, ConcurrencyLimit, FixedLimit, NestedLimit
from stook.service.api._logging import get_logger
from stook.service.api._models import (
    Batch,
    BatchMetric,
    BatchMetricsData,
    Build,
    Job,
    JobMetric,
    JobMetricsData,
    Report,
)
from stook.service.api._redact import redact_url, register_secret
from stook.service.api._retry import (
    RETRYABLE_STATUSES,
    RetryPolicy,
    new_gate,
    parse_retry_after,
)
from stook.service.api._retrying import call_with_retries
from stook.service.api._stats import TransferStats
from stook.service.api._transport import BodyCap, HttpTransport, Response

__all__ = ["ApiClient", "IdLike", "StorageClient"]

_log = get_logger("stook.service.client")

IdLike = uuid.UUID | str
_Model = TypeVar("_Model")

DEFAULT_CONCURRENCY: Final = 64
# The API caps pages; 100 is the largest size ReSim's own tools ask for.
DEFAULT_PAGE_SIZE: Final = 100
# What one answer may hold, decompressed: generous for metrics data, small for JSON. A
# real answer never comes near; a hostile or broken one is stopped at the cap.
DEFAULT_MAX_BODY_MB: Final = 256.0
DEFAULT_MAX_API_BODY_MB: Final = 16.0
_USER_AGENT: Final = "stook/0.1 (+aiohttp)"
_REDIRECT_STATUSES: Final = frozenset({301, 302, 303, 307, 308})
_MAX_STORAGE_REDIRECTS: Final = 5
_STORAGE_ERROR_CODE: Final = re.compile(rb"<Code>\s*([A-Za-z0-9_.-]{1,64})\s*</Code>")
_EXPIRED_CODES: Final = frozenset({b"ExpiredToken", b"AccessDenied", b"RequestExpired"})


class StorageClient:
    """Fetches presigned object-storage URLs, with retries and without any credentials.

    Usually owned by an :class:`ApiClient` (``api.storage``); it can also be used alone::

        async with StorageClient() as storage:
            payload = await storage.fetch_bytes(url)
    """

    def __init__(
        self,
        *,
        concurrency: int = DEFAULT_CONCURRENCY,
        retry: RetryPolicy | None = None,
        limiter: ConcurrencyLimit | None = None,
        body_cap: BodyCap | None = None,
    ) -> None:
        self._policy = retry or RetryPolicy()
        self.stats = TransferStats()
        # Shared by every storage request: when storage fails, they wait together.
        self.gate = new_gate("object storage", self._policy)
        self._transport = HttpTransport(
            name="storage",
            body_cap=body_cap or body_cap_mb(DEFAULT_MAX_BODY_MB, "max_body_mb"),
            concurrency=concurrency,
            request_timeout=self._policy.request_timeout,
            stats=self.stats,
            headers={hdrs.USER_AGENT: _USER_AGENT},
            follow_redirects=False,
            credentials_allowed=False,
            limiter=limiter,
        )

    async def __aenter__(self) -> Self:
        await self._transport.__aenter__()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self._transport.close()

    async def fetch_bytes(self, url: str) -> bytes:
        """The whole object behind a presigned URL.

        Raises :class:`PresignedUrlExpiredError` when storage refuses the signature (list
        again for a fresh URL), :class:`StorageError` for other refusals, and
        :class:`RetriesExhaustedError` when transient failures outlast the retry policy
        (:class:`OriginUnavailableError` when storage as a whole is failing).
        """
        # encoded=True: re-quoting would alter the signed query string and void the signature.
        target = URL(url, encoded=True)
        if target.scheme not in ("http", "https") or not target.host:
            raise StorageError("not an http(s) URL", url=url)
        return await call_with_retries(
            lambda: self._fetch_once(target),
            self._policy,
            stats=self.stats,
            method="GET",
            url=url,
            gate=self.gate,
        )

    async def _fetch_once(self, url: URL) -> bytes:
        for _hop in range(_MAX_STORAGE_REDIRECTS + 1):
            response = await self._transport.get(url)
            location = response.headers.get(hdrs.LOCATION)
            if response.status in _REDIRECT_STATUSES and location:
                url = url.join(URL(location, encoded=True))
                continue
            if response.ok:
                return response.body
            raise _storage_error(response)
        raise StorageError(
            f"more than {_MAX_STORAGE_REDIRECTS} redirects from object storage", url=url
        )


class ApiClient:
    """The ReSim REST API for one token, plus the storage client for the URLs it hands out.

    ::

        async with ApiClient(config.api_url, config.auth_token) as api:
            async for job in api.list_jobs(project_id, batch_id):
                async for metric in api.list_job_metrics(project_id, batch_id, job.job_id):
                    payload = await api.storage.fetch_bytes(metric.metric_url)

    ``concurrency`` bounds the requests in flight, API and storage together; with
    ``storage_concurrency`` storage fetches get a bound of their own instead. Callers may
    start as many tasks as they like: they queue for a slot, without that queueing
    counting against the request timeout. With ``adaptive=True`` each origin (API, storage)
    also gets an :class:`~stook.service.api._limits.AimdLimiter` that finds that server's pace
    below ``concurrency`` (backing off on 429s and on growing latency); ``self.paces``
    shows them, ``self.limiter`` the shared bound.
    """

    def __init__(
        self,
        base_url: str,
        token: str,
        *,
        concurrency: int = DEFAULT_CONCURRENCY,
        storage_concurrency: int | None = None,
        retry: RetryPolicy | None = None,
        page_size: int = DEFAULT_PAGE_SIZE,
        adaptive: bool = False,
        body_cap: BodyCap | None = None,
        storage_body_cap: BodyCap | None = None,
    ) -> None:
        base = URL(base_url)
        if base.scheme not in ("http", "https") or not base.host:
            raise ValueError(f"API base URL must be http(s)://host[/path], got {redact_url(base)}")
        if not token:
            raise ValueError("an API token is required")
        if page_size < 1:
            raise ValueError(f"page_size must be at least 1, got {page_size}")
        # Registered before any request so a token echoed in an error body or log is masked.
        register_secret(token)
        self._base = base.with_query(None).with_fragment(None)
        self._policy = retry or RetryPolicy()
        self._page_size = page_size
        self.stats = TransferStats()
        # Shared by every API request: when the API fails, they wait together.
        self.gate = new_gate("the API", self._policy)
        if concurrency < 1:
            raise ValueError(f"concurrency must be at least 1, got {concurrency}")
        self.limiter = FixedLimit(concurrency)
        # Adaptive: each origin finds its own pace, inside the shared bound. A rate limit
        # on the API says nothing about storage, and one shared pace cut by the API's 429s
        # would hold storage back too.
        self.paces: dict[str, AimdLimiter] = {}
        api_limit: ConcurrencyLimit = self.limiter
        storage_limit: ConcurrencyLimit | None = None if storage_concurrency else self.limiter
        if adaptive:
            self.paces["api"] = AimdLimiter(maximum=concurrency)
            self.paces["storage"] = AimdLimiter(maximum=storage_concurrency or concurrency)
            api_limit = NestedLimit(self.paces["api"], self.limiter)
            storage_limit = (
                self.paces["storage"]
                if storage_concurrency
                else NestedLimit(self.paces["storage"], self.limiter)
            )
        self._transport = HttpTransport(
            name="api",
            body_cap=body_cap or body_cap_mb(DEFAULT_MAX_API_BODY_MB, "max_api_body_mb"),
            concurrency=concurrency,
            limiter=api_limit,
            proxy_for=self._base,
            request_timeout=self._policy.request_timeout,
            stats=self.stats,
            headers={
                hdrs.AUTHORIZATION: f"Bearer {token}",
                hdrs.ACCEPT: "application/json",
                hdrs.USER_AGENT: _USER_AGENT,
            },
        )
        self.storage = StorageClient(
            concurrency=storage_concurrency or concurrency,
            retry=self._policy,
            limiter=storage_limit,
            body_cap=storage_body_cap,
        )

    def __repr__(self) -> str:
        return f"ApiClient({redact_url(self._base)!r})"

    async def __aenter__(self) -> Self:
        await self._transport.__aenter__()
        try:
            await self.storage.__aenter__()
        except BaseException:
            await self._transport.close()
            raise
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            await self.storage.__aexit__(exc_type, exc, tb)
        finally:
            await self._transport.close()

    # -- generic -------------------------------------------------------------------------

    async def get_json(
        self, path: str, params: Mapping[str, str | int] | None = None
    ) -> dict[str, Any]:
        """GET ``path`` (relative to the base URL) and return its JSON object."""
        url = self._url(path)
        response = await call_with_retries(
            lambda: self._get_once(url, params),
            self._policy,
            stats=self.stats,
            method="GET",
            url=str(url),
            gate=self.gate,
        )
        try:
            document = json.loads(response.body)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ApiResponseError(
                f"GET {redact_url(url)}: answer is not valid JSON ({exc})"
            ) from None
        if not isinstance(document, dict):
            raise ApiResponseError(
                f"GET {redact_url(url)}: expected a JSON object, got {type(document).__name__}"
            )
        return document

    async def paginate(
        self,
        path: str,
        items_key: str,
        params: Mapping[str, str | int] | None = None,
        page_size: int | None = None,
    ) -> AsyncIterator[dict[str, Any]]:
        """Every item of a list endpoint, page after page, until ``nextPageToken`` is empty.

        A listing that cannot end (see :class:`_ListingGuard`) is an ApiResponseError.
        """
        query: dict[str, str | int] = dict(params or {})
        query["pageSize"] = page_size or self._page_size
        listing = f"GET {redact_url(self._url(path))}"
        guard = _ListingGuard(listing, items_key, int(query["pageSize"]))
        while True:
            page = await self.get_json(path, query)
            items = page.get(items_key)
            if items is None:
                items = []  # the API omits empty lists
            if not isinstance(items, list):
                raise ApiResponseError(
                    f"{listing}: '{items_key}' should be a list, got {type(items).__name__}"
                )
            for item in items:
                if not isinstance(item, dict):
                    raise ApiResponseError(
                        f"{listing}: an item of '{items_key}' is {type(item).__name__}, "
                        "not an object"
                    )
            token = page.get("nextPageToken")
            if token and not isinstance(token, str):
                raise ApiResponseError(f"{listing}: 'nextPageToken' should be a string")
            # Checked before the items are handed on: a page that proves the listing
            # endless must not feed its repeats to the caller.
            guard.check(items, token or None, page.get("total"))
            for item in items:
                yield item
            if not token:
                return
            query["pageToken"] = token

    # -- typed endpoints -----------------------------------------------------------------

    def list_jobs(self, project_id: IdLike, batch_id: IdLike) -> AsyncIterator[Job]:
        """The jobs (tests) of a batch."""
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/jobs"
        return self._list(path, "jobs", Job.from_json)

    def list_job_metrics(
        self, project_id: IdLike, batch_id: IdLike, job_id: IdLike
    ) -> AsyncIterator[JobMetric]:
        """The metrics a job's metrics build produced."""
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/jobs/{_id(job_id)}/metrics"
        return self._list(path, "metrics", JobMetric.from_json)

    def list_job_metrics_data(
        self, project_id: IdLike, batch_id: IdLike, job_id: IdLike
    ) -> AsyncIterator[JobMetricsData]:
        """The metrics-data files of a job (all storage types; filter on ``is_standard``)."""
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/jobs/{_id(job_id)}/metricsData"
        return self._list(path, "metricsData", JobMetricsData.from_json)

    async def get_batch(self, project_id: IdLike, batch_id: IdLike) -> Batch:
        document = await self.get_json(f"/projects/{_id(project_id)}/batches/{_id(batch_id)}")
        return Batch.from_json(document)

    def list_batches(
        self, project_id: IdLike, *, search: str | None = None
    ) -> AsyncIterator[Batch]:
        """The batches of a project matching ``search`` (clauses joined with `` AND ``)."""
        params = {"search": search} if search else None
        return self._list(
            f"/projects/{_id(project_id)}/batches", "batches", Batch.from_json, params
        )

    def list_batch_metrics(
        self, project_id: IdLike, batch_id: IdLike
    ) -> AsyncIterator[BatchMetric]:
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/metrics"
        return self._list(path, "batchMetrics", BatchMetric.from_json)

    def list_batch_metrics_data(
        self, project_id: IdLike, batch_id: IdLike
    ) -> AsyncIterator[BatchMetricsData]:
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/metricsData"
        return self._list(path, "batchMetricsData", BatchMetricsData.from_json)

    async def get_report(self, project_id: IdLike, report_id: IdLike) -> Report:
        document = await self.get_json(f"/projects/{_id(project_id)}/reports/{_id(report_id)}")
        return Report.from_json(document)

    async def get_build(self, project_id: IdLike, build_id: IdLike) -> Build:
        document = await self.get_json(f"/projects/{_id(project_id)}/builds/{_id(build_id)}")
        return Build.from_json(document)

    # -- internals -----------------------------------------------------------------------

    async def _list(
        self,
        path: str,
        items_key: str,
        parse: Callable[[Mapping[str, Any]], _Model],
        params: Mapping[str, str | int] | None = None,
    ) -> AsyncIterator[_Model]:
        async for item in self.paginate(path, items_key, params):
            yield parse(item)

    def _url(self, path: str) -> URL:
        # Joined as text: yarl's join() would drop the base path ("/v1") for "/projects/...".
        return URL(str(self._base).rstrip("/") + "/" + path.lstrip("/"))

    async def _get_once(self, url: URL, params: Mapping[str, str | int] | None) -> Response:
        response = await self._transport.get(url, params=params)
        if response.ok:
            return response
        raise _api_error(response, self._base.origin())


def body_cap_mb(megabytes: float, setting: str) -> BodyCap:
    """The cap of a ``[fetch]`` setting given in megabytes (MiB)."""
    return BodyCap(max(1, int(megabytes * 2**20)), f"[fetch] {setting}")


def _id(value: IdLike) -> str:
    """An ID for a URL path; parsing it also keeps anything but a UUID out of the path."""
    if isinstance(value, uuid.UUID):
        return str(value)
    try:
        return str(uuid.UUID(value))
    except (ValueError, AttributeError, TypeError):
        raise ValueError(f"not a UUID: {value!r}") from None


def _retry_after(response: Response) -> float | None:
    if response.status not in RETRYABLE_STATUSES:
        return None
    return parse_retry_after(response.headers.get(hdrs.RETRY_AFTER))


def _api_error(response: Response, api_origin: URL) -> ApiError:
    common: dict[str, Any] = {
        "status": response.status,
        "method": "GET",
        "url": response.url,
        "body": response.body,
    }
    if response.status in (401, 403) and response.url.origin() != api_origin:
        # aiohttp drops the token on a redirect to another origin, so this refusal says
        # nothing about the token; blaming it would send the reader the wrong way.
        return RedirectedRefusalError(**common, api_origin=str(api_origin))
    if response.status in (401, 403):
        return AuthError(**common)
    if response.status == 404:
        return NotFoundError(**common)
    return ApiStatusError(**common, retry_after=_retry_after(response))


def _storage_error(response: Response) -> StorageError:
    """Map a storage refusal; only the error code is kept (S3 bodies echo the signature)."""
    match = _STORAGE_ERROR_CODE.search(response.body[:4096])
    code = match.group(1) if match else None
    code_text = f" ({code.decode()})" if code else ""
    status = response.status
    if status == 403 or (status == 400 and code in _EXPIRED_CODES):
        return PresignedUrlExpiredError(
            f"GET {redact_url(response.url)} answered HTTP {status}{code_text}: the presigned "
            "URL has expired or its signature is invalid; list again for a fresh URL",
            url=response.url,
            status=status,
        )
    if status == 404:
        message = "no such object"
    elif status in RETRYABLE_STATUSES:
        message = "object storage is unavailable or throttling"
    else:
        message = "object storage refused the request"
    return StorageError(
        f"GET {redact_url(response.url)} answered HTTP {status}{code_text}: {message}",
        url=response.url,
        status=status,
        retry_after=_retry_after(response),
    )


# The field that identifies an item of each listing, for telling repeats from new items.
_ITEM_ID_KEYS: Final = {
    "jobs": "jobID",
    "batches": "batchID",
    "metrics": "metricID",
    "batchMetrics": "metricID",
    "metricsData": "dataID",
    "batchMetricsData": "dataID",
}
# Empty pages that each hand out a new token: a server may skip ahead over a few, never
# over this many (156,000 a minute were seen from a server that never stopped).
_MAX_EMPTY_PAGES: Final = 50


class _ListingGuard:
    """Stops a listing whose pages prove it will not end, instead of following it for ever.

    Only what the answers themselves prove counts: a page token seen before; a page of
    nothing but items listed already (the same jobs again and again); an empty page with a
    further token once the listing's own ``total`` has been delivered, or more items than
    that total by a whole page; and a long run of empty pages that each carry a new token.
    """

    def __init__(self, listing: str, items_key: str, page_size: int) -> None:
        self._listing = listing
        self._id_key = _ITEM_ID_KEYS.get(items_key)
        self._page_size = page_size
        self._tokens: set[str] = set()
        self._seen: set[str] = set()
        self._pages = 0
        self._empty_run = 0

    def check(self, items: list[dict[str, Any]], token: str | None, total: object) -> None:
        self._pages += 1
        new = 0
        for item in items:
            identity = self._identity(item)
            if identity not in self._seen:
                self._seen.add(identity)
                new += 1
        if token is None:
            return  # the last page: nothing more will be asked for
        if token in self._tokens:
            self._stop("the API repeated a page token")
        self._tokens.add(token)
        if items and new == 0:
            self._stop(f"page {self._pages} holds only items listed on earlier pages")
        self._empty_run = 0 if items else self._empty_run + 1
        if isinstance(total, int) and not isinstance(total, bool):
            if not items and len(self._seen) >= total:
                self._stop(
                    f"page {self._pages} is empty and all {total} items of the listing's "
                    "total have been listed, yet it hands out another page token"
                )
            if len(self._seen) > total + self._page_size:
                self._stop(
                    f"{len(self._seen)} items listed, more than the listing's total of {total}"
                )
        if self._empty_run >= _MAX_EMPTY_PAGES:
            self._stop(f"{self._empty_run} empty pages in a row, each with a new page token")

    def _identity(self, item: dict[str, Any]) -> str:
        value = item.get(self._id_key) if self._id_key else None
        if isinstance(value, str) and value:
            return value
        # An item without its ID is told apart by its whole content.
        return json.dumps(item, sort_keys=True, default=str)

    def _stop(self, why: str) -> NoReturn:
        raise ApiResponseError(f"{self._listing}: the listing does not end ({why})")
