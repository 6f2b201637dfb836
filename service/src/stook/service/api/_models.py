"""The API's objects and listing pages as frozen msgspec Structs, each decoded straight
from an answer's body by one typed decoder (`decoder`). Field names follow ReSim's
published client; keys a model does not name are ignored, so a newer API keeps working.

The spec requires no field of a job, batch, metric or metrics data (ReSim's Go client
omits empty ones): required here are only the IDs stook cannot do without and a report's
window. A missing string reads as None (names as ""), a metric's missing ``status`` as
``NO_STATUS_REPORTED``, a missing ``metricsDataType`` as ``STANDARD``; "" (what Go writes
for an unset string) reads as absent (`_Model`). Enumerations are open: their fields are
``str``, a value the platform adds later is kept, and the ``StrEnum`` classes are the
known vocabulary (compare with ``==``). Lax mode (``strict=False``) reads an integral float
as an integer; where a field is not a string it also reads a number or boolean written as
a string, and ``1``/``0`` as booleans. Anything else of the wrong type, an ID that is not a
UUID, a number past a double's range or a timestamp that is not RFC 3339 is an error naming
the field's JSON path (`msgspec.ValidationError`, which the client words).
"""

from __future__ import annotations

import enum
import re
import uuid
from datetime import datetime
from typing import Any, ClassVar, Generic, TypeVar

import msgspec

__all__ = [
    "ApiMetric",
    "ApiMetricStatus",
    "ApiMetricType",
    "ApiMetricsData",
    "Batch",
    "BatchMetric",
    "BatchMetricsData",
    "BatchMetricsDataPage",
    "BatchMetricsPage",
    "BatchStatus",
    "BatchesPage",
    "Branch",
    "BranchesPage",
    "Build",
    "ConflatedBatchStatus",
    "ConflatedJobStatus",
    "CustomField",
    "CustomFieldType",
    "EventTimestampType",
    "ExecutionStep",
    "Experience",
    "ExperienceTag",
    "ExperienceTagsPage",
    "Job",
    "JobEventListing",
    "JobEventsPage",
    "JobLog",
    "JobLogsPage",
    "JobMetricsDataPage",
    "JobMetricsPage",
    "JobStatus",
    "JobsPage",
    "LogType",
    "MetricOwner",
    "MetricsDataStorageType",
    "Page",
    "Report",
    "Timestamp",
    "decoder",
    "parse_rfc3339",
]

_T = TypeVar("_T")


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
    """A metric's status as the API spells it.

    Named apart from ``stook.sdk.MetricStatus`` (the proto enum), which has no
    ``NO_STATUS_REPORTED``.
    """

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


class CustomFieldType(enum.StrEnum):
    """The spec's `customFieldValueType`: how an experience's custom field's values (text,
    whatever the type) are meant."""

    TEXT = "text"
    NUMBER = "number"
    TIMESTAMP = "timestamp"
    JSON = "json"


class MetricOwner(enum.StrEnum):
    """Whose metrics build produced a metric or metrics data: a job's, or the batch's own."""

    JOB = "job"
    BATCH = "batch"


# -- timestamps ---------------------------------------------------------------------------


class Timestamp(datetime):
    """An RFC 3339 time as an answer gives it: a ``datetime`` (always with a time zone).

    A type of its own only so that the decoder hands its text to `parse_rfc3339` (msgspec's
    own datetime parser refuses a leap second and rounds past microseconds)."""

    __slots__ = ()


# RFC 3339 as the RFC allows it, with what `datetime.fromisoformat` does not read: lower-case
# t and z, more than six fractional digits (Go's RFC3339Nano writes nine), a leap second.
_RFC3339 = re.compile(
    r"(\d{4}-\d{2}-\d{2})[Tt ](\d{2}:\d{2}):(\d{2})(?:\.(\d+))?([Zz]|[+-]\d{2}:\d{2})"
)


def parse_rfc3339(text: str) -> Timestamp | None:
    """An RFC 3339 timestamp, or None if it is not one. Fractions past microseconds are
    truncated; a leap second (:60, which a datetime cannot hold) reads as :59.999999, so
    the order of times is kept."""
    try:
        return Timestamp.fromisoformat(text)  # most timestamps, at once
    except ValueError:
        pass
    match = _RFC3339.fullmatch(text)
    if match is None:
        return None
    day, minutes, second, fraction, zone = match.groups()
    micros = (fraction or "0")[:6].ljust(6, "0")
    if second == "60":
        second, micros = "59", "999999"
    offset = "+00:00" if zone in ("Z", "z") else zone
    try:
        return Timestamp.fromisoformat(f"{day}T{minutes}:{second}.{micros}{offset}")
    except ValueError:  # e.g. month 13, or an offset of a day or more
        return None


def _decode_hook(kind: type, value: Any) -> Any:
    """What msgspec cannot read by itself: a `Timestamp`, from its text."""
    if kind is Timestamp:
        if not isinstance(value, str):
            raise TypeError(f"Expected an RFC 3339 timestamp, got {type(value).__name__}")
        moment = parse_rfc3339(value)
        if moment is None:
            raise ValueError(f"Not an RFC 3339 timestamp: {value!r}")
        if moment.tzinfo is None:
            raise ValueError(f"An RFC 3339 timestamp without a time zone: {value!r}")
        return moment
    raise NotImplementedError(kind)


def decoder(answer: type[_T]) -> msgspec.json.Decoder[_T]:
    """The decoder of one answer's body (a page, or an object), in lax mode (see above)."""
    return msgspec.json.Decoder(answer, strict=False, dec_hook=_decode_hook)


# -- models -------------------------------------------------------------------------------


class _Model(msgspec.Struct, frozen=True):
    """A frozen Struct whose string fields named in ``_blank`` read an empty string ("",
    which Go writes for an unset string) as that field's value when absent."""

    _blank: ClassVar[dict[str, object]] = {}

    def __post_init__(self) -> None:
        for name, absent in self._blank.items():
            if getattr(self, name) == "":
                msgspec.structs.force_setattr(self, name, absent)


class Job(_Model, frozen=True):
    """One test of a batch: an experience run against a build.

    ``conflated_status`` is None when the API gave none (batch aggregations count such
    jobs as ``UNKNOWN``); a status this client does not know is its raw string.
    ``parameters`` is what a sweep or the batch gave the job (the spec's
    ``batchParameters``); absent: {}.
    """

    job_id: uuid.UUID = msgspec.field(name="jobID")
    conflated_status: str | None = msgspec.field(default=None, name="conflatedStatus")
    job_status: str | None = msgspec.field(default=None, name="jobStatus")
    job_metrics_status: str | None = msgspec.field(default=None, name="jobMetricsStatus")
    batch_id: uuid.UUID | None = msgspec.field(default=None, name="batchID")
    project_id: uuid.UUID | None = msgspec.field(default=None, name="projectID")
    experience_id: uuid.UUID | None = msgspec.field(default=None, name="experienceID")
    experience_name: str | None = msgspec.field(default=None, name="experienceName")
    build_id: uuid.UUID | None = msgspec.field(default=None, name="buildID")
    creation_timestamp: Timestamp | None = msgspec.field(default=None, name="creationTimestamp")
    parameters: dict[str, str] = {}

    _blank: ClassVar[dict[str, object]] = {
        "conflated_status": None,
        "job_status": None,
        "job_metrics_status": None,
        "experience_name": None,
    }

    def __hash__(self) -> int:
        return hash(self.job_id)  # `parameters`, a dict, cannot be hashed


class ApiMetric(_Model, frozen=True):
    """A metric of a job's metrics build (`BatchMetric`: of the batch's own).

    ``value`` is the number of a ``SCALAR`` metric (None for ``COMPOSITE``, or when the job
    reported none, or the API lists it as null: then the value is in the message at
    ``metric_url``). ``metric_url`` is the presigned URL of the serialized ``Metric``
    message; it expires, so fetch it soon after listing. ``name`` is "" when the API gave
    none; ``type`` None when it gave none; an unknown type or status is its raw string.
    """

    owner: ClassVar[MetricOwner] = MetricOwner.JOB

    metric_id: uuid.UUID = msgspec.field(name="metricID")
    name: str = ""
    type: str | None = None
    status: str = ApiMetricStatus.NO_STATUS_REPORTED
    value: float | None = None
    unit: str | None = None
    metric_url: str | None = msgspec.field(default=None, name="metricURL")  # presigned
    data_ids: tuple[uuid.UUID, ...] = msgspec.field(default=(), name="dataIDs")
    event_metric: bool = msgspec.field(default=False, name="eventMetric")
    job_id: uuid.UUID | None = msgspec.field(default=None, name="jobID")
    batch_id: uuid.UUID | None = msgspec.field(default=None, name="batchID")

    _blank: ClassVar[dict[str, object]] = {
        "type": None,
        "status": ApiMetricStatus.NO_STATUS_REPORTED,
        "unit": None,
        "metric_url": None,
    }

    def __repr__(self) -> str:
        return _repr_without(self, "metric_url")


class BatchMetric(ApiMetric, frozen=True):
    """A metric of the batch's own metrics build (a batch listing's item)."""

    owner: ClassVar[MetricOwner] = MetricOwner.BATCH


class ApiMetricsData(_Model, frozen=True):
    """A metrics-data file of a job (`BatchMetricsData`: of the batch);
    ``metrics_data_url`` is presigned and expires.

    ``name`` is "" when the API gave none: such data cannot be asked for by name.
    """

    owner: ClassVar[MetricOwner] = MetricOwner.JOB

    data_id: uuid.UUID = msgspec.field(name="dataID")
    name: str = ""
    metrics_data_type: str = msgspec.field(
        default=MetricsDataStorageType.STANDARD, name="metricsDataType"
    )
    metrics_data_url: str | None = msgspec.field(default=None, name="metricsDataURL")
    filename: str | None = None
    job_id: uuid.UUID | None = msgspec.field(default=None, name="jobID")
    batch_id: uuid.UUID | None = msgspec.field(default=None, name="batchID")

    _blank: ClassVar[dict[str, object]] = {
        "metrics_data_type": MetricsDataStorageType.STANDARD,
        "metrics_data_url": None,
        "filename": None,
    }

    def __repr__(self) -> str:
        return _repr_without(self, "metrics_data_url")

    @property
    def is_standard(self) -> bool:
        """Whether the URL holds a ``MetricsData`` message (not a video or external file)."""
        return self.metrics_data_type == MetricsDataStorageType.STANDARD


class BatchMetricsData(ApiMetricsData, frozen=True):
    """A metrics-data file of the batch's own metrics build (a batch listing's item)."""

    owner: ClassVar[MetricOwner] = MetricOwner.BATCH


def _repr_without(item: msgspec.Struct, secret: str) -> str:
    """A Struct's repr without its field `secret` (a presigned URL, whose signature must not
    reach a log), as a dataclass field with ``repr=False`` shows."""
    shown = ", ".join(
        f"{name}={getattr(item, name)!r}" for name in item.__struct_fields__ if name != secret
    )
    return f"{type(item).__name__}({shown})"


class Batch(_Model, frozen=True):
    """A run of a test suite (or ad-hoc set of experiences) against one build."""

    batch_id: uuid.UUID = msgspec.field(name="batchID")
    status: str | None = None
    conflated_status: str | None = msgspec.field(default=None, name="conflatedStatus")
    batch_metrics_status: str | None = msgspec.field(default=None, name="batchMetricsStatus")
    jobs_metrics_status: str | None = msgspec.field(default=None, name="jobsMetricsStatus")
    project_id: uuid.UUID | None = msgspec.field(default=None, name="projectID")
    build_id: uuid.UUID | None = msgspec.field(default=None, name="buildID")
    branch_id: uuid.UUID | None = msgspec.field(default=None, name="branchID")
    test_suite_id: uuid.UUID | None = msgspec.field(default=None, name="testSuiteID")
    test_suite_revision: int | None = msgspec.field(default=None, name="testSuiteRevision")
    total_jobs: int | None = msgspec.field(default=None, name="totalJobs")
    friendly_name: str | None = msgspec.field(default=None, name="friendlyName")
    creation_timestamp: Timestamp | None = msgspec.field(default=None, name="creationTimestamp")
    # The metrics set the batch was launched with (nullable in the spec): None for none.
    metrics_set_name: str | None = msgspec.field(default=None, name="metricsSetName")

    _blank: ClassVar[dict[str, object]] = {
        "status": None,
        "conflated_status": None,
        "batch_metrics_status": None,
        "jobs_metrics_status": None,
        "friendly_name": None,
        "metrics_set_name": None,
    }


class Report(_Model, frozen=True):
    """A report: the batches of one test suite on one branch within a time window."""

    report_id: uuid.UUID = msgspec.field(name="reportID")
    project_id: uuid.UUID = msgspec.field(name="projectID")
    test_suite_id: uuid.UUID = msgspec.field(name="testSuiteID")
    test_suite_revision: int = msgspec.field(name="testSuiteRevision")
    branch_id: uuid.UUID = msgspec.field(name="branchID")
    start_timestamp: Timestamp = msgspec.field(name="startTimestamp")
    end_timestamp: Timestamp = msgspec.field(name="endTimestamp")
    respect_revision_boundary: bool = msgspec.field(default=False, name="respectRevisionBoundary")
    name: str = ""
    creation_timestamp: Timestamp | None = msgspec.field(default=None, name="creationTimestamp")


class Build(_Model, frozen=True):
    """A build (system-under-test image); stook only needs it for labels."""

    build_id: uuid.UUID = msgspec.field(name="buildID")
    name: str | None = None
    version: str | None = None
    creation_timestamp: Timestamp | None = msgspec.field(default=None, name="creationTimestamp")

    _blank: ClassVar[dict[str, object]] = {"name": None, "version": None}


class JobEventListing(_Model, frozen=True):
    """One event of a job, as ``GET .../jobs/{jobID}/events`` lists it (the spec's ``event``).

    The spec requires every field, but as elsewhere only the ID is relied on: a missing
    name reads as "", a missing status as ``NO_STATUS_REPORTED``, a missing timestamp or
    timestamp type as None, missing tags or metric IDs as empty. Unknown statuses and
    timestamp types are kept as their raw strings.
    """

    event_id: uuid.UUID = msgspec.field(name="eventID")
    name: str = ""
    status: str = ApiMetricStatus.NO_STATUS_REPORTED
    timestamp: Timestamp | None = None
    timestamp_type: str | None = msgspec.field(default=None, name="timestampType")
    description: str = ""
    tags: tuple[str, ...] = ()
    metric_ids: tuple[uuid.UUID, ...] = msgspec.field(default=(), name="metricsIDs")
    creation_timestamp: Timestamp | None = msgspec.field(default=None, name="creationTimestamp")

    _blank: ClassVar[dict[str, object]] = {
        "status": ApiMetricStatus.NO_STATUS_REPORTED,
        "timestamp_type": None,
    }


class CustomField(_Model, frozen=True):
    """One custom field of an experience (the spec's `customFieldDefinition`): its name,
    its values, always text (a number as "32", a timestamp as ISO 8601, JSON as its text),
    and its type. The spec requires all three; as elsewhere, a missing name reads as "",
    missing or null values (a Go client's nil list) as none, a missing type as None, and a
    type the spec does not list (yet) is its raw string (`CustomFieldType`: the known ones)."""

    name: str = ""
    values: tuple[str, ...] | None = None
    type: str | None = None

    _blank: ClassVar[dict[str, object]] = {"type": None}

    @property
    def texts(self) -> tuple[str, ...]:
        """The field's values, in the API's order (none when it gave none)."""
        return self.values or ()


class Experience(_Model, frozen=True):
    """An experience (a test's input), as ``GET .../experiences/{experienceID}`` answers it;
    stook reads its name and its custom fields. Only its ID is required, as with the other
    objects: missing (or null) ``customFields`` read as none."""

    experience_id: uuid.UUID = msgspec.field(name="experienceID")
    name: str = ""
    description: str = ""
    archived: bool = False
    custom_fields: tuple[CustomField, ...] | None = msgspec.field(default=None, name="customFields")
    creation_timestamp: Timestamp | None = msgspec.field(default=None, name="creationTimestamp")

    @property
    def fields(self) -> tuple[CustomField, ...]:
        """Its custom fields, in the API's order (none when it gave none)."""
        return self.custom_fields or ()


class ExperienceTag(_Model, frozen=True):
    """A tag of an experience (the spec's ``experienceTag``); only its ID is required."""

    experience_tag_id: uuid.UUID = msgspec.field(name="experienceTagID")
    name: str = ""
    description: str = ""


class Branch(_Model, frozen=True):
    """A branch of a project; stook finds a baseline's branch by its name."""

    branch_id: uuid.UUID = msgspec.field(name="branchID")
    name: str = ""
    branch_type: str | None = msgspec.field(default=None, name="branchType")

    _blank: ClassVar[dict[str, object]] = {"branch_type": None}


class JobLog(_Model, frozen=True):
    """One log of a job (the spec's `jobLog`). Only its ID is required, as with the other
    objects; a log without `logOutputLocation` cannot be downloaded. Unknown log types and
    steps are kept as their raw strings."""

    log_id: uuid.UUID = msgspec.field(name="logID")
    file_name: str = msgspec.field(default="", name="fileName")
    log_type: str | None = msgspec.field(default=None, name="logType")
    log_output_location: str | None = msgspec.field(
        default=None, name="logOutputLocation"
    )  # presigned
    file_size: int | None = msgspec.field(default=None, name="fileSize")
    checksum: str | None = None
    creation_timestamp: Timestamp | None = msgspec.field(default=None, name="creationTimestamp")
    execution_step: str | None = msgspec.field(default=None, name="executionStep")
    file_path: str = msgspec.field(default="", name="filePath")
    job_id: uuid.UUID | None = msgspec.field(default=None, name="jobID")

    _blank: ClassVar[dict[str, object]] = {
        "log_type": None,
        "log_output_location": None,
        "checksum": None,
        "execution_step": None,
    }

    def __repr__(self) -> str:
        return _repr_without(self, "log_output_location")


# -- listing pages ------------------------------------------------------------------------


class Page(msgspec.Struct, Generic[_T], frozen=True):
    """One page of a listing: its items (each listing names them its own way), the token
    of the next page ("" or absent on the last), and ``total``, the listing's size, when
    the API says it. ``item_id`` names the items' own ID, by which repeats are told."""

    items: list[_T] | None = None
    next_page_token: str | None = msgspec.field(default=None, name="nextPageToken")
    total: int | None = None

    item_id: ClassVar[str]


class JobsPage(Page[Job], frozen=True):
    items: list[Job] | None = msgspec.field(default=None, name="jobs")
    item_id: ClassVar[str] = "job_id"


class BatchesPage(Page[Batch], frozen=True):
    items: list[Batch] | None = msgspec.field(default=None, name="batches")
    item_id: ClassVar[str] = "batch_id"


class JobMetricsPage(Page[ApiMetric], frozen=True):
    items: list[ApiMetric] | None = msgspec.field(default=None, name="metrics")
    item_id: ClassVar[str] = "metric_id"


class BatchMetricsPage(Page[BatchMetric], frozen=True):
    items: list[BatchMetric] | None = msgspec.field(default=None, name="batchMetrics")
    item_id: ClassVar[str] = "metric_id"


class JobMetricsDataPage(Page[ApiMetricsData], frozen=True):
    items: list[ApiMetricsData] | None = msgspec.field(default=None, name="metricsData")
    item_id: ClassVar[str] = "data_id"


class BatchMetricsDataPage(Page[BatchMetricsData], frozen=True):
    items: list[BatchMetricsData] | None = msgspec.field(default=None, name="batchMetricsData")
    item_id: ClassVar[str] = "data_id"


class JobEventsPage(Page[JobEventListing], frozen=True):
    items: list[JobEventListing] | None = msgspec.field(default=None, name="events")
    item_id: ClassVar[str] = "event_id"


class ExperienceTagsPage(Page[ExperienceTag], frozen=True):
    items: list[ExperienceTag] | None = msgspec.field(default=None, name="experienceTags")
    item_id: ClassVar[str] = "experience_tag_id"


class BranchesPage(Page[Branch], frozen=True):
    items: list[Branch] | None = msgspec.field(default=None, name="branches")
    item_id: ClassVar[str] = "branch_id"


class JobLogsPage(Page[JobLog], frozen=True):
    items: list[JobLog] | None = msgspec.field(default=None, name="logs")
    item_id: ClassVar[str] = "log_id"
