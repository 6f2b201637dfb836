"""The fetch layer: every job of a batch, or every batch of a report, as records.

On top of the API layer (it imports `stook.service.api` and nothing above it): bounded
pools of workers list and download only what the aggregations' `Needs` name, and hand each
job (`JobRecord`) or batch (`BatchRecord`) on as soon as it is complete.
"""

from __future__ import annotations

# typing.TYPE_CHECKING without importing typing (see cli/_main.py). Names are imported on
# first use (see stook.service._lazy): a batch run does not import the report fetch, nor
# the baseline's search.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from stook.service.fetch._baseline_find import BaselineFound, find_baseline
    from stook.service.fetch._batch_fetch import BatchFetcher, FetchOutcome, MissingJob
    from stook.service.fetch._deadline import DeadlineReachedError, fetch_deadline
    from stook.service.fetch._directions import failure_directions
    from stook.service.fetch._emissions import fetch_emissions, fetch_emissions_log
    from stook.service.fetch._job_blobs import InvalidDataError, decode_values
    from stook.service.fetch._report_fetch import (
        ReportFetcher,
        ReportNotFoundError,
        ReportOutcome,
        search_for,
    )
    from stook.service.fetch._scalars import is_scalar, read_scalars
else:
    from stook.service._lazy import lazy_exports

    __getattr__, __dir__ = lazy_exports(
        __name__,
        {
            "BaselineFound": "stook.service.fetch._baseline_find",
            "find_baseline": "stook.service.fetch._baseline_find",
            "BatchFetcher": "stook.service.fetch._batch_fetch",
            "FetchOutcome": "stook.service.fetch._batch_fetch",
            "InvalidDataError": "stook.service.fetch._job_blobs",
            "MissingJob": "stook.service.fetch._batch_fetch",
            "DeadlineReachedError": "stook.service.fetch._deadline",
            "fetch_deadline": "stook.service.fetch._deadline",
            "failure_directions": "stook.service.fetch._directions",
            "fetch_emissions": "stook.service.fetch._emissions",
            "fetch_emissions_log": "stook.service.fetch._emissions",
            "decode_values": "stook.service.fetch._job_blobs",
            "ReportFetcher": "stook.service.fetch._report_fetch",
            "ReportNotFoundError": "stook.service.fetch._report_fetch",
            "ReportOutcome": "stook.service.fetch._report_fetch",
            "search_for": "stook.service.fetch._report_fetch",
            "is_scalar": "stook.service.fetch._scalars",
            "read_scalars": "stook.service.fetch._scalars",
        },
    )

__all__ = [
    "BaselineFound",
    "BatchFetcher",
    "DeadlineReachedError",
    "FetchOutcome",
    "InvalidDataError",
    "MissingJob",
    "ReportFetcher",
    "ReportNotFoundError",
    "ReportOutcome",
    "decode_values",
    "failure_directions",
    "fetch_deadline",
    "fetch_emissions",
    "fetch_emissions_log",
    "find_baseline",
    "is_scalar",
    "read_scalars",
    "search_for",
]
