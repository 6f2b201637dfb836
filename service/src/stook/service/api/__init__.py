"""The ReSim API layer: clients, models, errors, retries, limits and redaction; it imports no
higher layer."""

from stook.service.api._client import ApiClient
from stook.service.api._errors import (
    ApiError,
    ApiResponseError,
    ApiStatusError,
    AuthError,
    BodyTooLargeError,
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
from stook.service.api._job_logs import ExecutionStep, JobLog, LogType
from stook.service.api._limits import AimdLimiter, ConcurrencyLimit, FixedLimit, LimitStats
from stook.service.api._models import (
    ApiMetric,
    ApiMetricsData,
    ApiMetricType,
    Batch,
    BatchStatus,
    Build,
    Job,
    JobEventListing,
    MetricOwner,
    Report,
)
from stook.service.api._redact import redact_text, redact_url
from stook.service.api._retry import Origin, RetryPolicy
from stook.service.api._storage import StorageClient
from stook.service.api._transport import BodyCap, Response, TransferStats, Transport, body_cap_mb

__all__ = [
    "AimdLimiter",
    "ApiClient",
    "ApiError",
    "ApiMetric",
    "ApiMetricType",
    "ApiMetricsData",
    "ApiResponseError",
    "ApiStatusError",
    "AuthError",
    "Batch",
    "BatchStatus",
    "BodyCap",
    "BodyTooLargeError",
    "Build",
    "ConcurrencyLimit",
    "ExecutionStep",
    "FixedLimit",
    "Job",
    "JobEventListing",
    "JobLog",
    "LimitStats",
    "LogType",
    "MetricOwner",
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
    "redact_text",
    "redact_url",
]
