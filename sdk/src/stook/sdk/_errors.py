"""The SDK's exception types: one base, one type per thing that can go wrong."""

from __future__ import annotations

from dataclasses import dataclass


class StookError(Exception):
    """Base of every error stook raises on purpose."""


class WriterError(StookError, ValueError):
    """A metric or metrics data given to the writer cannot form a valid output."""


class OutputWriteError(StookError, OSError):
    """The output file could not be written: the disk is full, a file-size limit was hit, the
    folder refused it. Unlike the bare OSError (``[Errno 28] No space left on device``), its
    message names the path; it is still an OSError for code that catches those."""

    def __str__(self) -> str:
        return f"cannot write {self.filename}: {self.strerror}"


class ReadError(StookError):
    """Bytes could not be read as the message they were said to be.

    The message names what was being read, e.g.
    ``could not read MetricsData from 'job 1234 / speeds': truncated or not a protobuf message``.
    """


@dataclass(frozen=True)
class Problem:
    """One rule an output breaks: where (a metric, data or event name) and which rule."""

    where: str
    rule: str

    def __str__(self) -> str:
        return f"{self.where}: {self.rule}"


class InvalidMetricsError(StookError):
    """A JobMetrics message breaks one or more of the platform's rules."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = problems
        first = str(problems[0]) if problems else "invalid metrics"
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        super().__init__(first + more)
