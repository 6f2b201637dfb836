"""The ReSim API client: JSON over a bearer-token session, paging, typed endpoints.

Two sessions, on purpose: the API's carries ``Authorization: Bearer <token>``; the storage
client's (:mod:`stook.service.api._storage`) is built without it, so the token cannot follow
a presigned URL (or a redirect from one) to another host.
"""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator, Callable, Mapping
from types import TracebackType
from typing import Any, Final, Self, TypeVar

import msgspec
from yarl import URL

from stook.service.api._config import (
    DEFAULT_CONCURRENCY,
    DEFAULT_MAX_API_BODY_MB,
    DEFAULT_PAGE_SIZE,
    BodyCap,
    RetryPolicy,
    body_cap_mb,
)
from stook.service.api._errors import (
    ApiError,
    ApiResponseError,
    ApiStatusError,
    AuthError,
    NotFoundError,
    RedirectedRefusalError,
)
from stook.service.api._limits import AimdLimiter, ConcurrencyLimit, FixedLimit, NestedLimit
from stook.service.api._models import (
    ApiMetric,
    ApiMetricsData,
    Batch,
    BatchesPage,
    BatchMetricsDataPage,
    BatchMetricsPage,
    Branch,
    BranchesPage,
    Build,
    Experience,
    ExperienceTag,
    ExperienceTagsPage,
    Job,
    JobEventListing,
    JobEventsPage,
    JobLog,
    JobLogsPage,
    JobMetricsDataPage,
    JobMetricsPage,
    JobsPage,
    LogType,
    Page,
    Report,
    decoder,
)
from stook.service.api._paging import Listing
from stook.service.api._redact import redact_url, register_secret
from stook.service.api._retry import Origin, send
from stook.service.api._storage import StorageClient, answer_retry_after
from stook.service.api._transport import (
    USER_AGENT,
    HttpTransport,
    Response,
    TrafficCounts,
    Transport,
)

__all__ = ["ApiClient", "IdLike"]

IdLike = uuid.UUID | str
_Model = TypeVar("_Model")
_Answer = TypeVar("_Answer")

# Every answer the client decodes: a listing's page, an object, or any JSON object.
_ANSWERS: Final = (
    dict,
    JobsPage,
    BatchesPage,
    JobMetricsPage,
    BatchMetricsPage,
    JobMetricsDataPage,
    BatchMetricsDataPage,
    JobEventsPage,
    ExperienceTagsPage,
    BranchesPage,
    JobLogsPage,
    Batch,
    Report,
    Build,
    Experience,
)


class ApiClient:
    """The ReSim REST API for one token, plus the storage client for the URLs it hands out.

    ::

        async with ApiClient(config.api_url, config.auth_token) as api:
            async for job in api.list_jobs(project_id, batch_id):
                for metric in await api.list_job_metrics(project_id, batch_id, job.job_id):
                    payload = await api.storage.fetch_bytes(metric.metric_url)

    ``concurrency`` bounds the requests in flight, API and storage together (or the API's
    alone, with ``storage_concurrency``); queueing for a slot does not count against the
    request timeout. ``adaptive=True`` gives each origin an
    :class:`~stook.service.api._limits.AimdLimiter` below that bound (``self.paces``).
    ``limiter``, ``transport`` and ``storage_transport`` may be passed in instead of built,
    as httpx takes ``transport=``; a transport passed in brings its own headers, limiter,
    timeout and body cap.
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
        limiter: ConcurrencyLimit | None = None,
        transport: Transport | None = None,
        storage_transport: Transport | None = None,
    ) -> None:
        base = URL(base_url)
        if base.scheme not in ("http", "https") or not base.host:
            raise ValueError(f"API base URL must be http(s)://host[/path], got {redact_url(base)}")
        if not token:
            raise ValueError("an API token is required")
        if page_size < 1:
            raise ValueError(f"page_size must be at least 1, got {page_size}")
        register_secret(token)  # before any request: a token echoed back is masked
        self._base = base.with_query(None).with_fragment(None)
        self._base_path = self._base.path.rstrip("/")  # "/v1", or ""
        self._policy = retry or RetryPolicy()
        self._page_size = page_size
        # One decoder per answer, made once: it reads a body straight into its type.
        self._decoders: dict[type, msgspec.json.Decoder[Any]] = {
            answer: decoder(answer) for answer in _ANSWERS
        }
        # Shared by every API request: when the API fails, they wait together.
        self.origin = Origin("the API", self._policy, setting="apiURL")
        if concurrency < 1:
            raise ValueError(f"concurrency must be at least 1, got {concurrency}")
        self.limiter: ConcurrencyLimit = limiter or FixedLimit(concurrency)
        # Adaptive: each origin its own pace inside the shared bound (the API's 429s say
        # nothing about storage). A transport passed in paces itself.
        self.paces: dict[str, AimdLimiter] = {}
        api_limit: ConcurrencyLimit = self.limiter
        storage_limit: ConcurrencyLimit | None = None if storage_concurrency else self.limiter
        if adaptive:
            if transport is None:
                self.paces["api"] = AimdLimiter(maximum=concurrency)
                api_limit = NestedLimit(self.paces["api"], self.limiter)
            if storage_transport is None:
                pace = self.paces["storage"] = AimdLimiter(
                    maximum=storage_concurrency or concurrency
                )
                storage_limit = pace if storage_concurrency else NestedLimit(pace, self.limiter)
        # Every bound on requests in flight, by name, for its stats.
        self.limiters: dict[str, ConcurrencyLimit] = {"shared": self.limiter, **self.paces}
        if transport is None:
            transport = HttpTransport(
                name="api",
                body_cap=body_cap or body_cap_mb(DEFAULT_MAX_API_BODY_MB, "max_api_body_mb"),
                concurrency=concurrency,
                limiter=api_limit,
                proxy_for=self._base,
                request_timeout=self._policy.request_timeout,
                headers={
                    "Authorization": f"Bearer {token}",
                    "Accept": "application/json",
                    "User-Agent": USER_AGENT,
                },
            )
        self._transport = transport
        self.stats: TrafficCounts = transport.stats
        self.storage = StorageClient(
            concurrency=storage_concurrency or concurrency,
            retry=self._policy,
            limiter=storage_limit,
            body_cap=storage_body_cap,
            transport=storage_transport,
        )

    def __repr__(self) -> str:
        return f"ApiClient({redact_url(self._base)!r})"

    async def __aenter__(self) -> Self:
        await self._transport.open()
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

    async def get_json(
        self, path: str, params: Mapping[str, str | int] | None = None
    ) -> dict[str, Any]:
        """GET ``path`` (relative to the base URL) and return its JSON object."""
        document: dict[str, Any] = await self._get(self._url(path, params), dict)
        return document

    async def paginate(
        self,
        path: str,
        page: type[Page[_Model]],
        params: Mapping[str, str | int] | None = None,
        page_size: int | None = None,
        *,
        on_total: Callable[[int], None] | None = None,
        expected: int | None = None,
    ) -> AsyncIterator[_Model]:
        """Every item of a list endpoint whose answers are `page`s, page after page (see
        :class:`Listing` for ``on_total``, ``expected`` and what ends a listing that would
        not end)."""
        async for items in self._pages(path, page, params, page_size, on_total, expected):
            for item in items:
                yield item

    # A job's listings come as lists; a project's or a batch's, which can run to thousands
    # of items, as async iterators.

    def list_jobs(
        self,
        project_id: IdLike,
        batch_id: IdLike,
        *,
        on_total: Callable[[int], None] | None = None,
        expected: int | None = None,
    ) -> AsyncIterator[Job]:
        """The jobs (tests) of a batch; ``expected`` is its ``Batch.total_jobs`` if known."""
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/jobs"
        return self.paginate(path, JobsPage, on_total=on_total, expected=expected)

    async def list_job_metrics(
        self, project_id: IdLike, batch_id: IdLike, job_id: IdLike
    ) -> list[ApiMetric]:
        """The metrics a job's metrics build produced."""
        path = self._job_path(project_id, batch_id, job_id) + "/metrics"
        return await self._list_all(path, JobMetricsPage)

    async def list_job_metrics_data(
        self, project_id: IdLike, batch_id: IdLike, job_id: IdLike
    ) -> list[ApiMetricsData]:
        """The metrics-data files of a job (all storage types; filter on ``is_standard``)."""
        path = self._job_path(project_id, batch_id, job_id) + "/metricsData"
        return await self._list_all(path, JobMetricsDataPage)

    async def list_job_events(
        self, project_id: IdLike, batch_id: IdLike, job_id: IdLike
    ) -> list[JobEventListing]:
        """The events a job's metrics build recorded (without their data)."""
        path = self._job_path(project_id, batch_id, job_id) + "/events"
        return await self._list_all(path, JobEventsPage)

    def list_experience_tags(
        self, project_id: IdLike, experience_id: IdLike
    ) -> AsyncIterator[ExperienceTag]:
        """The tags of one experience."""
        path = f"/projects/{_id(project_id)}/experiences/{_id(experience_id)}/experienceTags"
        return self.paginate(path, ExperienceTagsPage)

    async def get_experience(self, project_id: IdLike, experience_id: IdLike) -> Experience:
        """One experience with its custom fields. The spec's `getExperience` answer requires
        `customFields`, and its listings leave them out unless `includeCustomFields` is true:
        the flag is sent here too, so that the answer has them either way."""
        path = f"/projects/{_id(project_id)}/experiences/{_id(experience_id)}"
        return await self._get(self._url(path, {"includeCustomFields": "true"}), Experience)

    async def get_batch(self, project_id: IdLike, batch_id: IdLike) -> Batch:
        return await self._get(
            self._url(f"/projects/{_id(project_id)}/batches/{_id(batch_id)}"), Batch
        )

    def list_batches(
        self, project_id: IdLike, *, search: str | None = None
    ) -> AsyncIterator[Batch]:
        """The batches of a project matching ``search`` (clauses joined with `` AND ``)."""
        params = {"search": search} if search else None
        return self.paginate(f"/projects/{_id(project_id)}/batches", BatchesPage, params)

    def list_batch_metrics(self, project_id: IdLike, batch_id: IdLike) -> AsyncIterator[ApiMetric]:
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/metrics"
        return self.paginate(path, BatchMetricsPage)

    def list_batch_metrics_data(
        self, project_id: IdLike, batch_id: IdLike
    ) -> AsyncIterator[ApiMetricsData]:
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/metricsData"
        return self.paginate(path, BatchMetricsDataPage)

    async def get_report(self, project_id: IdLike, report_id: IdLike) -> Report:
        return await self._get(
            self._url(f"/projects/{_id(project_id)}/reports/{_id(report_id)}"), Report
        )

    def list_branches(
        self, project_id: IdLike, *, name: str | None = None
    ) -> AsyncIterator[Branch]:
        """The branches of a project, those named `name` only when given."""
        params = {"name": name} if name else None
        return self.paginate(f"/projects/{_id(project_id)}/branches", BranchesPage, params)

    async def get_build(self, project_id: IdLike, build_id: IdLike) -> Build:
        return await self._get(
            self._url(f"/projects/{_id(project_id)}/builds/{_id(build_id)}"), Build
        )

    def list_job_logs(
        self,
        project_id: IdLike,
        batch_id: IdLike,
        job_id: IdLike,
        *,
        log_type: LogType | None = None,
        name: str | None = None,
    ) -> AsyncIterator[JobLog]:
        """A job's logs (of `log_type`, named `name`, when given): EMISSIONS_LOG for what
        its test emitted, each downloadable at its `log_output_location`."""
        params = {k: str(v) for k, v in (("type", log_type), ("name", name)) if v is not None}
        path = self._job_path(project_id, batch_id, job_id) + "/logs"
        return self.paginate(path, JobLogsPage, params)

    async def _pages(
        self,
        path: str,
        page: type[Page[_Model]],
        params: Mapping[str, str | int] | None = None,
        page_size: int | None = None,
        on_total: Callable[[int], None] | None = None,
        expected: int | None = None,
    ) -> AsyncIterator[list[_Model]]:
        """Each page's items (see :class:`Listing`), until ``nextPageToken`` is empty."""
        listing: Listing[_Model] = Listing(
            lambda: f"GET {redact_url(self._url(path))}",  # made only for an error
            page.item_id,
            page_size or self._page_size,
            params,
            on_total=on_total,
            expected=expected,
        )
        while listing.more:
            yield listing.take(await self._get(self._url(path, listing.query), page))

    async def _list_all(self, path: str, page: type[Page[_Model]]) -> list[_Model]:
        """What `paginate` yields, as one list (a job's listings: a page of a few dozen)."""
        return [item async for items in self._pages(path, page) for item in items]

    async def _get(self, url: URL, answer: type[_Answer]) -> _Answer:
        """GET `url` and decode its body as `answer` (a page, an object, or `dict`)."""
        response = await send(lambda: self._get_once(url), self.origin, url=url, stats=self.stats)
        try:
            document: _Answer = self._decoders[answer].decode(response.body)
        except msgspec.ValidationError as exc:  # valid JSON, not of the answer's shape
            raise ApiResponseError(f"GET {redact_url(url)}: unusable answer: {exc}") from None
        except msgspec.DecodeError as exc:
            raise ApiResponseError(
                f"GET {redact_url(url)}: answer is not valid JSON ({exc})"
            ) from None
        except RecursionError:  # msgspec's parser recurses, even over skipped fields
            raise ApiResponseError(
                f"GET {redact_url(url)}: answer is nested too deeply to read"
            ) from None
        return document

    def _job_path(self, project_id: IdLike, batch_id: IdLike, job_id: IdLike) -> str:
        return f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/jobs/{_id(job_id)}"

    def _url(self, path: str, params: Mapping[str, str | int] | None = None) -> URL:
        """`path` under the base URL's path (which yarl's join() would drop), `params` its query."""
        url = self._base.with_path(self._base_path + "/" + path.lstrip("/"))
        return url.with_query(params) if params else url

    async def _get_once(self, url: URL) -> Response:
        response = await self._transport.get(url)
        if response.ok:
            return response
        raise _api_error(response, self._base)


def _id(value: IdLike) -> str:
    """An ID for a URL path; parsing it also keeps anything but a UUID out of the path."""
    if isinstance(value, uuid.UUID):
        return str(value)
    try:
        return str(uuid.UUID(value))
    except (ValueError, AttributeError, TypeError):
        raise ValueError(f"not a UUID: {value!r}") from None


def _api_error(response: Response, api_url: URL) -> ApiError:
    common: dict[str, Any] = {"status": response.status, "method": "GET", "url": response.url}
    common["body"] = response.body
    api_origin = api_url.origin()
    if response.status in (401, 403) and response.url.origin() != api_origin:
        # aiohttp drops the token on a redirect to another origin: not the token's fault.
        return RedirectedRefusalError(**common, api_origin=str(api_origin))
    if response.status in (401, 403):
        return AuthError(**common)
    if response.status == 404:
        # Every path of ReSim's API starts with /v1: without it, every request is a 404.
        without_v1 = not api_url.path.rstrip("/").endswith("/v1")
        return NotFoundError(**common, api_url=api_url if without_v1 else "")
    return ApiStatusError(**common, retry_after=answer_retry_after(response))
