"""Metrics data: named, typed series that metrics reference, or that stand alone.

A `MetricsData` is built once, independent of any writer, and is written into an
output either because a metric references it (transitively, with its index) or
because it was added alone with `MetricsWriter.add_data` for later batch use.
"""

from __future__ import annotations

import math
import numbers
import uuid
from array import array
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import TYPE_CHECKING, TypeAlias, TypeGuard

from stook.sdk._enums import MetricStatus, SeriesKind
from stook.sdk._errors import WriterError

if TYPE_CHECKING:
    import polars as pl

# Timestamps are kept as integer nanoseconds since the Unix epoch (UTC). They are given as
# aware datetimes, integer nanoseconds, or float seconds (what robotics logs hold).
TimestampLike = datetime | int | float
UuidLike = uuid.UUID | str

# Doubles are kept packed (8 bytes each), not as a list of Python floats (32 bytes each).
_Elements: TypeAlias = "array[float] | list[int] | list[str] | list[MetricStatus]"


@dataclass(frozen=True, eq=False, slots=True)
class MetricsData:
    """One metrics-data item. Build it with the module functions (`doubles`, ...).

    Identity matters, not equality: two items with equal values are still two items.
    """

    name: str
    kind: SeriesKind
    # A plain series (list) or, when per category, a mapping category -> list.
    values: _Elements | dict[str, _Elements] | None
    unit: str = ""
    index: MetricsData | None = None
    external_path: str | None = None
    id: uuid.UUID = field(default_factory=uuid.uuid4)

    @property
    def per_category(self) -> bool:
        return isinstance(self.values, dict)

    @property
    def indexed(self) -> bool:
        return self.index is not None

    @property
    def categories(self) -> list[str]:
        return list(self.values) if isinstance(self.values, dict) else []

    def shape(self) -> int | dict[str, int]:
        """The series length, or the length of each category's series."""
        if isinstance(self.values, dict):
            return {k: len(v) for k, v in self.values.items()}
        return len(self.values) if self.values is not None else 0

    def dependencies(self) -> list[MetricsData]:
        """This item and the index chain below it, index first."""
        chain: list[MetricsData] = []
        node: MetricsData | None = self
        while node is not None:
            chain.append(node)
            node = node.index
        return chain[::-1]


def _check_name(name: str) -> None:
    if not name:
        raise WriterError("metrics data needs a non-empty name")


def _check_index(name: str, shape: int | dict[str, int], index: MetricsData | None) -> None:
    if index is None:
        return
    if index.kind is SeriesKind.EXTERNAL_FILE:
        raise WriterError(f"metrics data {name!r}: an external file cannot be an index")
    if index.shape() != shape:
        raise WriterError(
            f"metrics data {name!r}: its shape {shape} differs from its index "
            f"{index.name!r} shape {index.shape()}"
        )


_CHUNK = 1 << 16


def _is_polars_series(values: object) -> TypeGuard[pl.Series]:
    # Told by the class's module, so that the writer never imports polars for values that
    # are not polars' (`stook show` and the service's start-up go without it), and never
    # looks into a polars that another thread is still importing.
    if not any(c.__module__.startswith("polars.") for c in type(values).__mro__):
        return False
    import polars as pl

    return isinstance(values, pl.Series)


def _as_doubles(name: str, values: Iterable[float] | pl.Series) -> array[float]:
    if _is_polars_series(values):
        import polars as pl

        if not values.dtype.is_numeric():
            raise WriterError(f"metrics data {name!r}: a {values.dtype} series is not numbers")
        packed: array[float] = array("d")
        # In slices, so that the transient Python floats stay few whatever the length.
        doubles = values.cast(pl.Float64).fill_null(float("nan"))
        for offset in range(0, doubles.len(), _CHUNK):
            packed.extend(doubles.slice(offset, _CHUNK).to_list())
        return packed
    try:
        # array() converts and checks in C; a per-element float() loop is ~10x slower.
        return array("d", values)
    except (TypeError, ValueError) as exc:
        raise WriterError(f"metrics data {name!r}: values must be numbers ({exc})") from None


def timestamp_ns(value: TimestampLike) -> int:
    """Nanoseconds since the epoch for an aware datetime, an integer already in ns, or a
    float in seconds (``12.5`` is 12.5 s after the epoch: a log's relative time reads as
    such), rounded to the nearest nanosecond."""
    if isinstance(value, datetime):
        if value.tzinfo is None:
            raise WriterError(f"timestamp {value.isoformat()} has no time zone; use an aware one")
        delta = value - datetime(1970, 1, 1, tzinfo=UTC)
        return (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1_000
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    if isinstance(value, float):  # numpy's float64 too: it is a float
        if not math.isfinite(value):
            raise WriterError(f"timestamp {value!r} is not a finite number of seconds")
        # Whole and fractional seconds apart: value * 1e9 would round away the
        # nanoseconds of a present-day epoch time (1.7e18 needs more than 53 bits).
        whole = math.floor(value)
        return whole * 1_000_000_000 + round((value - whole) * 1_000_000_000)
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return int(value)  # numpy's integers: nanoseconds, as ints are
    raise WriterError(
        f"timestamp {value!r} must be an aware datetime, integer nanoseconds or float seconds"
    )


def _as_uuid(value: UuidLike) -> str:
    try:
        return str(value if isinstance(value, uuid.UUID) else uuid.UUID(value))
    except (ValueError, AttributeError, TypeError):
        raise WriterError(f"{value!r} is not a UUID") from None


def _convert(name: str, kind: SeriesKind, values: Iterable[object]) -> _Elements:
    match kind:
        case SeriesKind.DOUBLE:
            return _as_doubles(name, values)  # type: ignore[arg-type]
        case SeriesKind.TIMESTAMP:
            return [timestamp_ns(v) for v in values]  # type: ignore[arg-type]
        case SeriesKind.UUID:
            return [_as_uuid(v) for v in values]  # type: ignore[arg-type]
        case SeriesKind.STRING:
            out = [str(v) for v in values]
            return out
        case SeriesKind.STATUS:
            try:
                return [MetricStatus(v) for v in values]  # type: ignore[arg-type]
            except (ValueError, TypeError):
                raise WriterError(
                    f"metrics data {name!r}: statuses must be MetricStatus values"
                ) from None
        case SeriesKind.EXTERNAL_FILE:
            raise WriterError(f"metrics data {name!r}: an external file has no series")


def _series(
    name: str,
    kind: SeriesKind,
    values: Iterable[object],
    unit: str,
    index: MetricsData | None,
    id: uuid.UUID | None,
) -> MetricsData:
    _check_name(name)
    converted = _convert(name, kind, values)
    _check_index(name, len(converted), index)
    return MetricsData(name, kind, converted, unit, index, None, id or uuid.uuid4())


def _per_category(
    name: str,
    kind: SeriesKind,
    values: Mapping[str, Iterable[object]],
    unit: str,
    index: MetricsData | None,
    id: uuid.UUID | None,
) -> MetricsData:
    _check_name(name)
    if not values:
        raise WriterError(f"metrics data {name!r}: a per-category series needs a category")
    converted = {str(k): _convert(name, kind, v) for k, v in values.items()}
    _check_index(name, {k: len(v) for k, v in converted.items()}, index)
    return MetricsData(name, kind, converted, unit, index, None, id or uuid.uuid4())


# ---- public constructors: one per data kind ----


def doubles(
    name: str,
    values: Iterable[float] | pl.Series,
    *,
    unit: str = "",
    index: MetricsData | None = None,
    id: uuid.UUID | None = None,
) -> MetricsData:
    """A series of doubles, optionally indexed by another series of the same length."""
    return _series(name, SeriesKind.DOUBLE, values, unit, index, id)


def timestamps(
    name: str,
    values: Iterable[TimestampLike],
    *,
    unit: str = "",
    index: MetricsData | None = None,
    id: uuid.UUID | None = None,
) -> MetricsData:
    """A series of timestamps since the Unix epoch: aware datetimes, integer nanoseconds,
    or float seconds (``[0.0, 0.1, 0.2]``: a log's time; ints are always nanoseconds)."""
    return _series(name, SeriesKind.TIMESTAMP, values, unit, index, id)


def uuids(
    name: str,
    values: Iterable[UuidLike],
    *,
    unit: str = "",
    index: MetricsData | None = None,
    id: uuid.UUID | None = None,
) -> MetricsData:
    """A series of UUIDs."""
    return _series(name, SeriesKind.UUID, values, unit, index, id)


def strings(
    name: str,
    values: Iterable[str],
    *,
    unit: str = "",
    index: MetricsData | None = None,
    id: uuid.UUID | None = None,
) -> MetricsData:
    """A series of strings."""
    return _series(name, SeriesKind.STRING, values, unit, index, id)


def statuses(
    name: str,
    values: Iterable[MetricStatus],
    *,
    unit: str = "",
    index: MetricsData | None = None,
    id: uuid.UUID | None = None,
) -> MetricsData:
    """A series of metric statuses."""
    return _series(name, SeriesKind.STATUS, values, unit, index, id)


def per_category(
    name: str,
    kind: SeriesKind,
    values: Mapping[str, Iterable[object]],
    *,
    unit: str = "",
    index: MetricsData | None = None,
    id: uuid.UUID | None = None,
) -> MetricsData:
    """A series per category (e.g. one per object class), all of one kind."""
    return _per_category(name, kind, values, unit, index, id)


def external_file(name: str, path: str, *, id: uuid.UUID | None = None) -> MetricsData:
    """A file written next to metrics.binproto (an image, a video), referenced by path."""
    _check_name(name)
    if not path:
        raise WriterError(f"metrics data {name!r}: an external file needs a path")
    return MetricsData(name, SeriesKind.EXTERNAL_FILE, None, "", None, path, id or uuid.uuid4())


def status_like(data: MetricsData, status: MetricStatus, *, name: str | None = None) -> MetricsData:
    """A status series shaped and indexed like `data`, every element `status`.

    The platform wants a status series beside most value series; this builds the
    obvious one when a metric is given none.
    """
    status = MetricStatus(status)
    values: _Elements | dict[str, _Elements]
    if isinstance(data.values, dict):
        values = {k: [status] * len(v) for k, v in data.values.items()}
    else:
        values = [status] * (len(data.values) if data.values is not None else 0)
    return MetricsData(name or f"{data.name} (statuses)", SeriesKind.STATUS, values, "", data.index)


def sequence_of(items: MetricsData | Sequence[MetricsData]) -> list[MetricsData]:
    return [items] if isinstance(items, MetricsData) else list(items)
