"""The API layer: transport, retry policy, limits, clients, models, errors and redaction.

It imports nothing from the layers above it (fetch, modes, cli), and inside it the
transport knows nothing of the retry policy above it.
"""

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
    OriginUnreachableError,
    PresignedUrlExpiredError,
    RedirectedRefusalError,
    RetriesExhaustedError,
    RetryAfterTooLongError,
    StorageError,
    TransportError,
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
    Origin,
    RetryPolicy,
)
from stook.service.api._storage import (
    StorageClient,
)
from stook.service.api._transport import (
    BodyCap,
    HttpTransport,
    Response,
    TransferStats,
    Transport,
    body_cap_mb,
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
    "Origin",
    "OriginUnavailableError",
    "OriginUnreachableError",
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
    "redact_event",
    "redact_text",
    "redact_url",
    "register_secret",
]
