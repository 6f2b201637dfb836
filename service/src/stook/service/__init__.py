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

Names are imported on first use (see stook.service._lazy): `stook --help` imports this
package before its signal handlers are in place, and without polars or aiohttp.
"""

from __future__ import annotations

# typing.TYPE_CHECKING without importing typing (see cli/_main.py).
TYPE_CHECKING = False
if TYPE_CHECKING:
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
else:
    from stook.service._lazy import lazy_exports

    __getattr__, __dir__ = lazy_exports(
        __name__,
        {
            "AimdLimiter": "stook.service.api",
            "ApiClient": "stook.service.api",
            "ApiError": "stook.service.api",
            "ApiMetric": "stook.service.api",
            "ApiMetricsData": "stook.service.api",
            "ApiResponseError": "stook.service.api",
            "ApiStatusError": "stook.service.api",
            "AuthError": "stook.service.api",
            "Batch": "stook.service.api",
            "BodyCap": "stook.service.api",
            "Build": "stook.service.api",
            "FixedLimit": "stook.service.api",
            "Job": "stook.service.api",
            "MetricOwner": "stook.service.api",
            "NotFoundError": "stook.service.api",
            "OriginUnavailableError": "stook.service.api",
            "PresignedUrlExpiredError": "stook.service.api",
            "Report": "stook.service.api",
            "RetriesExhaustedError": "stook.service.api",
            "RetryAfterTooLongError": "stook.service.api",
            "RetryPolicy": "stook.service.api",
            "StorageClient": "stook.service.api",
            "StorageError": "stook.service.api",
            "TransportError": "stook.service.api",
            "BatchFetcher": "stook.service.fetch",
            "FetchOutcome": "stook.service.fetch",
            "InvalidDataError": "stook.service.fetch",
            "MissingJob": "stook.service.fetch",
            "ReportFetcher": "stook.service.fetch",
            "ReportNotFoundError": "stook.service.fetch",
            "ReportOutcome": "stook.service.fetch",
            "fetch_batch": "stook.service.modes",
            "fetch_batch_frame": "stook.service.modes",
            "fetch_report": "stook.service.modes",
        },
    )

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
