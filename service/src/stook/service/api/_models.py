"""Typed, immutable views of the API objects stook reads, each read by its own ``from_json``.

Only what stook relies on is checked and every other key ignored, so a newer API keeps
working. The spec requires no field of these objects (ReSim's Go client omits empty ones):
required here are only an object's own ID and a report's search window; anything else may
be absent, with the meaning each model documents. Enumerations are open: a value this
client does not know is kept as its raw string. Field names follow ReSim's published client.
``ApiMetric`` and ``ApiMetricsData``, read by the dozen per job, are frozen msgspec Structs
(built in a fifth of a frozen dataclass's time); the others frozen dataclasses.
"""

from __future__ import annotations

import enum
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any, Self

import msgspec

from stook.service.api._fields import Fields


class ConflatedJobStatus(enum.StrEnum):
    """The one status the platform shows for a test (job)."""

    QUEUED = "QUEUED"
    RUNNING = "RUNNING"
    PASSED = "PASSED"
    WARNING = "WARNING"
    BLOCKER = "BLOCKER"
    ERROR = "ERROR"
    CANCELLED = "CANCELLED"


class JobStatus(enum.StrEnum):
    """Where a job is in its execution."""

    SUBMITTED = "SUBMITTED"
    EXPERIENCE_RUNNING = "EXPERIENCE_RUNNING"
    METRICS_QUEUED = "METRICS_QUEUED"
    METRICS_RUNNING = "METRICS_RUNNING"
    SUCCEEDED = "SUCCEEDED"
    ERROR = "ERROR"
    CANCELLED = "CANCELLED"


class BatchStatus(enum.StrEnum):
    """Where a batch is in its execution."""

    SUBMITTED = "SUBMITTED"
    EXPERIENCES_RUNNING = "EXPERIENCES_RUNNING"
    BATCH_METRICS_QUEUED = "BATCH_METRICS_QUEUED"
    BATCH_METRICS_RUNNING = "BATCH_METRICS_RUNNING"
    SUCCEEDED = "SUCCEEDED"
    ERROR = "ERROR"
    CANCELLED = "CANCELLED"


class ConflatedBatchStatus(enum.StrEnum):
    """The one status the platform shows for a batch (a different set from a job's)."""

    SUBMITTED = "SUBMITTED"
    RUNNING = "RUNNING"
    COMPLETE = "COMPLETE"
    WARNING = "WARNING"
    BLOCKER = "BLOCKER"
    ERROR = "ERROR"
    CANCELLED = "CANCELLED"


class ApiMetricStatus(enum.StrEnum):
    """A metric's status as the API spells it (``stook.sdk.MetricStatus`` lacks the last)."""

    PASSED = "PASSED"
    FAIL_WARN = "FAIL_WARN"
    FAIL_BLOCK = "FAIL_BLOCK"
    NOT_APPLICABLE = "NOT_APPLICABLE"
    RAW = "RAW"
    NO_STATUS_REPORTED = "NO_STATUS_REPORTED"


class ApiMetricType(enum.StrEnum):
    """How the API stores a metric: a bare number, or a serialized ``Metric`` message."""

    SCALAR = "SCALAR"
    COMPOSITE = "COMPOSITE"


class EventTimestampType(enum.StrEnum):
    """Whether an event's timestamp is a moment or a time since the experience began."""

    ABSOLUTE = "ABSOLUTE"
    RELATIVE = "RELATIVE"


class MetricsDataStorageType(enum.StrEnum):
    """What a metrics-data URL points at; only ``STANDARD`` is a ``MetricsData`` message."""

    STANDARD = "STANDARD"
    EXTERNAL_FILE = "EXTERNAL_FILE"
    VIDEO = "VIDEO"


@dataclass(frozen=True, slots=True)
class Job:
    """One test of a batch: an experience run against a build (a missing
    ``conflated_status``, None, is counted as ``UNKNOWN`` by batch aggregations)."""

    job_id: uuid.UUID
    conflated_status: ConflatedJobStatus | str | None
    job_status: JobStatus | str | None = None
    job_metrics_status: ApiMetricStatus | str | None = None
    batch_id: uuid.UUID | None = None
    project_id: uuid.UUID | None = None
    experience_id: uuid.UUID | None = None
    experience_name: str | None = None
    build_id: uuid.UUID | None = None
    creation_timestamp: datetime | None = None
    #: what a sweep or the batch gave the job (the spec's ``batchParameters``); absent: {}
    parameters: Mapping[str, str] = field(default_factory=dict, hash=False)

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("Job", data, "jobID")
        return cls(
            job_id=f.id("jobID"),
            conflated_status=f.opt_choice("conflatedStatus", ConflatedJobStatus),
            job_status=f.opt_choice("jobStatus", JobStatus),
            job_metrics_status=f.opt_choice("jobMetricsStatus", ApiMetricStatus),
            batch_id=f.opt_id("batchID"),
            project_id=f.opt_id("projectID"),
            experience_id=f.opt_id("experienceID"),
            experience_name=f.opt_string("experienceName"),
            build_id=f.opt_id("buildID"),
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
            parameters=f.string_map("parameters"),
        )


class MetricOwner(enum.StrEnum):
    """Whose metrics build produced a metric or metrics data: a job's, or the batch's own."""

    JOB = "job"
    BATCH = "batch"


# The API's own schema names, which errors name: "JobMetric 1234…: field 'value' ...".
_METRIC_KINDS = {MetricOwner.JOB: "JobMetric", MetricOwner.BATCH: "BatchMetric"}
_DATA_KINDS = {MetricOwner.JOB: "JobMetricsData", MetricOwner.BATCH: "BatchMetricsData"}


class ApiMetric(msgspec.Struct, frozen=True):
    """A metric a job's or a batch's metrics build produced (``owner``).

    ``value`` is a ``SCALAR``'s number, or None (then it is in the ``Metric`` message at
    ``metric_url``, a presigned URL that expires). A missing ``status`` reads as
    ``NO_STATUS_REPORTED``; ``job_id`` is read for a job's metric only.
    """

    metric_id: uuid.UUID
    name: str
    type: ApiMetricType | str | None
    status: ApiMetricStatus | str
    value: float | None = None
    unit: str | None = None
    metric_url: str | None = None  # presigned: left out of repr
    data_ids: tuple[uuid.UUID, ...] = ()
    event_metric: bool = False
    owner: MetricOwner = MetricOwner.JOB
    job_id: uuid.UUID | None = None
    batch_id: uuid.UUID | None = None
    creation_timestamp: datetime | None = None

    def __repr__(self) -> str:
        return _repr_without(self, "metric_url")

    @classmethod
    def from_json(cls, data: Mapping[str, Any], *, owner: MetricOwner) -> Self:
        f = Fields(_METRIC_KINDS[owner], data, "metricID")
        # The order of evaluation decides which error an item with two bad fields gets.
        return cls(
            metric_id=f.id("metricID"),
            name=f.opt_string("name") or "",
            type=f.opt_choice("type", ApiMetricType),
            status=f.opt_choice("status", ApiMetricStatus) or ApiMetricStatus.NO_STATUS_REPORTED,
            value=f.opt_number("value"),
            unit=f.opt_string("unit"),
            metric_url=f.opt_string("metricURL"),
            data_ids=f.ids("dataIDs"),
            event_metric=f.flag("eventMetric"),
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
            owner=owner,
            job_id=f.opt_id("jobID") if owner is MetricOwner.JOB else None,
            batch_id=f.opt_id("batchID"),
        )


class ApiMetricsData(msgspec.Struct, frozen=True):
    """A metrics-data file of a job or of a batch (``owner``); ``metrics_data_url`` is
    presigned and expires. A missing ``metricsDataType`` reads as ``STANDARD``, as ReSim's
    own fetcher reads it; the owner's ID (``job_id`` or ``batch_id``) is read for its owner.
    """

    data_id: uuid.UUID
    name: str
    metrics_data_type: MetricsDataStorageType | str
    metrics_data_url: str | None = None  # presigned: left out of repr
    filename: str | None = None
    owner: MetricOwner = MetricOwner.JOB
    job_id: uuid.UUID | None = None
    batch_id: uuid.UUID | None = None
    creation_timestamp: datetime | None = None

    def __repr__(self) -> str:
        return _repr_without(self, "metrics_data_url")

    @property
    def is_standard(self) -> bool:
        """Whether the URL holds a ``MetricsData`` message (not a video or external file)."""
        return self.metrics_data_type is MetricsDataStorageType.STANDARD

    @classmethod
    def from_json(cls, data: Mapping[str, Any], *, owner: MetricOwner) -> Self:
        f = Fields(_DATA_KINDS[owner], data, "dataID")
        return cls(
            data_id=f.id("dataID"),
            name=f.opt_string("name") or "",
            metrics_data_type=f.opt_choice("metricsDataType", MetricsDataStorageType)
            or MetricsDataStorageType.STANDARD,
            metrics_data_url=f.opt_string("metricsDataURL"),
            filename=f.opt_string("filename"),
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
            owner=owner,
            job_id=f.opt_id("jobID") if owner is MetricOwner.JOB else None,
            batch_id=f.opt_id("batchID") if owner is MetricOwner.BATCH else None,
        )


def _repr_without(item: msgspec.Struct, secret: str) -> str:
    """A Struct's repr without its field `secret` (a presigned URL: no signature in a log)."""
    shown = ", ".join(
        f"{name}={getattr(item, name)!r}" for name in item.__struct_fields__ if name != secret
    )
    return f"{type(item).__name__}({shown})"


@dataclass(frozen=True, slots=True)
class Batch:
    """A run of a test suite (or ad-hoc set of experiences) against one build."""

    batch_id: uuid.UUID
    status: BatchStatus | str | None = None
    conflated_status: ConflatedBatchStatus | str | None = None
    batch_metrics_status: ApiMetricStatus | str | None = None
    jobs_metrics_status: ApiMetricStatus | str | None = None
    project_id: uuid.UUID | None = None
    build_id: uuid.UUID | None = None
    branch_id: uuid.UUID | None = None
    test_suite_id: uuid.UUID | None = None
    test_suite_revision: int | None = None
    total_jobs: int | None = None
    friendly_name: str | None = None
    creation_timestamp: datetime | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("Batch", data, "batchID")
        return cls(
            batch_id=f.id("batchID"),
            status=f.opt_choice("status", BatchStatus),
            conflated_status=f.opt_choice("conflatedStatus", ConflatedBatchStatus),
            batch_metrics_status=f.opt_choice("batchMetricsStatus", ApiMetricStatus),
            jobs_metrics_status=f.opt_choice("jobsMetricsStatus", ApiMetricStatus),
            project_id=f.opt_id("projectID"),
            build_id=f.opt_id("buildID"),
            branch_id=f.opt_id("branchID"),
            test_suite_id=f.opt_id("testSuiteID"),
            test_suite_revision=f.opt_integer("testSuiteRevision"),
            total_jobs=f.opt_integer("totalJobs"),
            friendly_name=f.opt_string("friendlyName"),
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
        )


@dataclass(frozen=True, slots=True)
class Report:
    """A report: the batches of one test suite on one branch within a time window."""

    report_id: uuid.UUID
    project_id: uuid.UUID
    test_suite_id: uuid.UUID
    test_suite_revision: int
    branch_id: uuid.UUID
    start_timestamp: datetime
    end_timestamp: datetime
    respect_revision_boundary: bool
    name: str
    creation_timestamp: datetime | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("Report", data, "reportID")
        return cls(
            report_id=f.id("reportID"),
            project_id=f.id("projectID"),
            test_suite_id=f.id("testSuiteID"),
            test_suite_revision=f.integer("testSuiteRevision"),
            branch_id=f.id("branchID"),
            start_timestamp=f.timestamp("startTimestamp"),
            end_timestamp=f.timestamp("endTimestamp"),
            respect_revision_boundary=f.flag("respectRevisionBoundary"),
            name=f.opt_string("name") or "",
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
        )


@dataclass(frozen=True, slots=True)
class Build:
    """A build (system-under-test image); stook only needs it for labels."""

    build_id: uuid.UUID
    name: str | None = None
    version: str | None = None
    creation_timestamp: datetime | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("Build", data, "buildID")
        return cls(
            build_id=f.id("buildID"),
            name=f.opt_string("name"),
            version=f.opt_string("version"),
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
        )


@dataclass(frozen=True, slots=True)
class JobEventListing:
    """One event of a job, as ``GET .../jobs/{jobID}/events`` lists it (without its data)."""

    event_id: uuid.UUID
    name: str
    status: ApiMetricStatus | str
    timestamp: datetime | None = None
    timestamp_type: EventTimestampType | str | None = None
    description: str = ""
    tags: tuple[str, ...] = ()
    metric_ids: tuple[uuid.UUID, ...] = ()
    creation_timestamp: datetime | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("Event", data, "eventID")
        return cls(
            event_id=f.id("eventID"),
            name=f.opt_string("name") or "",
            status=f.opt_choice("status", ApiMetricStatus) or ApiMetricStatus.NO_STATUS_REPORTED,
            timestamp=f.opt_timestamp("timestamp"),
            timestamp_type=f.opt_choice("timestampType", EventTimestampType),
            description=f.opt_string("description") or "",
            tags=f.strings("tags"),
            metric_ids=f.ids("metricsIDs"),
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
        )


@dataclass(frozen=True, slots=True)
class ExperienceTag:
    """A tag of an experience (the spec's ``experienceTag``); only its ID is required."""

    experience_tag_id: uuid.UUID
    name: str
    description: str = ""

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("ExperienceTag", data, "experienceTagID")
        return cls(
            experience_tag_id=f.id("experienceTagID"),
            name=f.opt_string("name") or "",
            description=f.opt_string("description") or "",
        )


@dataclass(frozen=True, slots=True)
class Branch:
    """A branch of a project; stook finds a baseline's branch by its name."""

    branch_id: uuid.UUID
    name: str = ""
    branch_type: str | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("Branch", data, "branchID")
        return cls(
            branch_id=f.id("branchID"),
            name=f.opt_string("name") or "",
            branch_type=f.opt_string("branchType"),
        )


class LogType(enum.StrEnum):
    """The spec's `logType`."""

    OTHER_LOG = "OTHER_LOG"
    METRICS_OUTPUT_LOG = "METRICS_OUTPUT_LOG"
    CONTAINER_LOG = "CONTAINER_LOG"
    EXECUTION_LOG = "EXECUTION_LOG"
    MCAP_LOG = "MCAP_LOG"
    MP4_LOG = "MP4_LOG"
    ARCHIVE_LOG = "ARCHIVE_LOG"
    FOXGLOVE_MCAP_LOG = "FOXGLOVE_MCAP_LOG"
    RERUN_IO_LOG = "RERUN_IO_LOG"
    ERROR_LOG = "ERROR_LOG"
    SERVICE_LOG = "SERVICE_LOG"
    EMISSIONS_LOG = "EMISSIONS_LOG"
    SYSTEM_LOG = "SYSTEM_LOG"


class ExecutionStep(enum.StrEnum):
    """The spec's `executionStep`: which step of the job wrote the log."""

    EXPERIENCE = "EXPERIENCE"
    METRICS = "METRICS"
    BATCH_METRICS = "BATCH_METRICS"
    REPORT = "REPORT"


@dataclass(frozen=True, slots=True)
class JobLog:
    """One log of a job, as ``GET .../jobs/{jobID}/logs`` lists it (the spec's ``jobLog``):
    a test's emissions are its EMISSIONS_LOG, downloaded from ``log_output_location``."""

    log_id: uuid.UUID
    file_name: str = ""
    log_type: LogType | str | None = None
    log_output_location: str | None = None
    file_size: int | None = None
    checksum: str | None = None
    creation_timestamp: datetime | None = None
    execution_step: ExecutionStep | str | None = None
    file_path: str = ""
    job_id: uuid.UUID | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("JobLog", data, "logID")
        return cls(
            log_id=f.id("logID"),
            file_name=f.opt_string("fileName") or "",
            log_type=f.opt_choice("logType", LogType),
            log_output_location=f.opt_string("logOutputLocation"),
            file_size=f.opt_integer("fileSize"),
            checksum=f.opt_string("checksum"),
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
            execution_step=f.opt_choice("executionStep", ExecutionStep),
            file_path=f.opt_string("filePath") or "",
            job_id=f.opt_id("jobID"),
        )
