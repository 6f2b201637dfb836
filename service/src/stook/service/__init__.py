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

This package is the one place in stook whose names are imported on first use (PEP 562's
module `__getattr__`); every other package re-exports its names plainly. The `stook`
console script is ``stook.service.cli:main``, so Python runs this file before any of the
command's own: eager, it would load the whole library (about 200 modules, ~0.2 s) for
`stook --help`, before the command even knows what it was asked. Each name below is
imported from the first layer, lowest first, whose ``__all__`` has it; type checkers read
the imports under TYPE_CHECKING.
"""

# Plain module imports only: any other name bound here would be public.
import importlib
import typing

if typing.TYPE_CHECKING:
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

_LAYERS = ("stook.service.api", "stook.service.fetch", "stook.service.modes")


def __getattr__(name: str) -> object:
    if name in __all__:
        for layer in _LAYERS:
            module = importlib.import_module(layer)
            if name in module.__all__:
                return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
