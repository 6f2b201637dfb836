"""A job's metric and metrics-data listing items, read on a fast path when well-formed.

A batch run parses ~22 listing items per job, each into a frozen dataclass through the
:class:`~stook.service.api._fields.Fields` accessors: a method call per field, and a
frozen ``__init__`` that sets each field through ``object.__setattr__``. That was the
largest share of stook's own CPU per request (~15 % at 0 ms latency). Here an item whose
every field already has the shape a well-formed answer has (by exact type) is read in one
function and its object is built by setting the slots directly. Anything else — a wrong
type, an ID that is no UUID, a timestamp without a zone — returns None, and the caller
reads the item through ``from_json``, which also words the error. Both paths give equal
objects (tests/service/api/test_listing_items.py).
"""

from __future__ import annotations

import dataclasses
import uuid
from collections.abc import Callable, Mapping
from typing import Any, Final

from stook.service.api._fields import new_uuid, parse_rfc3339, parse_uuid
from stook.service.api._models import (
    ApiMetric,
    ApiMetricsData,
    ApiMetricStatus,
    ApiMetricType,
    MetricOwner,
    MetricsDataStorageType,
)

__all__ = ["metric_parser", "metrics_data_parser"]

_TYPES: Final[Mapping[str, Any]] = ApiMetricType._value2member_map_
_STATUSES: Final[Mapping[str, Any]] = ApiMetricStatus._value2member_map_
_STORAGE_TYPES: Final[Mapping[str, Any]] = MetricsDataStorageType._value2member_map_
_NO_STATUS: Final = ApiMetricStatus.NO_STATUS_REPORTED
_STANDARD: Final = MetricsDataStorageType.STANDARD


def _slot_setters(cls: type) -> tuple[Callable[[object, object], None], ...]:
    # The slots' own descriptors, in field order: setting them is what a frozen dataclass's
    # __init__ does through object.__setattr__, at half the cost.
    return tuple(cls.__dict__[f.name].__set__ for f in dataclasses.fields(cls))


# Written out, not looped over: a loop over the setters cost a third of the gain.
(_m0, _m1, _m2, _m3, _m4, _m5, _m6, _m7, _m8, _m9, _m10, _m11, _m12) = _slot_setters(ApiMetric)
(_d0, _d1, _d2, _d3, _d4, _d5, _d6, _d7, _d8) = _slot_setters(ApiMetricsData)
_new = object.__new__


def _new_metric(*v: Any) -> ApiMetric:
    item: ApiMetric = _new(ApiMetric)
    _m0(item, v[0]), _m1(item, v[1]), _m2(item, v[2]), _m3(item, v[3]), _m4(item, v[4])
    _m5(item, v[5]), _m6(item, v[6]), _m7(item, v[7]), _m8(item, v[8]), _m9(item, v[9])
    _m10(item, v[10]), _m11(item, v[11]), _m12(item, v[12])
    return item


def _new_metrics_data(*v: Any) -> ApiMetricsData:
    item: ApiMetricsData = _new(ApiMetricsData)
    _d0(item, v[0]), _d1(item, v[1]), _d2(item, v[2]), _d3(item, v[3]), _d4(item, v[4])
    _d5(item, v[5]), _d6(item, v[6]), _d7(item, v[7]), _d8(item, v[8])
    return item


class _MalformedError(Exception):
    """Not the well-formed shape: the item goes the general way, which says what is wrong."""


def _text(value: object) -> str | None:
    """An optional string: "" and null read as None."""
    if type(value) is str:
        return value or None
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
    if value is None or value == "":
        return None
    if type(value) is not str:
        raise _MalformedError
    text, moment = _last_timestamp
    if value == text:
        return moment
    moment = parse_rfc3339(value)
    if moment is None or moment.tzinfo is None:
        raise _MalformedError
    _last_timestamp = (value, moment)
    return moment


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
        # In field order; the same checks as ApiMetric.from_json.
        return _new_metric(
            new_uuid(metric_id),  # unique per item: not worth a place in the ID cache
            _text(get("name")) or "",
            kind,
            status,
            value,
            _text(get("unit")),
            _text(get("metricURL")),
            data_ids,
            event_metric,
            owner,
            _opt_id(get("jobID")) if owner is MetricOwner.JOB else None,
            _opt_id(get("batchID")),
            _timestamp(get("creationTimestamp")),
        )
    except (_MalformedError, ValueError, TypeError, AttributeError):
        return None


def _metrics_data(data: Mapping[str, Any], owner: MetricOwner) -> ApiMetricsData | None:
    get = data.get
    try:
        data_id = get("dataID")
        if type(data_id) is not str or not data_id:
            return None
        storage_type = get("metricsDataType")
        if type(storage_type) is str and storage_type:
            storage_type = _STORAGE_TYPES.get(storage_type, storage_type)
        elif storage_type is None or storage_type == "":
            storage_type = _STANDARD
        else:
            return None
        job = owner is MetricOwner.JOB
        return _new_metrics_data(
            # Through the ID cache: the job's metrics list it too (their dataIDs).
            parse_uuid(data_id),
            _text(get("name")) or "",
            storage_type,
            _text(get("metricsDataURL")),
            _text(get("filename")),
            owner,
            _opt_id(get("jobID")) if job else None,
            None if job else _opt_id(get("batchID")),
            _timestamp(get("creationTimestamp")),
        )
    except (_MalformedError, ValueError, TypeError, AttributeError):
        return None


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
