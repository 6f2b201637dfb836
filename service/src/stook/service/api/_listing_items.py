"""Listing items (a job's metrics and metrics data, a batch's jobs), read on a fast path
when well-formed.

A batch run parses ~22 listing items per job, each into a frozen dataclass through the
:class:`~stook.service.api._fields.Fields` accessors: a method call per field, and a
frozen ``__init__`` that sets each field through ``object.__setattr__``. That was the
largest share of stook's own CPU per request (~15 % at 0 ms latency). Here an item whose
every field already has the shape a well-formed answer has (by exact type) is read in one
function and its object is written as a twin with the same slots, then given the model's
class (see ``stook.sdk.fastpaths.writable_twin``). Anything else — a wrong
type, an ID that is no UUID, a timestamp without a zone — returns None, and the caller
reads the item through ``from_json``, which also words the error. Both paths give equal
objects (tests/service/api/test_listing_items.py).
"""

from __future__ import annotations

import functools
import uuid
from collections.abc import Callable, Mapping
from datetime import datetime
from typing import Any, Final

from stook.sdk.fastpaths import writable_twin
from stook.service.api._fields import field_reader, new_uuid, parse_rfc3339, parse_uuid
from stook.service.api._models import (
    ApiMetric,
    ApiMetricsData,
    ApiMetricStatus,
    ApiMetricType,
    ConflatedJobStatus,
    Job,
    JobStatus,
    MetricOwner,
    MetricsDataStorageType,
)

__all__ = ["metric_parser", "metrics_data_parser", "read_job"]

_TYPES: Final[Mapping[str, Any]] = ApiMetricType._value2member_map_
_STATUSES: Final[Mapping[str, Any]] = ApiMetricStatus._value2member_map_
_STORAGE_TYPES: Final[Mapping[str, Any]] = MetricsDataStorageType._value2member_map_
_CONFLATED: Final[Mapping[str, Any]] = ConflatedJobStatus._value2member_map_
_JOB_STATUSES: Final[Mapping[str, Any]] = JobStatus._value2member_map_
_NO_STATUS: Final = ApiMetricStatus.NO_STATUS_REPORTED
_JOB: Final = MetricOwner.JOB
_STANDARD: Final = MetricsDataStorageType.STANDARD


_WritableMetric: Final = writable_twin(ApiMetric)
_WritableMetricsData: Final = writable_twin(ApiMetricsData)
_WritableJob: Final = writable_twin(Job)
_new = object.__new__
_from_iso: Final = datetime.fromisoformat


class _MalformedError(Exception):
    """Not the well-formed shape: the item goes the general way, which says what is wrong."""


def _text(value: object) -> str | None:
    """An optional string: "" and null read as None."""
    if type(value) is str:
        return value or None
    if value is None:
        return None
    raise _MalformedError


def _opt_choice(value: object, members: Mapping[str, Any]) -> Any:
    """An optional open enumeration: its member, else its raw text; "" and null: None."""
    if type(value) is str:
        return members.get(value, value) if value else None
    if value is None:
        return None
    raise _MalformedError


def _opt_id(value: object) -> uuid.UUID | None:
    if type(value) is str:
        return parse_uuid(value) if value else None
    if value is None:
        return None
    raise _MalformedError


# The last timestamp read, and what it read as: a listing's items were mostly created
# together, so most repeat it. A datetime is immutable: sharing one is safe.
_last_timestamp: tuple[str, Any] = ("", None)


def _timestamp(value: object) -> Any:
    global _last_timestamp
    if type(value) is str and value:
        text, moment = _last_timestamp
        if value == text:
            return moment
        try:
            moment = _from_iso(value)  # what parse_rfc3339 tries first, without its call
        except ValueError:
            moment = parse_rfc3339(value)
        if moment is None or moment.tzinfo is None:
            raise _MalformedError
        _last_timestamp = (value, moment)
        return moment
    if value is None or value == "":
        return None
    raise _MalformedError


def _metric(data: Mapping[str, Any], owner: MetricOwner) -> ApiMetric | None:
    get = data.get
    try:
        metric_id = get("metricID")
        if type(metric_id) is not str or not metric_id:
            return None
        kind = get("type")
        if type(kind) is str:
            kind = _TYPES.get(kind, kind) if kind else None
        elif kind is not None:
            return None
        status = get("status")
        if type(status) is str and status:
            status = _STATUSES.get(status, status)
        elif status is None or status == "":
            status = _NO_STATUS
        else:
            return None
        value = get("value")
        if type(value) is not float and value is not None:
            return None  # an integer, a string: the general path converts or refuses it
        data_ids = get("dataIDs")
        if type(data_ids) is list and data_ids:
            data_ids = tuple(map(parse_uuid, data_ids))  # TypeError: not all strings
        elif data_ids is None or data_ids == []:
            data_ids = ()
        else:
            return None
        event_metric = get("eventMetric")
        if event_metric is None:
            event_metric = False
        elif type(event_metric) is not bool:
            return None
        # The same checks as ApiMetric.from_json, in its order: the first failure
        # decides which error from_json then gives.
        item: Any = _new(_WritableMetric)
        item.metric_id = new_uuid(metric_id)  # unique per item: not worth the ID cache
        name = get("name")
        item.name = name if type(name) is str else _text(name) or ""
        item.type = kind
        item.status = status
        item.value = value
        unit = get("unit")
        item.unit = (unit or None) if type(unit) is str else _text(unit)
        url = get("metricURL")
        item.metric_url = (url or None) if type(url) is str else _text(url)
        item.data_ids = data_ids
        item.event_metric = event_metric
        item.owner = owner
        item.job_id = _opt_id(get("jobID")) if owner is _JOB else None
        item.batch_id = _opt_id(get("batchID"))
        item.creation_timestamp = _timestamp(get("creationTimestamp"))
        item.__class__ = ApiMetric
        metric: ApiMetric = item
        return metric
    except (_MalformedError, ValueError, TypeError, AttributeError):
        return None


# What `_metrics_data` reads of a metrics-data listing's item, in one call (see
# `field_reader`), by owner: its owner's ID is the job's or the batch's.
_DATA_KEYS: Final = {
    owner: (
        "dataID",
        "metricsDataType",
        "name",
        "metricsDataURL",
        "filename",
        "jobID" if owner is MetricOwner.JOB else "batchID",
        "creationTimestamp",
    )
    for owner in MetricOwner
}


@functools.cache
def _data_fields() -> tuple[Callable[[Mapping[str, Any]], tuple[Any, ...]], ...]:
    """The readers of a job's item, then of a batch's: by position, as an enum member's
    hash is Python code (a dict or a cache keyed by the owner cost a fifth of an item)."""
    return field_reader(_DATA_KEYS[_JOB]), field_reader(_DATA_KEYS[MetricOwner.BATCH])


def _metrics_data(data: dict[str, Any], owner: MetricOwner) -> ApiMetricsData | None:
    try:
        fields = _data_fields()[owner is not _JOB](data)
    except KeyError:  # a field left out: read as null, as from_json reads it
        fields = tuple(map(data.get, _DATA_KEYS[owner]))
    data_id, storage_type, name, url, filename, owner_id, created = fields
    try:
        if type(data_id) is not str or not data_id:
            return None
        if type(storage_type) is str and storage_type:
            storage_type = _STORAGE_TYPES.get(storage_type, storage_type)
        elif storage_type is None or storage_type == "":
            storage_type = _STANDARD
        else:
            return None
        item: Any = _new(_WritableMetricsData)
        # Through the ID cache: the job's metrics list it too (their dataIDs).
        item.data_id = parse_uuid(data_id)
        item.name = name if type(name) is str else _text(name) or ""
        item.metrics_data_type = storage_type
        item.metrics_data_url = (url or None) if type(url) is str else _text(url)
        item.filename = (filename or None) if type(filename) is str else _text(filename)
        item.owner = owner
        owner_id = parse_uuid(owner_id) if type(owner_id) is str and owner_id else _opt_id(owner_id)
        if owner is _JOB:
            item.job_id, item.batch_id = owner_id, None
        else:
            item.job_id, item.batch_id = None, owner_id
        item.creation_timestamp = _timestamp(created)
        item.__class__ = ApiMetricsData
        data_item: ApiMetricsData = item
        return data_item
    except (_MalformedError, ValueError, TypeError, AttributeError):
        return None


# What `_job` reads of a jobs listing's item, in one call (see `field_reader`).
_JOB_KEYS: Final = (
    "jobID",
    "conflatedStatus",
    "jobStatus",
    "jobMetricsStatus",
    "batchID",
    "projectID",
    "experienceID",
    "experienceName",
    "buildID",
    "creationTimestamp",
    "parameters",
)


@functools.cache
def _job_fields() -> Callable[[Mapping[str, Any]], tuple[Any, ...]]:
    return field_reader(_JOB_KEYS)


def _job(data: dict[str, Any]) -> Job | None:
    try:
        fields = _job_fields()(data)
    except KeyError:  # a field left out: read as null, as from_json reads it
        fields = tuple(map(data.get, _JOB_KEYS))
    (
        job_id,
        conflated,
        status,
        metrics_status,
        batch_id,
        project_id,
        experience_id,
        experience_name,
        build_id,
        created,
        parameters,
    ) = fields
    try:
        if type(job_id) is not str or not job_id:
            return None
        if type(parameters) is dict:
            for key, value in parameters.items():
                if type(value) is not str or type(key) is not str:
                    return None
            parameters = dict(parameters)  # a copy, as from_json's: the page is not kept
        elif parameters is None or parameters == "":
            parameters = {}
        else:
            return None
        # The same checks as Job.from_json, in its order; each field's common shape
        # inline (a function call per field was a fifth of reading a job), any other
        # through the helpers.
        item: Any = _new(_WritableJob)
        item.job_id = new_uuid(job_id)  # unique per job: not worth the ID cache
        item.conflated_status = (
            _CONFLATED.get(conflated, conflated)
            if type(conflated) is str and conflated
            else _opt_choice(conflated, _CONFLATED)
        )
        item.job_status = (
            _JOB_STATUSES.get(status, status)
            if type(status) is str and status
            else _opt_choice(status, _JOB_STATUSES)
        )
        item.job_metrics_status = (
            _STATUSES.get(metrics_status, metrics_status)
            if type(metrics_status) is str and metrics_status
            else _opt_choice(metrics_status, _STATUSES)
        )
        item.batch_id = (
            parse_uuid(batch_id) if type(batch_id) is str and batch_id else _opt_id(batch_id)
        )
        item.project_id = (
            parse_uuid(project_id)
            if type(project_id) is str and project_id
            else _opt_id(project_id)
        )
        item.experience_id = (
            parse_uuid(experience_id)
            if type(experience_id) is str and experience_id
            else _opt_id(experience_id)
        )
        item.experience_name = (
            experience_name or None if type(experience_name) is str else _text(experience_name)
        )
        item.build_id = (
            parse_uuid(build_id) if type(build_id) is str and build_id else _opt_id(build_id)
        )
        item.creation_timestamp = _timestamp(created)
        item.parameters = parameters
        item.__class__ = Job
        job: Job = item
        return job
    except (_MalformedError, ValueError, TypeError, AttributeError):
        return None


def read_job(data: Mapping[str, Any]) -> Job:
    """A jobs listing's item: the fast path, else ``Job.from_json``."""
    item = _job(data) if type(data) is dict else None
    return item if item is not None else Job.from_json(data)


def metric_parser(owner: MetricOwner) -> Callable[[Mapping[str, Any]], ApiMetric]:
    """What a metric listing's items are read with: the fast path, else ``from_json``."""

    def parse(data: Mapping[str, Any]) -> ApiMetric:
        item = _metric(data, owner) if type(data) is dict else None
        return item if item is not None else ApiMetric.from_json(data, owner=owner)

    return parse


def metrics_data_parser(owner: MetricOwner) -> Callable[[Mapping[str, Any]], ApiMetricsData]:
    """What a metrics-data listing's items are read with: the fast path, else ``from_json``."""

    def parse(data: Mapping[str, Any]) -> ApiMetricsData:
        item = _metrics_data(data, owner) if type(data) is dict else None
        return item if item is not None else ApiMetricsData.from_json(data, owner=owner)

    return parse
