"""The API's JSON objects, with the camelCase keys and enum spellings of ReSim's API."""

from __future__ import annotations

import functools
import uuid
from collections import Counter
from datetime import UTC, datetime, timedelta
from typing import Any

from stook.emulator._dataset import Dataset
from stook.emulator._store import StoredData, StoredEvent, StoredMetric
from stook.emulator._world import (
    BASE_TIME,
    BatchSpec,
    Build,
    Experience,
    ExperienceTag,
    JobSpec,
    ReportSpec,
)

Json = dict[str, Any]


# The same few IDs and times are written into every listing item: formatting them again
# each time was a fifth of the emulator's CPU per request (it shares the benchmark machine
# with the client it serves). Cached by value, so an answer's bytes do not change.
@functools.lru_cache(maxsize=65536)
def timestamp(moment: datetime) -> str:
    """RFC 3339 in UTC with a Z, as the API writes times."""
    return moment.isoformat().replace("+00:00", "Z")


@functools.lru_cache(maxsize=65536)
def _id(value: uuid.UUID) -> str:
    return str(value)


def job(ds: Dataset, j: JobSpec) -> Json:
    batch = ds.batch(j.batch_id)
    assert batch is not None
    finished = j.created + timedelta(minutes=3, seconds=j.index % 60)
    return {
        "jobID": str(j.id),
        "projectID": _id(ds.project_id),
        "batchID": str(j.batch_id),
        "systemID": str(ds.system_id),
        "branchID": str(batch.branch_id),
        "buildID": str(j.build_id),
        "experienceID": str(j.experience.id),
        "experienceName": j.experience.name,
        "experienceProfile": "",
        "description": "",
        "conflatedStatus": j.conflated_status,
        "jobStatus": j.job_status,
        "jobMetricsStatus": j.metrics_status,
        "statusHistory": [
            {"status": "SUBMITTED", "updatedAt": timestamp(j.created)},
            {"status": j.job_status, "updatedAt": timestamp(finished)},
        ],
        "creationTimestamp": timestamp(j.created),
        "lastRunTimestamp": timestamp(j.created),
        "lastUpdatedTimestamp": timestamp(finished),
        "outputLocation": f"s3://emulated-resim/{ds.project_id}/{j.batch_id}/{j.id}/",
        "parameters": j.parameter_map,
        "userID": _id(ds.user_id),
        "orgID": ds.org_id,
        "runCounter": 1,
    }


_JOB_STATUS_COUNT_KEYS = {
    "SUBMITTED": "submitted",
    "EXPERIENCE_RUNNING": "running",
    "SUCCEEDED": "succeeded",
    "ERROR": "error",
    "CANCELLED": "cancelled",
    "METRICS_QUEUED": "metricsQueued",
    "METRICS_RUNNING": "metricsRunning",
}
_METRICS_STATUS_COUNT_KEYS = {
    "PASSED": "passed",
    "RAW": "raw",
    "NO_STATUS_REPORTED": "noStatusReported",
    "NOT_APPLICABLE": "notApplicable",
    "FAIL_WARN": "failWarn",
    "FAIL_BLOCK": "failBlock",
}
_SEVERITY = ("NO_STATUS_REPORTED", "NOT_APPLICABLE", "RAW", "PASSED", "FAIL_WARN", "FAIL_BLOCK")


def batch(ds: Dataset, b: BatchSpec) -> Json:
    jobs = ds.jobs(b.id)
    job_counts = Counter(j.job_status for j in jobs)
    metrics_counts = Counter(j.metrics_status for j in jobs)
    conflated = Counter(j.conflated_status for j in jobs)
    if b.status != "SUCCEEDED":
        batch_conflated = "RUNNING"
    elif conflated["BLOCKER"]:
        batch_conflated = "BLOCKER"
    elif conflated["WARNING"]:
        batch_conflated = "WARNING"
    elif conflated["ERROR"]:
        batch_conflated = "ERROR"
    else:
        batch_conflated = "COMPLETE"
    worst = max((j.metrics_status for j in jobs), key=_SEVERITY.index, default="NO_STATUS_REPORTED")
    output = ds.batch_output(b.id)
    batch_status = output.truth.overall_status if output and b.status == "SUCCEEDED" else None
    updated = b.created + timedelta(minutes=30)
    return {
        "batchID": str(b.id),
        "projectID": _id(ds.project_id),
        "friendlyName": b.friendly_name,
        "description": "",
        "batchType": "NORMAL",
        "buildID": str(b.build_id),
        "branchID": str(b.branch_id),
        "systemID": str(ds.system_id),
        "testSuiteID": str(b.test_suite_id),
        "testSuiteRevision": b.test_suite_revision,
        "metricsBuildID": str(ds.metrics_build_id),
        "metricsSetName": ds.config.metrics_set_name,
        "status": b.status,
        "conflatedStatus": batch_conflated,
        "batchMetricsStatus": batch_status or "NO_STATUS_REPORTED",
        "jobsMetricsStatus": worst,
        "overallMetricsStatus": max(
            worst, batch_status or "NO_STATUS_REPORTED", key=_SEVERITY.index
        ),
        "totalJobs": len(jobs),
        "jobStatusCounts": {k: job_counts[s] for s, k in _JOB_STATUS_COUNT_KEYS.items()},
        "jobMetricsStatusCounts": {
            k: metrics_counts[s] for s, k in _METRICS_STATUS_COUNT_KEYS.items()
        },
        "statusHistory": [
            {"status": "SUBMITTED", "updatedAt": timestamp(b.created)},
            {"status": b.status, "updatedAt": timestamp(updated)},
        ],
        "creationTimestamp": timestamp(b.created),
        "lastRunTimestamp": timestamp(b.created),
        "lastUpdatedTimestamp": timestamp(updated),
        "poolLabels": [],
        "associatedAccount": "",
        "userID": _id(ds.user_id),
        "orgID": ds.org_id,
        "runCounter": 1,
    }


def report(ds: Dataset, r: ReportSpec) -> Json:
    return {
        "reportID": str(r.id),
        "projectID": _id(ds.project_id),
        "name": r.name,
        "testSuiteID": str(r.test_suite_id),
        "testSuiteRevision": r.test_suite_revision,
        "respectRevisionBoundary": r.respect_revision_boundary,
        "branchID": str(r.branch_id),
        "metricsBuildID": str(ds.metrics_build_id),
        "metricsSetName": None,
        "startTimestamp": timestamp(r.start),
        "endTimestamp": timestamp(r.end),
        "outputLocation": f"s3://emulated-resim/{ds.project_id}/reports/{r.id}/",
        "status": "RUNNING",
        "statusHistory": [{"status": "RUNNING", "updatedAt": timestamp(r.created)}],
        "metricsStatus": "NO_STATUS_REPORTED",
        "creationTimestamp": timestamp(r.created),
        "lastUpdatedTimestamp": timestamp(r.created),
        "associatedAccount": "",
        "userID": _id(ds.user_id),
        "orgID": ds.org_id,
    }


def build(ds: Dataset, b: Build) -> Json:
    return {
        "buildID": str(b.id),
        "projectID": _id(ds.project_id),
        "branchID": str(b.branch_id),
        "systemID": str(ds.system_id),
        "name": b.name,
        "version": b.version,
        "description": f"Emulated build {b.version}",
        "imageUri": f"registry.example.com/planner:{b.version}",
        "buildSpecification": "",
        "creationTimestamp": timestamp(b.created),
        "updateTimestamp": timestamp(b.created),
        "associatedAccount": "",
        "userID": _id(ds.user_id),
        "updateUserID": _id(ds.user_id),
        "orgID": ds.org_id,
    }


def experience(ds: Dataset, e: Experience) -> Json:
    """An experience, with its custom fields (the spec's `experience` requires them)."""
    created = BASE_TIME - timedelta(days=120)
    return {
        "experienceID": str(e.id),
        "projectID": _id(ds.project_id),
        "name": e.name,
        "description": f"Emulated scenario {e.name}",
        "location": f"s3://emulated-resim/experiences/{e.index}/",
        "locations": [f"s3://emulated-resim/experiences/{e.index}/"],
        "containerTimeoutSeconds": 3600,
        "profile": "",
        "environmentVariables": [],
        "creationTimestamp": timestamp(created),
        "updateTimestamp": timestamp(created),
        "updateUserID": _id(ds.user_id),
        "userID": _id(ds.user_id),
        "orgID": ds.org_id,
        "archived": False,
        "cacheExempt": False,
        "customFields": [
            {"name": f.name, "values": list(f.values), "type": f.type} for f in e.custom_fields
        ],
    }


def experience_tag(ds: Dataset, t: ExperienceTag) -> Json:
    return {
        "experienceTagID": str(t.id),
        "projectID": _id(ds.project_id),
        "name": t.name,
        "description": f"Experiences tagged {t.name}",
        "creationTimestamp": timestamp(t.created),
        "userID": _id(ds.user_id),
        "orgID": ds.org_id,
    }


def metric(ds: Dataset, m: StoredMetric, url: str, created: datetime, owner: Json) -> Json:
    """A JobMetric (owner has jobID and batchID) or a BatchMetric (owner has batchID)."""
    return {
        "metricID": _id(m.id),
        "name": m.name,
        "type": m.api_type,
        "status": m.status,
        "value": m.value,
        "unit": m.unit,
        "dataIDs": list(m.data_ids),
        "eventMetric": m.event,
        "metricURL": url,
        "fileLocation": "",
        "projectID": _id(ds.project_id),
        "creationTimestamp": timestamp(created),
        "userID": _id(ds.user_id),
        "orgID": ds.org_id,
        **owner,
    }


def metrics_data(d: StoredData, url: str, created: datetime, owner: Json, ds: Dataset) -> Json:
    return {
        "dataID": _id(d.id),
        "name": d.name,
        "metricsDataType": d.storage_type,
        "filename": d.filename,
        "metricsDataURL": url,
        "fileLocation": "",
        "creationTimestamp": timestamp(created),
        "userID": _id(ds.user_id),
        "orgID": ds.org_id,
        **owner,
    }


def event(e: StoredEvent, created: datetime) -> Json:
    """An event; a RELATIVE one's timestamp counts from the epoch."""
    moment = datetime.fromtimestamp(e.timestamp_ns // 1_000_000_000, UTC) + timedelta(
        microseconds=e.timestamp_ns % 1_000_000_000 // 1000
    )
    return {
        "eventID": str(e.id),
        "name": e.name,
        "description": e.description,
        "creationTimestamp": timestamp(created),
        "timestampType": e.timestamp_type,
        "timestamp": timestamp(moment),
        "tags": list(e.tags),
        "status": e.status,
        "metricsIDs": [str(m) for m in e.metric_ids],
    }


def error(status: int, message: str) -> Json:
    return {"code": status, "message": message}
