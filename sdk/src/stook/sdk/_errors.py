"""The SDK's exceptions: one base, one type per thing that can go wrong.

The hierarchy::

    StookError                      every error stook raises on purpose
    ├── WriterError (ValueError)    a metric or data cannot form a valid output
    ├── OutputWriteError (OSError)  the output file could not be written
    ├── InvalidMetricsError         a JobMetrics message breaks the platform's rules
    ├── ReadError                   bytes are not readable as the message they should be
    │   ├── MissingDataError        a metric references data the output does not hold
    │   └── JobDataError            a job's data is not what an aggregation can read
    ├── AggregationConfigError      a config table does not describe an aggregation
    └── SummaryError                bytes are not a stook batch summary
        └── SummaryVersionError     a summary in a newer stook's layout

    MetricNotFoundError (KeyError)  no metric of that name in a `JobMetricsView`

`Problem` is one rule an output breaks, as `InvalidMetricsError.problems` lists them.
`MalformedError` and `read_error` are the reader's internals, not part of the public
surface: a view that finds a value it cannot decode raises the former deep down, and
the reader's entry points turn it into a `ReadError` that names what was being read.
Which exit code each error means is the service's to say (docs/cli.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import uuid

    from google.protobuf.message import Message


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


class MissingDataError(ReadError):
    """A metric references a metrics data ID that the output it was read from does not hold.

    ``metric`` is the metric's name, ``data_id`` the ID it references (None when the
    reference is unset).
    """

    def __init__(self, metric: str, data_id: uuid.UUID | None) -> None:
        self.metric = metric
        self.data_id = data_id
        what = f"metrics data {data_id}" if data_id is not None else "a metrics data with no ID"
        super().__init__(f"metric {metric!r} references {what}, which the output does not hold")


class MalformedError(Exception):
    """Parsed, but not readable as the claimed message; turned into a ReadError."""


def read_error(what: type[Message], source: str, reason: str) -> ReadError:
    return ReadError(f"could not read {what.DESCRIPTOR.name} from {source!r}: {reason}")


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


class JobDataError(ReadError):
    """A job's metric or data is not what the configured aggregation can read, or it
    disagrees with another job's (histogram buckets that differ, say). The message names
    the job or jobs at fault. It is invalid data, like any `ReadError`."""


class AggregationConfigError(StookError):
    """A config table does not describe an aggregation that can be built."""


class SummaryError(StookError):
    """Bytes that are not a stook batch summary (truncated, or another format)."""


class SummaryVersionError(SummaryError):
    """A summary written by a newer stook, in a layout this one does not know."""


class MetricNotFoundError(KeyError):
    """No metric of that name; a KeyError whose message reads as a sentence."""

    def __str__(self) -> str:
        return str(self.args[0])
