"""The fetch layer's errors, beside the API layer's, which it raises through unchanged.

    StookError (stook.sdk)
    ├── ApiError (stook.service.api)  a request failed for good (the API layer's tree)
    ├── FetchError                    the fetch ended without a complete result (exit 3)
    │   ├── DeadlineReachedError      `[fetch] deadline` reached
    │   └── ReportNotFoundError       the report ID does not exist in its project
    └── ReadError (stook.sdk)
        └── InvalidDataError          a job's metrics data could not be decoded (exit 4)

The exit codes are mapped once, by the CLI (`stook.service.cli`), from these classes: a
FetchError is not an ApiError (no request failed), so `except ApiError` catches what the
server or the network did, and `except FetchError` what the fetch as a whole could not do.
"""

from __future__ import annotations

from stook.sdk import ReadError, StookError

__all__ = ["DeadlineReachedError", "FetchError", "InvalidDataError", "ReportNotFoundError"]


class FetchError(StookError):
    """The fetch ended without a complete result, though no request failed (exit code 3)."""


class DeadlineReachedError(FetchError):
    """The fetch outlasted `[fetch] deadline` (exit code 3)."""


class ReportNotFoundError(FetchError):
    """The report ID of report_config.json does not exist in its project (exit code 3)."""


class InvalidDataError(ReadError):
    """A job's metrics data could not be decoded (exit code 4)."""
