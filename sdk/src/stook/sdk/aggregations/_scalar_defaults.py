"""For every SCALAR job metric: its mean and its distribution across the batch's jobs."""

from __future__ import annotations

import math
import operator
import struct
from array import array
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Self

from stook.sdk import _data
from stook.sdk._errors import WriterError
from stook.sdk._writer import histogram_buckets
from stook.sdk.aggregations._base import (
    Aggregation,
    JobRecord,
    Needs,
    Scalar,
    exact_mean,
    pick_unit,
)
from stook.sdk.aggregations._columns import values_by_name

if TYPE_CHECKING:
    from stook.sdk._writer import MetricsWriter


def auto_buckets(low: float, high: float, count: int) -> tuple[float, float, int]:
    """Bounds and a bucket count that cover [low, high]: about sqrt(count) buckets, 1..20,
    fewer where the range is too narrow (or too wide) for distinct floating-point edges."""
    if low == high:
        half = max(abs(low) * 0.05, 0.5)
        lo, hi = low - half, high + half
        if not (math.isfinite(lo) and math.isfinite(hi)):
            lo, hi = math.nextafter(low, -math.inf), math.nextafter(high, math.inf)
        return lo, hi, 1
    buckets = max(1, min(20, math.ceil(math.sqrt(count))))
    while buckets > 1:
        try:
            histogram_buckets("auto", buckets, low, high)
            break
        except WriterError:
            buckets //= 2
    return low, high, buckets


_BATCH = 256
_VALUE = operator.attrgetter("value")
_UNIT = operator.attrgetter("unit")


@dataclass
class _Column:
    values: array[float] = field(default_factory=lambda: array("d"))
    units: Counter[str] = field(default_factory=Counter)


def _count_units(counts: Counter[str], units: list[str]) -> None:
    """`counts.update(units)`. A metric's scalars nearly always share one unit: then
    counted by one comparison each (a Counter hashes and looks up each, ~5x the cost)."""
    if units and units.count(units[0]) == len(units):
        counts[units[0]] += len(units)
    else:
        counts.update(units)


def _sorted_finite(values: array[float]) -> list[float]:
    """The finite values, sorted, and -0.0 made 0.0 (they compare equal, so sorting keeps
    arrival order): the output must not depend on the order jobs arrived in."""
    # The common case in C loops: a sum is finite only when every value is, and with no
    # zero there is no -0.0 to make 0.0 (-0.0 == 0.0, so `in` finds either).
    if math.isfinite(sum(values)) and 0.0 not in values:
        return sorted(values)
    return sorted(v + 0.0 for v in values if math.isfinite(v))


@dataclass
class ScalarDefaults(Aggregation[JobRecord]):
    """Writes ``N (mean)`` (a SCALAR, unit carried over) and ``N (distribution)`` (a
    HISTOGRAM of the per-job values) for every SCALAR job metric ``N`` in the batch."""

    name: str = "(mean) and (distribution) of every scalar"
    columns: dict[str, _Column] = field(default_factory=dict, init=False)
    # Jobs' scalars wait here and join `columns` _BATCH jobs at a time, a metric at a
    # time, in C loops (map, filter): a Python loop over every job's scalars cost ~5x.
    waiting: list[Mapping[str, Scalar]] = field(default_factory=list, init=False)

    def needs(self) -> Needs:
        return Needs(every_scalar=True)

    def update(self, job: JobRecord) -> None:
        self.waiting.append(job.scalars)
        if len(self.waiting) >= _BATCH:
            self._add_waiting()

    def _add_waiting(self) -> None:
        """Add the waiting jobs' scalars to `columns`, in the order the jobs came."""
        waiting, self.waiting = self.waiting, []
        metrics = list(set().union(*waiting))
        for metric, column in zip(metrics, values_by_name(waiting, metrics), strict=True):
            # The jobs without `metric` left out (a Scalar is never false).
            found = list(filter(None, column))
            mine = self.columns.get(metric)
            if mine is None:
                mine = self.columns[metric] = _Column()
            # Packed by struct, then copied in: array.extend converts each value through
            # a format parser (~4x the cost a value).
            mine.values.frombytes(struct.pack(f"={len(found)}d", *map(_VALUE, found)))
            _count_units(mine.units, list(map(_UNIT, found)))

    def __getstate__(self) -> dict[str, object]:
        """What travels between processes (see `Aggregation`): the columns, the waiting
        jobs added to them first."""
        self._add_waiting()
        return dict(self.__dict__)

    def merge(self, other: Self) -> None:
        self._add_waiting()
        other._add_waiting()
        for metric, theirs in other.columns.items():
            mine = self.columns.setdefault(metric, _Column())
            mine.values.extend(theirs.values)
            mine.units.update(theirs.units)

    def finish(self, writer: MetricsWriter) -> None:

        self._add_waiting()
        for metric in sorted(self.columns):
            column = self.columns[metric]
            values = column.values
            finite = _sorted_finite(values)
            unit = pick_unit(column.units)
            if not finite:
                continue
            writer.scalar(
                f"{metric} (mean)",
                exact_mean(finite),
                unit=unit,
                description=f"Mean of {metric!r} over the {len(finite)} jobs that reported it.",
            )
            low, high, buckets = auto_buckets(min(finite), max(finite), len(finite))
            writer.histogram(
                f"{metric} (distribution)",
                _data.doubles(f"{metric} (distribution) values", finite, unit=unit),
                buckets=buckets,
                lower=low,
                upper=high,
                x_axis_name=f"{metric} [{unit}]" if unit else metric,
                description=f"{metric!r} of each of the {len(finite)} jobs that reported it.",
            )
