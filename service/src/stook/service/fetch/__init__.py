"""The fetch layer: every job of a batch, or every batch of a report, as records.

On top of the API layer (it imports `stook.service.api` and nothing above it): bounded
pools of workers list and download only what the aggregations' `Needs` name, and hand each
job (`JobRecord`) or batch (`BatchRecord`) on as soon as it is complete.
"""

from stook.service.fetch._baseline_find import BaselineFound, failure_directions, find_baseline
from stook.service.fetch._batch_fetch import BatchFetcher, FetchOutcome, MissingJob, OnEmissions
from stook.service.fetch._emissions import JobEmissions, fetch_emissions, fetch_emissions_log
from stook.service.fetch._errors import (
    DeadlineReachedError,
    FetchError,
    InvalidDataError,
    ReportNotFoundError,
)
from stook.service.fetch._job_blobs import decode_values
from stook.service.fetch._report_fetch import (
    ReportFetcher,
    ReportOutcome,
    search_for,
)
from stook.service.fetch._scalars import is_scalar, read_scalars

__all__ = [
    "BaselineFound",
    "BatchFetcher",
    "DeadlineReachedError",
    "FetchError",
    "FetchOutcome",
    "InvalidDataError",
    "JobEmissions",
    "MissingJob",
    "OnEmissions",
    "ReportFetcher",
    "ReportNotFoundError",
    "ReportOutcome",
    "decode_values",
    "failure_directions",
    "fetch_emissions",
    "fetch_emissions_log",
    "find_baseline",
    "is_scalar",
    "read_scalars",
    "search_for",
]
