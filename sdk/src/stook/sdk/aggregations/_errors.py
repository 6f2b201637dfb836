"""The error an aggregation raises when the jobs' data cannot be aggregated as configured."""

from __future__ import annotations

from stook.sdk._errors import ReadError


class JobDataError(ReadError):
    """A job's metric or data is not what the configured aggregation can read, or it
    disagrees with another job's (histogram buckets that differ, say). The message names
    the job or jobs at fault. It is invalid data, exit code 4, like any `ReadError`."""
