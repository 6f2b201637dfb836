"""What report mode reads of a job's metric listing, read from its JSON items directly.

Report mode lists every job's metrics (thousands of listings, ~11 items each) and keeps
only each metric's status and, for its SCALARs, name, value and unit. Reading each item
into an `ApiMetric` first (IDs, timestamps, a frozen dataclass) was most of the client's
own CPU per listing. Here a listing whose every item is well-formed is read in one pass:
each item's fields are checked for the shapes the model accepts, as the model reads them
(`stook.service.api._listing_items._metric`), but nothing is built but the scalars. A
timestamp other than the previous item's is read with `datetime.fromisoformat`, as the model first
reads it, and else by reading its item as the model does. A listing
with anything else — a field of another type, an ID not written as 36 hex digits and
hyphens, a timestamp the model refuses, a SCALAR listed with a null value (its number is
in its message) — gives None, and the caller reads it through the model, which converts
what it can, words the error for what it cannot, and reads null scalars' messages
(tests/service/fetch/test_listed_scalars.py checks that both paths agree).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Final

from stook.service.api import (
    ApiMetric,
    ApiMetricStatus,
    ApiMetricType,
    MetricOwner,
)
from stook.service.fetch._listing_checks import (
    are_ids,
    is_owner_id,
    model_reads_time,
)

__all__ = ["ListedScalars", "read_listed_scalars"]

_SCALAR: Final = ApiMetricType.SCALAR.value
_NO_STATUS: Final = ApiMetricStatus.NO_STATUS_REPORTED.value
# The model reading a whole item, for a creation time fromisoformat does not read.
_read: Final = functools.partial(ApiMetric.from_json, owner=MetricOwner.JOB)
# The fields the model reads, in one call: most items have them all.
_KEYS: Final = (
    "metricID",
    "type",
    "status",
    "value",
    "dataIDs",
    "eventMetric",
    "name",
    "unit",
    "metricURL",
    "jobID",
    "batchID",
    "creationTimestamp",
)


@functools.cache
def _fields() -> Callable[[dict[str, Any]], tuple[Any, ...]]:
    """What reads `_KEYS` of an item (see `ApiClient.field_reader`); imported here, with
    the first answer, as the client has been by then."""
    from stook.service.api import ApiClient

    return ApiClient.field_reader(_KEYS)


# Not frozen: a frozen dataclass sets each field through object.__setattr__, three times
# the cost of the plain __init__, for one of these per job. Nobody changes one.
@dataclass(slots=True)
class ListedScalars:
    """A job's metric listing as report and batch mode read it: each SCALAR's (value,
    unit) by name (the last of a name wins), every named SCALAR's name, and each item's
    status as its text (an unknown one as written; none as NO_STATUS_REPORTED).

    For batch mode also: each SCALAR's status by name (the last of a name wins, as for
    its value) and every named item's name. Left empty where the listing was read as
    `ApiMetric`s (report mode does not need them)."""

    values: dict[str, tuple[float, str]]
    names: list[str]
    statuses: list[str]
    scalar_statuses: dict[str, str] = field(default_factory=dict)
    metric_names: list[str] = field(default_factory=list)


def read_listed_scalars(items: list[Any]) -> ListedScalars | None:
    """`items` (a job's metric listing) read in one pass, or None when any item is not
    well-formed or is a SCALAR listed without a value: then read them as `ApiMetric`s."""
    values: dict[str, tuple[float, str]] = {}
    names: list[str] = []
    statuses: list[str] = []
    scalar_statuses: dict[str, str] = {}
    metric_names: list[str] = []
    # The last item's job and batch IDs, checked: a listing's items repeat them (a
    # comparison costs less than a set's hash of a new string).
    checked_job: object = None
    checked_batch: object = None
    timestamp = ""  # the last item's, checked: a listing's items were created together
    ids: list[str] = []  # the metric, data and owner IDs, checked at once
    fields_of = _fields()
    for item in items:
        try:
            fields = fields_of(item)
        except (KeyError, TypeError):  # a field left out (read as null), or no object
            if type(item) is not dict:
                return None
            fields = tuple(map(item.get, _KEYS))
        (
            metric_id,
            kind,
            status,
            value,
            data_ids,
            event_metric,
            name,
            unit,
            url,
            job_id,
            batch_id,
            created,
        ) = fields
        # The model's checks, each field for the shapes it reads as they are. The IDs are
        # checked at the end, all at once, their types too (`are_ids`).
        ids.append(metric_id)
        if type(kind) is not str and kind is not None:
            return None
        if type(status) is str:
            status = status or _NO_STATUS
        elif status is None:
            status = _NO_STATUS
        else:
            return None
        statuses.append(status)
        if type(value) is not float and value is not None:
            return None  # an integer the model converts; anything else it refuses
        if type(data_ids) is list:
            ids += data_ids
        elif data_ids is not None:
            return None
        if type(event_metric) is not bool and event_metric is not None:
            return None
        if (
            (type(name) is not str and name is not None)
            or (type(unit) is not str and unit is not None)
            or (type(url) is not str and url is not None)
        ):
            return None
        if job_id != checked_job or batch_id != checked_batch:
            if not (is_owner_id(job_id, ids) and is_owner_id(batch_id, ids)):
                return None
            checked_job, checked_batch = job_id, batch_id
        if type(created) is str:
            if created and created != timestamp and not model_reads_time(created, item, _read):
                return None
            timestamp = created
        elif created is not None:
            return None
        if name:
            metric_names.append(name)
            if kind == _SCALAR and not event_metric:
                if value is None:
                    return None  # its number is in its message
                names.append(name)
                values[name] = (value, unit or "")
                scalar_statuses[name] = status
    if not are_ids(ids):
        return None
    return ListedScalars(values, names, statuses, scalar_statuses, metric_names)
