"""stook's library: the ReSim API client and the fetch cores that `stook run` is built on.

    from stook.sdk.aggregations import Needs
    from stook.service import ApiClient, BatchFetcher

    async with ApiClient(api_url, token) as api:
        fetcher = BatchFetcher(api, project_id, batch_id, Needs(data=frozenset({"speeds"})))
        outcome = await fetcher.run(on_job)  # each job as a stook.sdk.aggregations.JobRecord

The layers, lowest first, each importing only from those below it: `stook.service.api`
(transport, retries, limits, clients, models, errors, redaction), `stook.service.fetch`
(a batch's jobs or a report's batches as records), `stook.service.modes` (test, batch and
report mode) and `stook.service.cli` (the `stook` command). This package re-exports what
a program built on the first two needs, and the fetch library (`fetch_batch`,
`fetch_batch_frame`, `fetch_report`, from the modes layer, which reads the platform's
inputs); each layer's own ``__all__`` has the rest.

Heavy libraries (aiohttp, polars, ...) are imported by the functions that use them, so
that importing this package, as `stook --help` does, stays cheap.
"""

from stook.service.api import (
    AimdLimiter,
    ApiClient,
    ApiError,
    ApiMetric,
    ApiMetricsData,
    ApiResponseError,
    ApiStatusError,
    AuthError,
    Batch,
    BodyCap,
    Build,
    FixedLimit,
    Job,
    MetricOwner,
    NotFoundError,
    OriginUnavailableError,
    PresignedUrlExpiredError,
    Report,
    RetriesExhaustedError,
    RetryAfterTooLongError,
    RetryPolicy,
    StorageClient,
    StorageError,
    TransportError,
)
from stook.service.fetch import (
    BatchFetcher,
    FetchOutcome,
    InvalidDataError,
    MissingJob,
    ReportFetcher,
    ReportNotFoundError,
    ReportOutcome,
)
from stook.service.modes import fetch_batch, fetch_batch_frame, fetch_report

__all__ = [
    "AimdLimiter",
    "ApiClient",
    "ApiError",
    "ApiMetric",
    "ApiMetricsData",
    "ApiResponseError",
    "ApiStatusError",
    "AuthError",
    "Batch",
    "BatchFetcher",
    "BodyCap",
    "Build",
    "FetchOutcome",
    "FixedLimit",
    "InvalidDataError",
    "Job",
    "MetricOwner",
    "MissingJob",
    "NotFoundError",
    "OriginUnavailableError",
    "PresignedUrlExpiredError",
    "Report",
    "ReportFetcher",
    "ReportNotFoundError",
    "ReportOutcome",
    "RetriesExhaustedError",
    "RetryAfterTooLongError",
    "RetryPolicy",
    "StorageClient",
    "StorageError",
    "TransportError",
    "fetch_batch",
    "fetch_batch_frame",
    "fetch_report",
]
