"""The two aiohttp applications: the REST API origin and the object-storage origin."""

from __future__ import annotations

import asyncio
import json
import math
import time
import uuid
from collections import Counter
from collections.abc import Awaitable, Callable
from datetime import timedelta
from typing import Any

from aiohttp import web

from stook.emulator import _json
from stook.emulator._config import EmulatorConfig, Origin
from stook.emulator._dataset import BatchKind, Dataset, MetricsOutput
from stook.emulator._faults import (
    Fault,
    FaultInjector,
    FaultKind,
    Latency,
    OutageSchedule,
    TokenBucket,
)
from stook.emulator._paging import PagingError, paginate
from stook.emulator._quirks import SpecQuirks
from stook.emulator._search import SearchError, parse_search
from stook.emulator._signing import UrlSigner
from stook.emulator._stats import EmulatorStats

API_PREFIX = "/v1"
BUCKET = "emulated-resim-metrics"
Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]
# What EmulatorConfig.corrupt_data_jobs serve instead of a MetricsData message: a first
# tag with wire type 7, which no protobuf parser accepts.
CORRUPT_BLOB = b"\xff\xff\xff\xff corrupt metrics data"


class ApiError(Exception):
    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


class EmulatorState:
    """Everything the handlers share; lives on the server's event loop only."""

    def __init__(self, config: EmulatorConfig, dataset: Dataset | None = None) -> None:
        self.config = config
        self.dataset = dataset or Dataset(config)
        self.stats = EmulatorStats()
        self.faults = FaultInjector(config)
        self.latency = Latency(config)
        self.quirks = SpecQuirks(config)
        self.outages = OutageSchedule(config.outages, time.monotonic())
        self.in_latency: Counter[str] = Counter()  # requests waiting out their latency now
        self.clock_offset = 0.0
        self.storage_url = ""  # known once the storage site is bound
        # The secret only has to be unguessable by clients, not secret across runs.
        self.signer = UrlSigner(
            uuid.uuid5(self.dataset.project_id, "url-secret").bytes, config.url_lifetime_s
        )
        now = self.now()
        self.buckets: dict[Origin, TokenBucket] = {}
        if config.rate_limit_rps is not None:
            self.buckets["api"] = TokenBucket(config.rate_limit_rps, config.rate_limit_burst, now)
        if config.storage_rate_limit_rps is not None:
            self.buckets["storage"] = TokenBucket(
                config.storage_rate_limit_rps, config.storage_rate_limit_burst, now
            )

    def now(self) -> float:
        return time.time() + self.clock_offset

    def presign(self, path: str) -> str:
        return self.signer.sign(self.storage_url, path, self.now())


# ---- shared request plumbing ----


def _json_response(
    body: Any, status: int = 200, headers: dict[str, str] | None = None
) -> web.Response:
    return web.Response(
        body=json.dumps(body, separators=(",", ":")).encode(),
        status=status,
        content_type="application/json",
        headers=headers,
    )


def _error(status: int, message: str, headers: dict[str, str] | None = None) -> web.Response:
    return _json_response(_json.error(status, message), status, headers)


async def _apply_fault(
    request: web.Request, fault: Fault, handler: Handler, stats: EmulatorStats, origin: str
) -> web.StreamResponse:
    stats.faults[f"{origin}:{fault.kind.value}"] += 1
    if fault.kind is FaultKind.SERVER_ERROR:
        return _error(fault.status, "injected transient server error")
    if fault.kind is FaultKind.RATE_LIMITED:
        return _error(429, "injected rate limit", {"Retry-After": str(fault.retry_after_s)})
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


def _route_name(request: web.Request) -> str:
    route = request.match_info.route
    return route.name or ("unknown" if route.resource is None else route.resource.canonical)


async def _admit(state: EmulatorState, request: web.Request, origin: Origin) -> web.Response | None:
    """Latency and rate limiting, common to both origins; an answer if refused."""
    stats = state.stats
    stats.requests[origin] += 1
    stats.endpoints[f"{origin}:{_route_name(request)}"] += 1
    now = time.monotonic()
    window = state.outages.refuses(origin, stats.requests[origin] - 1, now)
    if window is not None:
        # Before the latency: a load balancer with nothing behind it answers at once.
        stats.outage_refusals[origin] += 1
        if window not in stats.outage_windows:
            stats.outage_windows.append(window)
        return _error(503, "service unavailable (emulated outage)")
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
            return _error(429, "rate limit exceeded", {"Retry-After": str(math.ceil(wait))})
    return None


def _finish(
    stats: EmulatorStats, origin: str, response: web.StreamResponse, fault: Fault | None = None
) -> web.StreamResponse:
    # A reset or truncated answer never arrives whole; count it as what the client sees.
    broken = fault is not None and fault.kind in (FaultKind.RESET, FaultKind.TRUNCATED)
    label = fault.kind.value if broken and fault is not None else str(response.status)
    stats.statuses[f"{origin}:{label}"] += 1
    if broken:
        return response
    if isinstance(response, web.Response) and isinstance(response.body, bytes):
        stats.bytes_served[origin] += len(response.body)
    return response


# ---- the API origin ----


def build_api_app(state: EmulatorState) -> web.Application:
    expected = f"Bearer {state.config.token}"

    @web.middleware
    async def middleware(request: web.Request, handler: Handler) -> web.StreamResponse:
        refused = await _admit(state, request, "api")
        if refused is not None:
            return _finish(state.stats, "api", refused)
        revoke_after = state.config.revoke_token_after_requests
        expired = revoke_after is not None and state.stats.requests["api"] > revoke_after
        if request.headers.get("Authorization") != expected or expired:
            state.stats.unauthorized += 1
            return _finish(state.stats, "api", _error(401, "missing or invalid bearer token"))
        fault = state.faults.decide("api", request.method, request.path_qs)
        try:
            if fault is not None:
                response = await _apply_fault(request, fault, handler, state.stats, "api")
            else:
                response = await handler(request)
        except ApiError as exc:
            response = _error(exc.status, exc.message)
        except web.HTTPException as exc:
            response = _error(exc.status, exc.reason)
        return _finish(state.stats, "api", response, fault)

    app = web.Application(middlewares=[middleware])
    routes = _ApiRoutes(state)
    p = f"{API_PREFIX}/projects/{{project_id}}"
    app.router.add_get(f"{p}/batches", routes.list_batches, name="list_batches")
    app.router.add_get(f"{p}/batches/{{batch_id}}", routes.get_batch, name="get_batch")
    app.router.add_get(f"{p}/batches/{{batch_id}}/jobs", routes.list_jobs, name="list_jobs")
    app.router.add_get(f"{p}/batches/{{batch_id}}/jobs/{{job_id}}", routes.get_job, name="get_job")
    app.router.add_get(
        f"{p}/batches/{{batch_id}}/jobs/{{job_id}}/metrics",
        routes.list_job_metrics,
        name="list_job_metrics",
    )
    app.router.add_get(
        f"{p}/batches/{{batch_id}}/jobs/{{job_id}}/metricsData",
        routes.list_job_metrics_data,
        name="list_job_metrics_data",
    )
    app.router.add_get(
        f"{p}/batches/{{batch_id}}/metrics", routes.list_batch_metrics, name="list_batch_metrics"
    )
    app.router.add_get(
        f"{p}/batches/{{batch_id}}/metricsData",
        routes.list_batch_metrics_data,
        name="list_batch_metrics_data",
    )
    app.router.add_get(f"{p}/reports/{{report_id}}", routes.get_report, name="get_report")
    app.router.add_get(f"{p}/builds/{{build_id}}", routes.get_build, name="get_build")
    app.router.add_get(
        f"{p}/experiences/{{experience_id}}/experienceTags",
        routes.list_experience_tags,
        name="list_experience_tags",
    )
    app.router.add_get("/_emulator/stats", routes.emulator_stats, name="emulator_stats")
    return app


def _uuid_arg(request: web.Request, key: str) -> uuid.UUID:
    text = request.match_info[key]
    try:
        return uuid.UUID(text)
    except ValueError:
        raise ApiError(400, f"{key} {text!r} is not a valid UUID") from None


class _ApiRoutes:
    def __init__(self, state: EmulatorState) -> None:
        self.state = state
        self.ds = state.dataset
        self.quirks = state.quirks

    # ---- lookups that 400 on malformed IDs and 404 on unknown ones ----

    def _project(self, request: web.Request) -> None:
        if _uuid_arg(request, "project_id") != self.ds.project_id:
            raise ApiError(404, f"project {request.match_info['project_id']} not found")

    def _batch(self, request: web.Request) -> uuid.UUID:
        self._project(request)
        batch_id = _uuid_arg(request, "batch_id")
        if self.ds.batch(batch_id) is None:
            raise ApiError(404, f"batch {batch_id} not found")
        return batch_id

    def _job(self, request: web.Request) -> tuple[uuid.UUID, uuid.UUID]:
        batch_id = self._batch(request)
        job_id = _uuid_arg(request, "job_id")
        if self.ds.job(batch_id, job_id) is None:
            raise ApiError(404, f"job {job_id} not found in batch {batch_id}")
        return batch_id, job_id

    def _page(self, request: web.Request, items: list[Any], key: str) -> tuple[list[Any], str, int]:
        config = self.state.config
        try:
            page = paginate(
                items,
                request.query,
                key,
                default=config.default_page_size,
                maximum=config.max_page_size,
            )
        except PagingError as exc:
            raise ApiError(400, str(exc)) from None
        return list(page.items), page.next_token, page.total

    def _broken(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> bool:
        broken = self.state.config.broken_jobs
        if not broken or batch_id != self.ds.main_batch_id:
            return False
        job = self.ds.job(batch_id, job_id)
        return job is not None and job.index in broken

    # ---- handlers ----

    async def list_batches(self, request: web.Request) -> web.Response:
        self._project(request)
        try:
            filters = parse_search(request.query.get("search", ""))
        except SearchError as exc:
            raise ApiError(400, str(exc)) from None
        found = [b for b in self.ds.batches if all(f(b) for f in filters)]
        # Newest first, as the platform lists; clients must sort for time order.
        found.sort(key=lambda b: b.created, reverse=True)
        key = f"batches:{request.query.get('search', '')}"
        items, token, total = self._page(request, found, key)
        return _json_response(
            self.quirks.page(
                {
                    "batches": [self.quirks.batch(_json.batch(self.ds, b)) for b in items],
                    "nextPageToken": token,
                    "total": total,
                }
            )
        )

    async def get_batch(self, request: web.Request) -> web.Response:
        batch = self.ds.batch(self._batch(request))
        assert batch is not None
        return _json_response(self.quirks.batch(_json.batch(self.ds, batch)))

    async def list_jobs(self, request: web.Request) -> web.Response:
        batch_id = self._batch(request)
        items, token, total = self._page(request, list(self.ds.jobs(batch_id)), f"jobs:{batch_id}")
        return _json_response(
            self.quirks.page(
                {
                    "jobs": [self.quirks.job(j, _json.job(self.ds, j)) for j in items],
                    "nextPageToken": token,
                    "total": total,
                }
            )
        )

    async def get_job(self, request: web.Request) -> web.Response:
        batch_id, job_id = self._job(request)
        job = self.ds.job(batch_id, job_id)
        assert job is not None
        return _json_response(self.quirks.job(job, _json.job(self.ds, job)))

    def _job_output(self, request: web.Request) -> tuple[uuid.UUID, uuid.UUID, MetricsOutput]:
        batch_id, job_id = self._job(request)
        if self._broken(batch_id, job_id):
            self.state.stats.broken_job_answers += 1
            raise ApiError(500, f"job {job_id} is broken (emulated permanent server error)")
        output = self.ds.job_output(batch_id, job_id)
        assert output is not None
        return batch_id, job_id, self.quirks.job_output(output)

    async def list_job_metrics(self, request: web.Request) -> web.Response:
        batch_id, job_id, output = self._job_output(request)
        job = self.ds.job(batch_id, job_id)
        assert job is not None
        items, token, _ = self._page(request, list(output.metrics), f"job-metrics:{job_id}")
        base = f"/{BUCKET}/projects/{self.ds.project_id}/batches/{batch_id}/jobs/{job_id}"
        owner = {"jobID": str(job_id), "batchID": str(batch_id)}
        created = job.created + timedelta(minutes=3)
        return _json_response(
            self.quirks.page(
                {
                    "metrics": [
                        self.quirks.metric(
                            m,
                            _json.metric(
                                self.ds,
                                m,
                                self.state.presign(f"{base}/metrics/{m.id}"),
                                created,
                                owner,
                            ),
                            job,
                        )
                        for m in items
                    ],
                    "nextPageToken": token,
                }
            )
        )

    async def list_job_metrics_data(self, request: web.Request) -> web.Response:
        batch_id, job_id, output = self._job_output(request)
        job = self.ds.job(batch_id, job_id)
        assert job is not None
        items, token, _ = self._page(request, list(output.data), f"job-data:{job_id}")
        base = f"/{BUCKET}/projects/{self.ds.project_id}/batches/{batch_id}/jobs/{job_id}"
        owner = {"jobID": str(job_id)}
        created = job.created + timedelta(minutes=3)
        return _json_response(
            self.quirks.page(
                {
                    "metricsData": [
                        self.quirks.other(
                            _json.metrics_data(
                                d,
                                self.state.presign(f"{base}/metricsData/{d.id}"),
                                created,
                                owner,
                                self.ds,
                            )
                        )
                        for d in items
                    ],
                    "nextPageToken": token,
                }
            )
        )

    def _batch_output(self, request: web.Request) -> tuple[uuid.UUID, MetricsOutput | None]:
        batch_id = self._batch(request)
        batch = self.ds.batch(batch_id)
        assert batch is not None
        # The main batch is the one whose batch metrics are being computed right now.
        if batch.kind is BatchKind.MAIN:
            return batch_id, None
        return batch_id, self.ds.batch_output(batch_id)

    async def list_batch_metrics(self, request: web.Request) -> web.Response:
        batch_id, output = self._batch_output(request)
        metrics = list(output.metrics) if output is not None else []
        items, token, _ = self._page(request, metrics, f"batch-metrics:{batch_id}")
        batch = self.ds.batch(batch_id)
        assert batch is not None
        base = f"/{BUCKET}/projects/{self.ds.project_id}/batches/{batch_id}"
        created = batch.created + timedelta(minutes=30)
        return _json_response(
            self.quirks.page(
                {
                    "batchMetrics": [
                        self.quirks.metric(
                            m,
                            _json.metric(
                                self.ds,
                                m,
                                self.state.presign(f"{base}/metrics/{m.id}"),
                                created,
                                {"batchID": str(batch_id)},
                            ),
                        )
                        for m in items
                    ],
                    "nextPageToken": token,
                }
            )
        )

    async def list_batch_metrics_data(self, request: web.Request) -> web.Response:
        batch_id, output = self._batch_output(request)
        data = list(output.data) if output is not None else []
        items, token, _ = self._page(request, data, f"batch-data:{batch_id}")
        batch = self.ds.batch(batch_id)
        assert batch is not None
        base = f"/{BUCKET}/projects/{self.ds.project_id}/batches/{batch_id}"
        created = batch.created + timedelta(minutes=30)
        return _json_response(
            self.quirks.page(
                {
                    "batchMetricsData": [
                        self.quirks.other(
                            _json.metrics_data(
                                d,
                                self.state.presign(f"{base}/metricsData/{d.id}"),
                                created,
                                {"batchID": str(batch_id)},
                                self.ds,
                            )
                        )
                        for d in items
                    ],
                    "nextPageToken": token,
                }
            )
        )

    async def get_report(self, request: web.Request) -> web.Response:
        self._project(request)
        report = self.ds.reports.get(_uuid_arg(request, "report_id"))
        if report is None:
            raise ApiError(404, f"report {request.match_info['report_id']} not found")
        return _json_response(self.quirks.other(_json.report(self.ds, report)))

    async def get_build(self, request: web.Request) -> web.Response:
        self._project(request)
        build = self.ds.builds.get(_uuid_arg(request, "build_id"))
        if build is None:
            raise ApiError(404, f"build {request.match_info['build_id']} not found")
        return _json_response(self.quirks.other(_json.build(self.ds, build)))

    async def list_experience_tags(self, request: web.Request) -> web.Response:
        self._project(request)
        experience = self.ds.experience(_uuid_arg(request, "experience_id"))
        if experience is None:
            raise ApiError(404, f"experience {request.match_info['experience_id']} not found")
        items, token, _ = self._page(
            request, list(experience.tags), f"experience-tags:{experience.id}"
        )
        return _json_response(
            self.quirks.page(
                {
                    "experienceTags": [
                        self.quirks.other(_json.experience_tag(self.ds, t)) for t in items
                    ],
                    "nextPageToken": token,
                }
            )
        )

    async def emulator_stats(self, request: web.Request) -> web.Response:
        return _json_response(self.state.stats.to_dict())


# ---- the object-storage origin ----


def build_storage_app(state: EmulatorState) -> web.Application:
    @web.middleware
    async def middleware(request: web.Request, handler: Handler) -> web.StreamResponse:
        stats = state.stats
        if "Authorization" in request.headers:
            # A presigned request must not carry the API token: record the leak first,
            # whatever else happens to the request, then refuse it as S3 does.
            stats.requests["storage"] += 1
            stats.storage_authorization.append(request.path)
            return _finish(
                stats,
                "storage",
                _s3_error(400, "InvalidArgument", "Only one auth mechanism allowed"),
            )
        refused = await _admit(state, request, "storage")
        if refused is not None:
            return _finish(stats, "storage", refused)
        problem = state.signer.check(request.path, request.query, state.now())
        if problem is not None:
            if problem == "request has expired":
                stats.expired_urls += 1
            else:
                stats.bad_signatures += 1
            return _finish(stats, "storage", _s3_error(403, "AccessDenied", problem))
        # Keyed on the object, not the URL: a re-listed URL differs only in its
        # signature, and faults should not depend on the time a URL was signed.
        fault = state.faults.decide("storage", request.method, request.path)
        try:
            if fault is not None:
                response = await _apply_fault(request, fault, handler, stats, "storage")
            else:
                response = await handler(request)
        except web.HTTPException as exc:
            response = _s3_error(exc.status, "NoSuchKey", exc.reason)
        return _finish(stats, "storage", response, fault)

    routes = _StorageRoutes(state)
    app = web.Application(middlewares=[middleware])
    base = f"/{BUCKET}/projects/{{project_id}}/batches/{{batch_id}}"
    app.router.add_get(
        f"{base}/jobs/{{job_id}}/metrics/{{object_id}}", routes.job_metric, name="job_metric"
    )
    app.router.add_get(
        f"{base}/jobs/{{job_id}}/metricsData/{{object_id}}",
        routes.job_data,
        name="job_metrics_data",
    )
    app.router.add_get(f"{base}/metrics/{{object_id}}", routes.batch_metric, name="batch_metric")
    app.router.add_get(
        f"{base}/metricsData/{{object_id}}", routes.batch_data, name="batch_metrics_data"
    )
    return app


def _s3_error(status: int, code: str, message: str) -> web.Response:
    body = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f"<Error><Code>{code}</Code><Message>{message}</Message></Error>"
    )
    return web.Response(body=body.encode(), status=status, content_type="application/xml")


class _StorageRoutes:
    def __init__(self, state: EmulatorState) -> None:
        self.ds = state.dataset
        self.quirks = state.quirks
        self.corrupt = frozenset(state.config.corrupt_data_jobs)

    def _ids(self, request: web.Request, *keys: str) -> list[uuid.UUID]:
        try:
            return [uuid.UUID(request.match_info[k]) for k in keys]
        except ValueError:
            raise web.HTTPNotFound() from None

    def _job_output(self, request: web.Request) -> tuple[MetricsOutput, uuid.UUID]:
        batch_id, job_id, object_id = self._ids(request, "batch_id", "job_id", "object_id")
        output = self.ds.job_output(batch_id, job_id)
        if output is None:
            raise web.HTTPNotFound()
        return self.quirks.job_output(output), object_id

    def _batch_output(self, request: web.Request) -> tuple[MetricsOutput, uuid.UUID]:
        batch_id, object_id = self._ids(request, "batch_id", "object_id")
        output = self.ds.batch_output(batch_id)
        if output is None:
            raise web.HTTPNotFound()
        return output, object_id

    async def job_metric(self, request: web.Request) -> web.Response:
        output, object_id = self._job_output(request)
        return _metric_body(output, object_id)

    async def job_data(self, request: web.Request) -> web.Response:
        output, object_id = self._job_output(request)
        response = _data_body(output, object_id)
        if self.corrupt and self._is_corrupt(request):
            return web.Response(body=CORRUPT_BLOB, content_type=response.content_type)
        return response

    def _is_corrupt(self, request: web.Request) -> bool:
        batch_id, job_id = self._ids(request, "batch_id", "job_id")
        if batch_id != self.ds.main_batch_id:
            return False
        job = self.ds.job(batch_id, job_id)
        return job is not None and job.index in self.corrupt

    async def batch_metric(self, request: web.Request) -> web.Response:
        output, object_id = self._batch_output(request)
        return _metric_body(output, object_id)

    async def batch_data(self, request: web.Request) -> web.Response:
        output, object_id = self._batch_output(request)
        return _data_body(output, object_id)


def _metric_body(output: MetricsOutput, metric_id: uuid.UUID) -> web.Response:
    metric = output.metric(metric_id)
    if metric is None:
        raise web.HTTPNotFound()
    return web.Response(body=metric.body, content_type="application/octet-stream")


def _data_body(output: MetricsOutput, data_id: uuid.UUID) -> web.Response:
    item = output.data_item(data_id)
    if item is None:
        raise web.HTTPNotFound()
    return web.Response(body=item.body, content_type=item.content_type)
