"""The ReSim API client: JSON over a bearer-token session, paging, typed endpoints.

Two sessions, on purpose. The API session carries ``Authorization: Bearer <token>`` on every
request; the storage client's (:mod:`stook.service.api._storage`) is built without it, so the
token cannot follow a presigned URL (or a redirect from one) to another host.
"""

from __future__ import annotations

import re
import uuid
from collections.abc import AsyncIterator, Awaitable, Callable, Mapping
from types import TracebackType
from typing import Any, Final, Generic, Self, TypeVar

import msgspec
from yarl import URL

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
from stook.service.api._paging import ListingGuard
from stook.service.api._redact import redact_url, register_secret
from stook.service.api._retry import Origin, RetryPolicy, send
from stook.service.api._storage import DEFAULT_CONCURRENCY, StorageClient, answer_retry_after
from stook.service.api._transport import (
    USER_AGENT,
    BodyCap,
    HttpTransport,
    Response,
    TransferStats,
    Transport,
    body_cap_mb,
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
)
# The API caps pages; 100 is the largest size ReSim's own tools ask for.
DEFAULT_PAGE_SIZE: Final = 100
# What one API answer (a JSON page) may hold, decompressed.
DEFAULT_MAX_API_BODY_MB: Final = 16.0
# A path, and a query key or value, that yarl would neither quote nor normalise: such a URL
# is written out as text and parsed as already encoded (see ApiClient._url).
_PLAIN_PATH: Final = re.compile(r"[A-Za-z0-9_/-]*")
_PLAIN_QUERY: Final = re.compile(r"[A-Za-z0-9_.~-]*")


class ApiClient:
    """The ReSim REST API for one token, plus the storage client for the URLs it hands out.

    ::

        async with ApiClient(config.api_url, config.auth_token) as api:
            async for job in api.list_jobs(project_id, batch_id):
                for metric in await api.list_job_metrics(project_id, batch_id, job.job_id):
                    payload = await api.storage.fetch_bytes(metric.metric_url)

    ``concurrency`` bounds the requests in flight, API and storage together; with
    ``storage_concurrency`` storage fetches get a bound of their own instead. Callers may
    start as many tasks as they like: they queue for a slot, without that queueing
    counting against the request timeout. With ``adaptive=True`` each origin (API, storage)
    also gets an :class:`~stook.service.api._limits.AimdLimiter` that finds that server's pace
    below ``concurrency`` (backing off on 429s and on growing latency); ``self.paces``
    shows them, ``self.limiter`` the shared bound, and ``self.limiters`` all of them by
    name, for their ``stats``.

    What is built from these settings can be passed in instead, as httpx takes
    ``transport=`` and aiohttp ``connector=``: ``limiter`` is the shared bound (a
    :class:`~stook.service.api._limits.FixedLimit` of ``concurrency`` by default), and
    ``transport`` sends the API's requests (an HTTP transport carrying the token, under the
    shared bound and the API's pace); one passed in brings its own headers, limiter, timeout
    and body cap. ``storage_transport`` does the same for the storage client.
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
        # Registered before any request so a token echoed in an error body or log is masked.
        register_secret(token)
        self._base = base.with_query(None).with_fragment(None)
        self._base_text = str(self._base).rstrip("/")  # joined to every request's path
        self._policy = retry or RetryPolicy()
        self._page_size = page_size
        # What `_url` makes of a listing's first page's query ({"pageSize": page_size}).
        self._first_page_query = f"?pageSize={page_size}"
        # The parts of a listing's first page's URL that every such URL shares: its scheme,
        # authority and query, and the base URL's path before the listing's (see _all_items).
        shared = URL(self._base_text + "/" + self._first_page_query, encoded=True)
        self._first_page_parts = (shared.scheme, shared.raw_authority, shared.raw_query_string)
        self._base_path = shared.raw_path[:-1]  # "/v1", or "" for a base URL without one
        # The last batch whose jobs' paths were made, by its IDs' identity (see _job_path).
        self._batch_path: tuple[IdLike, IdLike, str] | None = None
        # One decoder per answer, each made once: it reads a body straight into its type.
        self._decoders: dict[type, msgspec.json.Decoder[Any]] = {
            answer: decoder(answer) for answer in _ANSWERS
        }
        # Shared by every API request: when the API fails, they wait together.
        self.origin = Origin("the API", self._policy, setting="apiURL")
        if concurrency < 1:
            raise ValueError(f"concurrency must be at least 1, got {concurrency}")
        self.limiter: ConcurrencyLimit = limiter or FixedLimit(concurrency)
        # Adaptive: each origin finds its own pace, inside the shared bound. A rate limit
        # on the API says nothing about storage, and one shared pace cut by the API's 429s
        # would hold storage back too. A transport passed in paces itself.
        self.paces: dict[str, AimdLimiter] = {}
        api_limit: ConcurrencyLimit = self.limiter
        storage_limit: ConcurrencyLimit | None = None if storage_concurrency else self.limiter
        if adaptive:
            if transport is None:
                self.paces["api"] = AimdLimiter(maximum=concurrency)
                api_limit = NestedLimit(self.paces["api"], self.limiter)
            if storage_transport is None:
                self.paces["storage"] = AimdLimiter(maximum=storage_concurrency or concurrency)
                storage_limit = (
                    self.paces["storage"]
                    if storage_concurrency
                    else NestedLimit(self.paces["storage"], self.limiter)
                )
        # The bounds on requests in flight by name, for their stats: the shared one (the
        # API's alone when storage has a concurrency of its own) and each origin's pace.
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
        self.stats: TransferStats = transport.stats
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

    # -- generic -------------------------------------------------------------------------

    async def get_json(
        self, path: str, params: Mapping[str, str | int] | None = None
    ) -> dict[str, Any]:
        """GET ``path`` (relative to the base URL) and return its JSON object."""
        document: dict[str, Any] = await self._get_document(self._url(path, params), dict)
        return document

    def _get_document(self, url: URL, answer: type[_Answer]) -> Awaitable[_Answer]:
        """GET `url` and decode its body as `answer` (a page, or an object)."""
        return self._get(url, answer)

    async def _get(self, url: URL, answer: type[Any], listing: str | None = None) -> Any:
        """GET `url` and decode its body as `answer` (`_get_document`); with `listing` (its
        path; `answer` is its page), that listing's items, from this first page on
        (`_all_items`).

        One coroutine for both: a job's listing is one page, and a coroutine fewer between
        the worker and the transport saves a frame's resumption at every step of its
        request.
        """
        response = await send(lambda: self._get_once(url), self.origin, url=url, stats=self.stats)
        try:
            document = self._decoders[answer].decode(response.body)
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
        if listing is None:
            return document
        if not document.next_page_token:
            # The only page (a job's listing, as a rule): its items, without the paging
            # state `take` keeps for further pages.
            return document.items or []
        return await self._rest_of_listing(listing, answer, document)

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
        """Every item of a list endpoint, whose answers are `page`s, page after page, until
        ``nextPageToken`` is empty.

        ``on_total`` is called with the listing's ``total`` (how many items it holds, an
        optional field) from the first page that carries one, before that page's items.
        A listing that cannot end (see :class:`ListingGuard`; ``expected`` is what the
        caller knows of its count) is an ApiResponseError.
        """
        paging = _Paging(self, path, page, params, page_size, on_total, expected)
        while paging.more:
            answer = await self._get_document(self._url(path, paging.query), page)
            for item in paging.take(answer):
                yield item

    # -- typed endpoints -----------------------------------------------------------------
    #
    # A job's listings (a page or two, as a rule) come as lists; the listings of a project
    # or a batch, which can run to thousands of items, as async iterators.

    def list_jobs(
        self,
        project_id: IdLike,
        batch_id: IdLike,
        *,
        on_total: Callable[[int], None] | None = None,
        expected: int | None = None,
    ) -> AsyncIterator[Job]:
        """The jobs (tests) of a batch; ``on_total`` hears the listing's job count first.

        ``expected``: the batch's job count when known (``Batch.total_jobs``), which
        bounds the listing until its pages say their own ``total``."""
        path = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/jobs"
        return self.paginate(path, JobsPage, on_total=on_total, expected=expected)

    def list_job_metrics(
        self, project_id: IdLike, batch_id: IdLike, job_id: IdLike
    ) -> Awaitable[list[ApiMetric]]:
        """The metrics a job's metrics build produced."""
        path = self._job_path(project_id, batch_id, job_id) + "/metrics"
        return self._all_items(path, JobMetricsPage)

    def list_job_metrics_data(
        self, project_id: IdLike, batch_id: IdLike, job_id: IdLike
    ) -> Awaitable[list[ApiMetricsData]]:
        """The metrics-data files of a job (all storage types; filter on ``is_standard``)."""
        path = self._job_path(project_id, batch_id, job_id) + "/metricsData"
        return self._all_items(path, JobMetricsDataPage)

    def list_job_events(
        self, project_id: IdLike, batch_id: IdLike, job_id: IdLike
    ) -> Awaitable[list[JobEventListing]]:
        """The events a job's metrics build recorded (without their data)."""
        path = self._job_path(project_id, batch_id, job_id) + "/events"
        return self._all_items(path, JobEventsPage)

    def list_experience_tags(
        self, project_id: IdLike, experience_id: IdLike
    ) -> AsyncIterator[ExperienceTag]:
        """The tags of one experience."""
        path = f"/projects/{_id(project_id)}/experiences/{_id(experience_id)}/experienceTags"
        return self.paginate(path, ExperienceTagsPage)

    async def get_batch(self, project_id: IdLike, batch_id: IdLike) -> Batch:
        url = self._url(f"/projects/{_id(project_id)}/batches/{_id(batch_id)}")
        return await self._get_document(url, Batch)

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
        url = self._url(f"/projects/{_id(project_id)}/reports/{_id(report_id)}")
        return await self._get_document(url, Report)

    def list_branches(
        self, project_id: IdLike, *, name: str | None = None
    ) -> AsyncIterator[Branch]:
        """The branches of a project, those named `name` only when given."""
        params = {"name": name} if name else None
        return self.paginate(f"/projects/{_id(project_id)}/branches", BranchesPage, params)

    async def get_build(self, project_id: IdLike, build_id: IdLike) -> Build:
        url = self._url(f"/projects/{_id(project_id)}/builds/{_id(build_id)}")
        return await self._get_document(url, Build)

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
        params: dict[str, str | int] = {}
        if log_type is not None:
            params["type"] = str(log_type)
        if name is not None:
            params["name"] = name
        path = self._job_path(project_id, batch_id, job_id) + "/logs"
        return self.paginate(path, JobLogsPage, params)

    # -- internals -----------------------------------------------------------------------

    def _all_items(self, path: str, page: type[Page[_Model]]) -> Awaitable[list[_Model]]:
        """What `paginate` yields, as one list: with no async generator step per item, and
        none per page (a job's listing is two dozen items or fewer, on one page), in
        `_get`'s coroutine.

        `path` starts with "/" and holds literal segments and `_id`s only."""
        # The first page's URL built from its parts: `path` is made of literal segments and
        # `_id`s, so it needs no quoting, and the rest is the same for every listing; `_url`
        # would check and build both for every job's listings (half of their own CPU), and
        # parsing the URL written out costs four times building it (24k instructions).
        # Keywords, not a dict unpacked into the call: that costs a third more.
        scheme, authority, query = self._first_page_parts
        url = URL.build(
            scheme=scheme,
            authority=authority,
            path=self._base_path + path,
            query_string=query,
            encoded=True,
        )
        return self._get(url, page, path)

    async def _rest_of_listing(
        self, path: str, page_type: type[Page[_Model]], page: Page[_Model]
    ) -> list[_Model]:
        """A listing's items from its first `page` on, every page's (see `_all_items`)."""
        paging = _Paging(self, path, page_type, None, None, None, None)
        items = paging.take(page)
        while paging.more:  # the next page's URL only when there is one (a job's: none)
            answer = await self._get_document(self._url(path, paging.query), page_type)
            items = items + paging.take(answer)
        return items

    def _job_path(self, project_id: IdLike, batch_id: IdLike, job_id: IdLike) -> str:
        """`/projects/{project}/batches/{batch}/jobs/{job}`, the batch's part remembered:
        a batch run lists two listings of each of its jobs, and formatting the same two
        IDs for each cost more than the job's."""
        batch = self._batch_path
        if batch is None or batch[0] is not project_id or batch[1] is not batch_id:
            prefix = f"/projects/{_id(project_id)}/batches/{_id(batch_id)}/jobs/"
            batch = self._batch_path = (project_id, batch_id, prefix)
        return batch[2] + _id(job_id)

    def _url(self, path: str, params: Mapping[str, str | int] | None = None) -> URL:
        """The URL of `path` under the base URL, with `params` as its query.

        Joined as text: yarl's join() would drop the base path ("/v1") for "/projects/...".
        A path of UUIDs and names, with a query of numbers and plain page tokens (every
        request of a run, in practice), is written out and parsed as already encoded: the
        same URL that quoting it and adding the query would make, for a quarter of the
        CPU (yarl's extend_query alone costs more than the parse).
        """
        path = path.lstrip("/")
        text = self._base_text + "/" + path
        if _PLAIN_PATH.fullmatch(path) is not None:
            query = _plain_query(params) if params else ""
            if query is not None:
                return URL(text + query, encoded=True)
        url = URL(text)
        return url.extend_query(params) if params else url

    async def _get_once(self, url: URL) -> Response:
        response = await self._transport.get(url)
        if response.ok:
            return response
        raise _api_error(response, self._base.origin())


class _Paging(Generic[_Model]):
    """One listing's pages as `ApiClient.paginate` reads them: the next page's query, and
    each page's items once checked (a listing that cannot end is an ApiResponseError; see
    :class:`ListingGuard`)."""

    __slots__ = (
        "_client",
        "_expected",
        "_guard",
        "_on_total",
        "_page",
        "_path",
        "more",
        "query",
    )

    def __init__(
        self,
        client: ApiClient,
        path: str,
        page: type[Page[_Model]],
        params: Mapping[str, str | int] | None,
        page_size: int | None,
        on_total: Callable[[int], None] | None,
        expected: int | None,
    ) -> None:
        self._client = client
        self._expected = expected
        self._path = path
        self._page = page
        self._on_total = on_total
        self.query: dict[str, str | int] = dict(params or {})
        self.query["pageSize"] = page_size or client._page_size
        # Made with the first page that has a next page: a listing of one page (a job's)
        # has nothing to compare its page with.
        self._guard: ListingGuard | None = None
        self.more = True  # until a page without a next page token

    def _listing(self) -> str:
        # Made only for an error: a batch run starts two listings per job.
        return f"GET {redact_url(self._client._url(self._path))}"

    def take(self, page: Page[_Model]) -> list[_Model]:
        """The page's items to hand on; the query then asks for the next page, if any.

        ``on_total`` is called with the listing's ``total`` from the first page that
        carries one, before that page's items are handed on.
        """
        items = page.items or []  # the API omits empty lists
        token = page.next_page_token
        # Checked before the items are handed on: a page that proves the listing
        # endless must not feed its repeats to the caller.
        total = page.total
        guard = self._guard
        if guard is None and token:
            guard = self._guard = ListingGuard(
                self._listing,
                self._page.item_id,
                int(self.query["pageSize"]),
                expected=self._expected,
            )
        if guard is not None:
            items = guard.check(items, token or None, total)
        on_total = self._on_total
        if on_total is not None and total is not None:
            on_total(total)
            self._on_total = None  # once: later pages repeat it
        if token:
            self.query["pageToken"] = token
        else:
            self.more = False
        return items


def _plain_query(params: Mapping[str, str | int]) -> str | None:
    """``?key=value&...`` when no key or value needs quoting, else None."""
    parts = []
    for key, value in params.items():
        if type(value) is int:
            text = str(value)
        elif type(value) is str and _PLAIN_QUERY.fullmatch(value) is not None:
            text = value
        else:
            return None
        if _PLAIN_QUERY.fullmatch(key) is None:
            return None
        parts.append(f"{key}={text}")
    return "?" + "&".join(parts)


def _id(value: IdLike) -> str:
    """An ID for a URL path; parsing it also keeps anything but a UUID out of the path."""
    if isinstance(value, uuid.UUID):
        return str(value)
    try:
        return str(uuid.UUID(value))
    except (ValueError, AttributeError, TypeError):
        raise ValueError(f"not a UUID: {value!r}") from None


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
    return ApiStatusError(**common, retry_after=answer_retry_after(response))
