"""Schema series to plain Python values, for code that wants a few values without polars.

Doubles are floats, strings str, timestamps integer UTC nanoseconds (as `EventView`
counts them), UUIDs ``uuid.UUID`` and statuses `MetricStatus` members (None for an
unset status, the number for one this schema does not know). A UUID that does not
parse raises `MalformedError`; the views turn it into a `ReadError` naming the data.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from typing import Any

from stook.proto import metrics_pb2 as pb
from stook.sdk._enums import NANOS_PER_SECOND, MetricStatus, SeriesKind
from stook.sdk._errors import MalformedError


def plain_values(series: pb.Series, kind: SeriesKind) -> tuple[Any, ...]:
    """The elements of `series`, which holds elements of `kind` (not an external file)."""
    return _CONVERTERS[kind](series)


def _uuid(text: str) -> uuid.UUID:
    try:
        return uuid.UUID(hex=text)
    except ValueError:
        raise MalformedError(f"series element {text!r} is not a UUID") from None


def _status(value: int) -> MetricStatus | int | None:
    if value == 0:
        return None
    try:
        return MetricStatus(value)
    except ValueError:
        return value


_CONVERTERS: dict[SeriesKind, Callable[[pb.Series], tuple[Any, ...]]] = {
    SeriesKind.DOUBLE: lambda s: tuple(s.doubles.series),
    SeriesKind.STRING: lambda s: tuple(s.strings.series),
    SeriesKind.TIMESTAMP: lambda s: tuple(
        t.seconds * NANOS_PER_SECOND + t.nanos for t in s.timestamps.series
    ),
    SeriesKind.UUID: lambda s: tuple(_uuid(u.data) for u in s.uuids.series),
    SeriesKind.STATUS: lambda s: tuple(_status(v) for v in s.statuses.series),
}
