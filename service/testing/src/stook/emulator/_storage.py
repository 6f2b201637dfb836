"""The object-storage origin: each stored Metric and MetricsData at a presigned URL.

Requests must carry a valid, unexpired signature and no API token; errors answer as S3
does, in XML.
"""

from __future__ import annotations

import uuid

from aiohttp import web

from stook.emulator._middleware import (
    Handler,
    admit,
    apply_fault,
    in_flight_limit,
    record_response,
)
from stook.emulator._state import EmulatorState
from stook.emulator._store import MetricsOutput

BUCKET = "emulated-resim-metrics"
# What EmulatorConfig.corrupt_data_jobs serve instead of a MetricsData message: a first
# tag with wire type 7, which no protobuf parser accepts.
CORRUPT_BLOB = b"\xff\xff\xff\xff corrupt metrics data"


def build_storage_app(state: EmulatorState) -> web.Application:
    @web.middleware
    async def middleware(request: web.Request, handler: Handler) -> web.StreamResponse:
        stats = state.stats
        if "Authorization" in request.headers:
            # A presigned request must not carry the API token: record the leak first,
            # whatever else happens to the request, then refuse it as S3 does.
            stats.requests["storage"] += 1
            stats.storage_authorization.append(request.path)
            return record_response(
                stats,
                "storage",
                _s3_error(400, "InvalidArgument", "Only one auth mechanism allowed"),
            )
        refused = await admit(state, request, "storage")
        if refused is not None:
            return record_response(stats, "storage", refused)
        problem = state.signer.check(request.path, request.query, state.now())
        if problem is not None:
            if problem == "request has expired":
                stats.expired_urls += 1
            else:
                stats.bad_signatures += 1
            return record_response(stats, "storage", _s3_error(403, "AccessDenied", problem))
        # Keyed on the object, not the URL: a re-listed URL differs only in its
        # signature, and faults should not depend on the time a URL was signed.
        fault = state.faults.decide("storage", request.method, request.path)
        try:
            if fault is not None:
                response = await apply_fault(request, fault, handler, stats, "storage")
            else:
                response = await handler(request)
        except web.HTTPException as exc:
            response = _s3_error(exc.status, "NoSuchKey", exc.reason)
        return record_response(stats, "storage", response, fault)

    routes = _StorageRoutes(state)
    app = web.Application(middlewares=[*in_flight_limit(state, "storage"), middleware])
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
