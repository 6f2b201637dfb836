"""The REST API origin: bearer-token auth and the endpoints batch and report modes use.

Lists are paged; IDs that do not parse answer 400 and unknown ones 404, as ReSim's API
does. Metrics and metrics data are listed with presigned URLs into the storage origin.
"""

from __future__ import annotations

import functools
import uuid
from collections import OrderedDict
from datetime import datetime, timedelta
from typing import Any, Final

import orjson
from aiohttp import web

from stook.emulator import _json
from stook.emulator._branch_routes import add_branch_routes
from stook.emulator._job_logs import add_job_log_routes
from stook.emulator._middleware import (
    Handler,
    admit,
    apply_fault,
    error_response,
    in_flight_limit,
    json_bytes_response,
    json_response,
    record_response,
)
from stook.emulator._page_templates import PLACEHOLDER, PageTemplate
from stook.emulator._paging import PagingError, paginate
from stook.emulator._search import SearchError, parse_search
from stook.emulator._state import EmulatorState
from stook.emulator._storage import BUCKET
from stook.emulator._store import MetricsOutput
from stook.emulator._world import BatchKind, Experience

API_PREFIX = "/v1"
# Job listing pages kept serialized (about 120 KB each at 100 jobs): a report lists each
# of its batches' jobs once a run, and a job's fields never change.
_JOB_PAGES_KEPT: Final = 512


class ApiError(Exception):
    """A handler's refusal, answered by the middleware as the API's JSON error."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


def build_api_app(state: EmulatorState) -> web.Application:
    expected = f"Bearer {state.config.token}"

    @web.middleware
    async def middleware(request: web.Request, handler: Handler) -> web.StreamResponse:
        refused = await admit(state, request, "api")
        if refused is not None:
            return record_response(state.stats, "api", refused)
        revoke_after = state.config.revoke_token_after_requests
        expired = revoke_after is not None and state.stats.requests["api"] > revoke_after
        if request.headers.get("Authorization") != expected or expired:
            state.stats.unauthorized += 1
            return record_response(
                state.stats, "api", error_response(401, "missing or invalid bearer token")
            )
        fault = state.faults.decide("api", request.method, request.path_qs)
        try:
            if fault is not None:
                response = await apply_fault(request, fault, handler, state.stats, "api")
            else:
                response = await handler(request)
        except ApiError as exc:
            response = error_response(exc.status, exc.message)
        except web.HTTPException as exc:
            response = error_response(exc.status, exc.reason)
        return record_response(state.stats, "api", response, fault)

    app = web.Application(middlewares=[*in_flight_limit(state, "api"), middleware])
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
    job = f"{p}/batches/{{batch_id}}/jobs/{{job_id}}"
    app.router.add_get(f"{job}/events", routes.list_events, name="list_events")
    app.router.add_get(f"{job}/events/{{event_id}}", routes.get_event, name="get_event")
    app.router.add_get(f"{job}/eventMetrics", routes.list_event_metrics, name="list_event_metrics")
    app.router.add_get(f"{job}/eventTags", routes.list_event_tags, name="list_event_tags")
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
        f"{p}/experiences/{{experience_id}}", routes.get_experience, name="get_experience"
    )
    app.router.add_get(
        f"{p}/experiences/{{experience_id}}/experienceTags",
        routes.list_experience_tags,
        name="list_experience_tags",
    )
    add_branch_routes(app, state, p)
    add_job_log_routes(app, state, p, BUCKET)
    app.router.add_get("/_emulator/stats", routes.emulator_stats, name="emulator_stats")
    return app


def _uuid_arg(request: web.Request, key: str) -> uuid.UUID:
    text = request.match_info[key]
    try:
        return _parse_uuid(text)
    except ValueError:
        raise ApiError(400, f"{key} {text!r} is not a valid UUID") from None


# Every request names its project, and a job's its batch and job: parsed once each (a
# refused text raises again, uncached).
_parse_uuid = functools.lru_cache(maxsize=65_536)(uuid.UUID)


class _ApiRoutes:
    def __init__(self, state: EmulatorState) -> None:
        self.state = state
        self.ds = state.dataset
        self.quirks = state.quirks
        # Each job listing page's bytes, by batch and the page asked for; the most
        # recently served last.
        self._job_pages: OrderedDict[tuple[uuid.UUID, str, str], bytes] = OrderedDict()

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

    @staticmethod
    def _no_filter(request: web.Request, *names: str) -> None:
        """The spec's optional filters this emulator does not implement answer 400, so that
        a client relying on one fails loudly instead of reading an unfiltered list."""
        for name in names:
            if name in request.query:
                raise ApiError(400, f"the emulator does not implement the {name!r} filter")

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
        return json_response(
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
        return json_response(self.quirks.batch(_json.batch(self.ds, batch)))

    async def list_jobs(self, request: web.Request) -> web.Response:
        batch_id = self._batch(request)
        items, token, total = self._page(request, list(self.ds.jobs(batch_id)), f"jobs:{batch_id}")
        # Serialized once a page: the same jobs' JSON objects were nearly a tenth of the
        # emulator's CPU in a report run, on the two cores it shares with the client.
        query = request.query
        page = (batch_id, query.get("pageSize") or "", query.get("pageToken") or "")
        body = self._job_pages.get(page)
        if body is None:
            body = orjson.dumps(
                self.quirks.page(
                    {
                        "jobs": [self.quirks.job(j, _json.job(self.ds, j)) for j in items],
                        "nextPageToken": token,
                        "total": total,
                    }
                )
            )
            self._job_pages[page] = body
            if len(self._job_pages) > _JOB_PAGES_KEPT:
                self._job_pages.popitem(last=False)
        else:
            self._job_pages.move_to_end(page)
        return json_bytes_response(body)

    async def get_job(self, request: web.Request) -> web.Response:
        batch_id, job_id = self._job(request)
        job = self.ds.job(batch_id, job_id)
        assert job is not None
        return json_response(self.quirks.job(job, _json.job(self.ds, job)))

    def _job_output(self, request: web.Request) -> tuple[uuid.UUID, uuid.UUID, MetricsOutput]:
        batch_id, job_id = self._job(request)
        if self._broken(batch_id, job_id):
            self.state.stats.broken_job_answers += 1
            raise ApiError(500, f"job {job_id} is broken (emulated permanent server error)")
        output = self.ds.job_output(batch_id, job_id)
        assert output is not None
        return batch_id, job_id, self.quirks.job_output(output)

    async def list_job_metrics(self, request: web.Request) -> web.Response:
        return self._job_metrics_answer(request, event_only=False)

    async def list_event_metrics(self, request: web.Request) -> web.Response:
        self._no_filter(request, "text")
        return self._job_metrics_answer(request, event_only=True)

    def _job_metrics_answer(self, request: web.Request, *, event_only: bool) -> web.Response:
        """A job's metrics (all, as `/metrics` lists them, or its event metrics only)."""
        batch_id, job_id, output = self._job_output(request)
        job = self.ds.job(batch_id, job_id)
        assert job is not None
        metrics = output.event_metrics if event_only else output.metrics
        # The job's ID as str() writes it, remembered (UUID.__str__ is Python code).
        key = f"job-{'event-' if event_only else ''}metrics:{_json._id(job_id)}"
        items, token, _ = self._page(request, list(metrics), key)
        # The page is the same but for its URLs' signatures: serialized once (see
        # _page_templates), per page of the listing.
        query = request.query
        page = (key, query.get("pageSize") or "", query.get("pageToken") or "")
        template = output.listing_pages.get(page)
        if template is None:
            base = f"/{BUCKET}/projects/{self.ds.project_id}/batches/{batch_id}/jobs/{job_id}"
            owner = {"jobID": str(job_id), "batchID": str(batch_id)}
            created = job.created + timedelta(minutes=3)
            body = self.quirks.page(
                {
                    "metrics": [
                        self.quirks.metric(
                            m, _json.metric(self.ds, m, PLACEHOLDER, created, owner), job
                        )
                        for m in items
                    ],
                    "nextPageToken": token,
                }
            )
            made = PageTemplate.of(body, [f"{base}/metrics/{m.id}" for m in items])
            if made is None:
                raise RuntimeError(f"{key}: a page's URLs do not fill its placeholders")
            template = output.listing_pages[page] = made
        return json_bytes_response(template.fill(map(self.state.presign, template.paths)))

    async def list_job_metrics_data(self, request: web.Request) -> web.Response:
        batch_id, job_id, output = self._job_output(request)
        job = self.ds.job(batch_id, job_id)
        assert job is not None
        items, token, _ = self._page(request, list(output.data), f"job-data:{job_id}")
        base = f"/{BUCKET}/projects/{self.ds.project_id}/batches/{batch_id}/jobs/{job_id}"
        owner = {"jobID": str(job_id)}
        created = job.created + timedelta(minutes=3)
        return json_response(
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

    async def list_events(self, request: web.Request) -> web.Response:
        self._no_filter(request, "eventTags")
        batch_id, job_id, output = self._job_output(request)
        job = self.ds.job(batch_id, job_id)
        assert job is not None
        items, token, _ = self._page(request, list(output.events), f"job-events:{job_id}")
        created = job.created + timedelta(minutes=3)
        return json_response(
            self.quirks.page(
                {
                    "events": [self.quirks.event(_json.event(e, created)) for e in items],
                    "nextPageToken": token,
                }
            )
        )

    async def get_event(self, request: web.Request) -> web.Response:
        batch_id, job_id, output = self._job_output(request)
        job = self.ds.job(batch_id, job_id)
        assert job is not None
        event_id = _uuid_arg(request, "event_id")
        event = output.event(event_id)
        if event is None:
            raise ApiError(404, f"event {event_id} not found in job {job_id}")
        created = job.created + timedelta(minutes=3)
        return json_response(self.quirks.event(_json.event(event, created)))

    async def list_event_tags(self, request: web.Request) -> web.Response:
        self._no_filter(request, "name")
        _, job_id, output = self._job_output(request)
        items, token, _ = self._page(request, output.event_tags, f"job-event-tags:{job_id}")
        return json_response(self.quirks.page({"eventTags": items, "nextPageToken": token}))

    def _batch_output(self, request: web.Request) -> tuple[uuid.UUID, MetricsOutput | None]:
        batch_id = self._batch(request)
        batch = self.ds.batch(batch_id)
        assert batch is not None
        # The main batch is the one whose batch metrics are being computed right now.
        if batch.kind is BatchKind.MAIN:
            return batch_id, None
        return batch_id, self.ds.batch_output(batch_id)

    def _batch_blobs(self, batch_id: uuid.UUID) -> tuple[str, datetime]:
        """Where a batch's metric blobs are stored, and when its metrics build wrote them."""
        batch = self.ds.batch(batch_id)
        assert batch is not None
        base = f"/{BUCKET}/projects/{self.ds.project_id}/batches/{batch_id}"
        return base, batch.created + timedelta(minutes=30)

    async def list_batch_metrics(self, request: web.Request) -> web.Response:
        batch_id, output = self._batch_output(request)
        metrics = list(output.metrics) if output is not None else []
        items, token, _ = self._page(request, metrics, f"batch-metrics:{batch_id}")
        base, created = self._batch_blobs(batch_id)
        return json_response(
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
        base, created = self._batch_blobs(batch_id)
        return json_response(
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
        return json_response(self.quirks.other(_json.report(self.ds, report)))

    async def get_build(self, request: web.Request) -> web.Response:
        self._project(request)
        build = self.ds.builds.get(_uuid_arg(request, "build_id"))
        if build is None:
            raise ApiError(404, f"build {request.match_info['build_id']} not found")
        return json_response(self.quirks.other(_json.build(self.ds, build)))

    def _experience(self, request: web.Request) -> Experience:
        self._project(request)
        experience = self.ds.experience(_uuid_arg(request, "experience_id"))
        if experience is None or experience.index in self.state.config.missing_experiences:
            raise ApiError(404, f"experience {request.match_info['experience_id']} not found")
        return experience

    async def get_experience(self, request: web.Request) -> web.Response:
        # The spec's answer requires customFields, so they are always there;
        # `includeCustomFields` (the listings' flag) changes nothing here.
        experience = self._experience(request)
        return json_response(self.quirks.other(_json.experience(self.ds, experience)))

    async def list_experience_tags(self, request: web.Request) -> web.Response:
        experience = self._experience(request)
        items, token, _ = self._page(
            request, list(experience.tags), f"experience-tags:{experience.id}"
        )
        return json_response(
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
        return json_response(self.state.stats.to_dict())
