"""The API layer: transport, retry policy, limits, clients, models, errors and redaction.

It imports nothing from the layers above it (fetch, modes, cli), and inside it the
transport knows nothing of the retry policy above it. Its names are imported on first use
(see stook.service._lazy): importing it for `redact_url` does not import aiohttp.
"""

from __future__ import annotations

# typing.TYPE_CHECKING without importing typing (see cli/_main.py).
TYPE_CHECKING = False
if TYPE_CHECKING:
    from stook.service.api._client import (
        ApiClient,
        IdLike,
    )
    from stook.service.api._errors import (
        ApiError,
        ApiResponseError,
        ApiStatusError,
        AuthError,
        BodyTooLargeError,
        IncompleteBodyError,
        NotFoundError,
        OriginUnavailableError,
        PresignedUrlExpiredError,
        RedirectedRefusalError,
        RetriesExhaustedError,
        RetryAfterTooLongError,
        StorageError,
        TransportError,
    )
    from stook.service.api._gate import (
        GateStats,
        OriginGate,
    )
    from stook.service.api._job_logs import (
        ExecutionStep,
        JobLog,
        LogType,
    )
    from stook.service.api._limits import (
        AimdLimiter,
        ConcurrencyLimit,
        FixedLimit,
        LimitStats,
        NestedLimit,
    )
    from stook.service.api._logging import (
        configure_logging,
        get_logger,
        redact_event,
    )
    from stook.service.api._models import (
        ApiMetric,
        ApiMetricsData,
        ApiMetricStatus,
        ApiMetricType,
        Batch,
        BatchStatus,
        Branch,
        Build,
        ConflatedBatchStatus,
        ConflatedJobStatus,
        EventTimestampType,
        ExperienceTag,
        Job,
        JobEventListing,
        JobStatus,
        MetricOwner,
        MetricsDataStorageType,
        Report,
    )
    from stook.service.api._redact import (
        redact_text,
        redact_url,
        register_secret,
    )
    from stook.service.api._retry import (
        RetryPolicy,
    )
    from stook.service.api._stats import (
        TransferStats,
    )
    from stook.service.api._storage import (
        StorageClient,
    )
    from stook.service.api._tls import (
        import_aiohttp_without_tls_defaults,
    )
    from stook.service.api._transport import (
        BodyCap,
        HttpTransport,
        Response,
        Transport,
        body_cap_mb,
    )
else:
    from stook.service._lazy import lazy_exports

    __getattr__, __dir__ = lazy_exports(
        __name__,
        {
            "ApiClient": "stook.service.api._client",
            "IdLike": "stook.service.api._client",
            "ApiError": "stook.service.api._errors",
            "ApiResponseError": "stook.service.api._errors",
            "ApiStatusError": "stook.service.api._errors",
            "AuthError": "stook.service.api._errors",
            "BodyTooLargeError": "stook.service.api._errors",
            "IncompleteBodyError": "stook.service.api._errors",
            "NotFoundError": "stook.service.api._errors",
            "OriginUnavailableError": "stook.service.api._errors",
            "PresignedUrlExpiredError": "stook.service.api._errors",
            "RedirectedRefusalError": "stook.service.api._errors",
            "RetriesExhaustedError": "stook.service.api._errors",
            "RetryAfterTooLongError": "stook.service.api._errors",
            "StorageError": "stook.service.api._errors",
            "TransportError": "stook.service.api._errors",
            "GateStats": "stook.service.api._gate",
            "OriginGate": "stook.service.api._gate",
            "ExecutionStep": "stook.service.api._job_logs",
            "JobLog": "stook.service.api._job_logs",
            "LogType": "stook.service.api._job_logs",
            "AimdLimiter": "stook.service.api._limits",
            "ConcurrencyLimit": "stook.service.api._limits",
            "FixedLimit": "stook.service.api._limits",
            "LimitStats": "stook.service.api._limits",
            "NestedLimit": "stook.service.api._limits",
            "configure_logging": "stook.service.api._logging",
            "get_logger": "stook.service.api._logging",
            "redact_event": "stook.service.api._logging",
            "ApiMetric": "stook.service.api._models",
            "ApiMetricsData": "stook.service.api._models",
            "ApiMetricStatus": "stook.service.api._models",
            "ApiMetricType": "stook.service.api._models",
            "Batch": "stook.service.api._models",
            "BatchStatus": "stook.service.api._models",
            "Branch": "stook.service.api._models",
            "Build": "stook.service.api._models",
            "ConflatedBatchStatus": "stook.service.api._models",
            "ConflatedJobStatus": "stook.service.api._models",
            "EventTimestampType": "stook.service.api._models",
            "ExperienceTag": "stook.service.api._models",
            "Job": "stook.service.api._models",
            "JobEventListing": "stook.service.api._models",
            "JobStatus": "stook.service.api._models",
            "MetricOwner": "stook.service.api._models",
            "MetricsDataStorageType": "stook.service.api._models",
            "Report": "stook.service.api._models",
            "redact_text": "stook.service.api._redact",
            "redact_url": "stook.service.api._redact",
            "register_secret": "stook.service.api._redact",
            "RetryPolicy": "stook.service.api._retry",
            "TransferStats": "stook.service.api._stats",
            "StorageClient": "stook.service.api._storage",
            "import_aiohttp_without_tls_defaults": "stook.service.api._tls",
            "body_cap_mb": "stook.service.api._transport",
            "BodyCap": "stook.service.api._transport",
            "HttpTransport": "stook.service.api._transport",
            "Response": "stook.service.api._transport",
            "Transport": "stook.service.api._transport",
        },
    )

__all__ = [
    "AimdLimiter",
    "ApiClient",
    "ApiError",
    "ApiMetric",
    "ApiMetricStatus",
    "ApiMetricType",
    "ApiMetricsData",
    "ApiResponseError",
    "ApiStatusError",
    "AuthError",
    "Batch",
    "BatchStatus",
    "BodyCap",
    "BodyTooLargeError",
    "Branch",
    "Build",
    "ConcurrencyLimit",
    "ConflatedBatchStatus",
    "ConflatedJobStatus",
    "EventTimestampType",
    "ExecutionStep",
    "ExperienceTag",
    "FixedLimit",
    "GateStats",
    "HttpTransport",
    "IdLike",
    "IncompleteBodyError",
    "Job",
    "JobEventListing",
    "JobLog",
    "JobStatus",
    "LimitStats",
    "LogType",
    "MetricOwner",
    "MetricsDataStorageType",
    "NestedLimit",
    "NotFoundError",
    "OriginGate",
    "OriginUnavailableError",
    "PresignedUrlExpiredError",
    "RedirectedRefusalError",
    "Report",
    "Response",
    "RetriesExhaustedError",
    "RetryAfterTooLongError",
    "RetryPolicy",
    "StorageClient",
    "StorageError",
    "TransferStats",
    "Transport",
    "TransportError",
    "body_cap_mb",
    "configure_logging",
    "get_logger",
    "import_aiohttp_without_tls_defaults",
    "redact_event",
    "redact_text",
    "redact_url",
    "register_secret",
]
