"""A job's logs: the listing (`GET .../jobs/{jobID}/logs`) and the files in storage.

Every job that ran has its container's output (CONTAINER_LOG); those that reached their
metrics also uploaded `emissions.resim.jsonl` (EMISSIONS_LOG, see _emissions.py). The
listing is paged like the others, filters on `type` (repeatable) and `name`, and hands out
presigned `logOutputLocation` URLs into the storage origin.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from datetime import timedelta
from typing import Final

from aiohttp import web

from stook.emulator._emissions import EMISSIONS_FILE
from stook.emulator._json import Json, timestamp
from stook.emulator._middleware import error_response, json_response
from stook.emulator._paging import PagingError, paginate
from stook.emulator._state import EmulatorState
from stook.emulator._world import JobSpec

__all__ = ["LOG_TYPES", "add_job_log_routes", "add_log_storage_routes"]

# The API spec's logType enum: a `type` filter outside it answers 400.
LOG_TYPES: Final = frozenset(
    {
        "OTHER_LOG",
        "METRICS_OUTPUT_LOG",
        "CONTAINER_LOG",
        "EXECUTION_LOG",
        "MCAP_LOG",
        "MP4_LOG",
        "ARCHIVE_LOG",
        "FOXGLOVE_MCAP_LOG",
        "RERUN_IO_LOG",
        "ERROR_LOG",
        "SERVICE_LOG",
        "EMISSIONS_LOG",
        "SYSTEM_LOG",
    }
)
_CONTAINER_FILE: Final = "experience-container.log"


@dataclass(frozen=True, slots=True)
class _Log:
    id: uuid.UUID
    name: str
    log_type: str
    body: bytes
    checksum: str


def _job_logs(state: EmulatorState, job: JobSpec) -> list[_Log]:
    """A job's logs in listing order: its container's output, then its emissions."""
    if job.conflated_status == "CANCELLED":
        return []
    container = f"experience {job.experience.name}: {job.job_status}\n".encode()
    logs = [
        _Log(uuid.uuid5(job.id, "log:container"), _CONTAINER_FILE, "CONTAINER_LOG", container, "")
    ]
    emitted = state.dataset.emissions_log(job.batch_id, job.id)
    if emitted is not None:
        logs.append(
            _Log(
                uuid.uuid5(job.id, "log:emissions"),
                EMISSIONS_FILE,
                "EMISSIONS_LOG",
                emitted.body,
                emitted.checksum,
            )
        )
    return logs


def _find_job(state: EmulatorState, request: web.Request) -> JobSpec | web.Response:
    ds = state.dataset
    info = request.match_info
    try:
        project_id, batch_id, job_id = (
            uuid.UUID(info[k]) for k in ("project_id", "batch_id", "job_id")
        )
    except ValueError:
        return error_response(400, "projectID, batchID and jobID must be UUIDs")
    if project_id != ds.project_id:
        return error_response(404, f"project {project_id} not found")
    if ds.batch(batch_id) is None:
        return error_response(404, f"batch {batch_id} not found")
    job = ds.job(batch_id, job_id)
    if job is None:
        return error_response(404, f"job {job_id} not found in batch {batch_id}")
    return job


def _log_path(state: EmulatorState, bucket: str, job: JobSpec, log: _Log) -> str:
    return (
        f"/{bucket}/projects/{state.dataset.project_id}/batches/{job.batch_id}"
        f"/jobs/{job.id}/logs/{log.id}"
    )


def _log_json(state: EmulatorState, bucket: str, job: JobSpec, log: _Log) -> Json:
    ds = state.dataset
    return {
        "logID": str(log.id),
        "jobID": str(job.id),
        "fileName": log.name,
        "fileSize": len(log.body),
        "checksum": log.checksum,
        "creationTimestamp": timestamp(job.created + timedelta(minutes=3)),
        "location": f"s3://emulated-resim/{ds.project_id}/{job.batch_id}/{job.id}/{log.name}",
        "logOutputLocation": state.presign(_log_path(state, bucket, job, log)),
        "executionStep": "EXPERIENCE",
        "logType": log.log_type,
        "userID": str(ds.user_id),
        "orgID": ds.org_id,
        "filePath": "",
        "fullPath": log.name,
    }


def add_job_log_routes(
    app: web.Application, state: EmulatorState, prefix: str, bucket: str
) -> None:
    """`GET {prefix}/batches/{batchID}/jobs/{jobID}/logs` on the API origin; the URLs it
    hands out point into `bucket` on the storage origin."""

    async def list_job_logs(request: web.Request) -> web.Response:
        job = _find_job(state, request)
        if isinstance(job, web.Response):
            return job
        types = request.query.getall("type", [])
        for log_type in types:
            if log_type not in LOG_TYPES:
                return error_response(400, f"type {log_type!r} is not a log type")
        name = request.query.get("name")
        logs = [
            log
            for log in _job_logs(state, job)
            if (not types or log.log_type in types) and (name is None or log.name == name)
        ]
        key = f"job-logs:{job.id}:{sorted(types)}:{name}"
        try:
            page = paginate(
                logs,
                request.query,
                key,
                default=state.config.default_page_size,
                maximum=state.config.max_page_size,
            )
        except PagingError as exc:
            return error_response(400, str(exc))
        quirks = state.quirks
        return json_response(
            quirks.page(
                {
                    "logs": [
                        quirks.other(_log_json(state, bucket, job, log)) for log in page.items
                    ],
                    "nextPageToken": page.next_token,
                    "total": page.total,
                }
            )
        )

    app.router.add_get(
        f"{prefix}/batches/{{batch_id}}/jobs/{{job_id}}/logs", list_job_logs, name="list_job_logs"
    )


def add_log_storage_routes(app: web.Application, state: EmulatorState, bucket: str) -> None:
    """Each job log's file on the storage origin (behind its middleware's signature check)."""

    async def job_log(request: web.Request) -> web.Response:
        job = _find_job(state, request)
        if isinstance(job, web.Response):
            raise web.HTTPNotFound()
        log_id = request.match_info["log_id"]
        for log in _job_logs(state, job):
            if str(log.id) == log_id:
                return web.Response(body=log.body, content_type="application/octet-stream")
        raise web.HTTPNotFound()

    app.router.add_get(
        f"/{bucket}/projects/{{project_id}}/batches/{{batch_id}}/jobs/{{job_id}}/logs/{{log_id}}",
        job_log,
        name="job_log",
    )
