"""A job's metrics-data listing as batch mode reads it for data asked for by name, read
from its JSON items directly.

Batch mode lists every job's metrics data (a dozen items each) and, when the plan asks
for data by name only, keeps every item's name and downloads the few it names. Reading
each item into an `ApiMetricsData` first (a UUID, a timestamp, a frozen dataclass) was
the largest share of the client's own CPU per job. Here a listing whose every item is
well-formed is read in one pass: each item's fields are checked for the shapes the model
accepts (`ApiMetricsData.from_json`), as `_listed_scalars` checks a metric listing, and
only the items the plan names are left to be read as `ApiMetricsData`. A timestamp other than the
previous item's is read with `datetime.fromisoformat`, and else by reading its item as
the model does. A listing with anything else — a field of another type, an ID not written
as 36 hex digits and hyphens, a timestamp the model refuses — gives None, and the caller
reads it through the model, which converts what it can and words the error for what it
cannot (tests/service/fetch/test_listed_data.py checks that both paths agree).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any, Final

from stook.service.api import ApiMetricsData, MetricOwner
from stook.service.fetch._listing_checks import (
    are_ids,
    is_owner_id,
    model_reads_time,
)

__all__ = ["ListedData", "read_listed_data"]

# The model reading a whole item, for a creation time fromisoformat does not read.
_read: Final = functools.partial(ApiMetricsData.from_json, owner=MetricOwner.JOB)
# What the model reads as a STANDARD item: the member's text, or no type at all.
_STANDARD_TYPES: Final = frozenset({"STANDARD", "", None})
# The fields the model reads, in one call: most items have them all.
_KEYS: Final = (
    "dataID",
    "name",
    "metricsDataType",
    "metricsDataURL",
    "filename",
    "jobID",
    "creationTimestamp",
)


@functools.cache
def _fields() -> Callable[[dict[str, Any]], tuple[Any, ...]]:
    """What reads `_KEYS` of an item (see `ApiClient.field_reader`); imported here, with
    the first answer, as the client has been by then."""
    from stook.service.api import ApiClient

    return ApiClient.field_reader(_KEYS)


# Not frozen: one per job, and a frozen dataclass's __init__ costs three times the plain
# one (each field set through object.__setattr__). Nobody changes one.
@dataclass(slots=True)
class ListedData:
    """A job's metrics-data listing as batch mode reads it: every named item's name (in
    listing order), how many items have no name, and the STANDARD items whose name is
    wanted, as listed (in listing order; read them with
    `ApiClient.read_job_metrics_data`)."""

    names: list[str]
    unnamed: int
    wanted: list[dict[str, Any]]


def read_listed_data(items: list[Any], wanted: Collection[str]) -> ListedData | None:
    """`items` (a job's metrics-data listing) read in one pass, or None when any item is
    not well-formed: then read them as `ApiMetricsData`s."""
    names: list[str] = []
    unnamed = 0
    found: list[dict[str, Any]] = []
    # The last item's job ID, checked: a listing's items repeat it (a comparison costs
    # less than a set's hash of a new string).
    checked_job: object = None
    timestamp = ""  # the last item's, checked: a listing's items were created together
    ids: list[str] = []  # the data and owner IDs, checked at once
    fields_of = _fields()
    for item in items:
        try:
            fields = fields_of(item)
        except (KeyError, TypeError):  # a field left out (read as null), or no object
            if type(item) is not dict:
                return None
            fields = tuple(map(item.get, _KEYS))
        data_id, name, kind, url, filename, job_id, created = fields
        # The model's checks, each field for the shapes it reads as they are. The IDs are
        # checked at the end, all at once, their types too (`are_ids`).
        ids.append(data_id)
        if (
            (type(kind) is not str and kind is not None)
            or (type(url) is not str and url is not None)
            or (type(filename) is not str and filename is not None)
        ):
            return None
        if job_id != checked_job:
            if not is_owner_id(job_id, ids):
                return None
            checked_job = job_id
        if type(created) is str:
            if created and created != timestamp and not model_reads_time(created, item, _read):
                return None
            timestamp = created
        elif created is not None:
            return None
        if type(name) is str and name:
            names.append(name)
            if name in wanted and kind in _STANDARD_TYPES:
                found.append(item)
        elif name is None or name == "":
            unnamed += 1
        else:
            return None
    if not are_ids(ids):
        return None
    return ListedData(names, unnamed, found)
