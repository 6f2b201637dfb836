"""Series values as plain Python lists, read from the views' messages, and thinning for drawing.

Plain lists, not polars frames: a preview turns every series into JSON anyway, and
reading repeated protobuf fields directly keeps `stook preview` free of polars and numpy.
Values that JSON cannot hold (NaN, infinities) become None, which plotly draws as a gap.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Sequence
from datetime import datetime, timedelta
from typing import Any, overload

from stook.proto import metrics_pb2 as pb
from stook.sdk import JobMetricsView, MetricsDataView, MetricStatus, SeriesKind

MAX_DRAWN = 1000
"""Points drawn per trace, about: longer series are thinned (min and max per bucket).
A chart is a few hundred pixels wide, so more points draw no more detail, only slower."""

# Naive, read as UTC: isoformat then carries no offset, which plotly's dates do not take.
_EPOCH = datetime(1970, 1, 1)
_STATUS_NAMES: dict[int, str] = {int(s): s.name for s in MetricStatus}


def status_name(value: int) -> str:
    name = _STATUS_NAMES.get(value)
    if name is not None:
        return name
    return "NO_STATUS" if value == 0 else f"UNKNOWN_{value}"


def timestamp_text(seconds: int, nanos: int) -> str:
    """Plotly's date format, to the microsecond, in UTC."""
    moment = _EPOCH + timedelta(seconds=seconds, microseconds=nanos // 1000)
    return moment.isoformat(sep=" ", timespec="microseconds")


class Converted(Sequence[Any]):
    """A series' elements, each converted when read: a long series is thinned before its
    timestamps and statuses are turned into text, so only the drawn ones pay for it."""

    __slots__ = ("_convert", "_items")

    def __init__(self, items: Sequence[Any], convert: Callable[[Any], Any]) -> None:
        self._items = items
        self._convert = convert

    def __len__(self) -> int:
        return len(self._items)

    @overload
    def __getitem__(self, i: int) -> Any: ...
    @overload
    def __getitem__(self, i: slice) -> list[Any]: ...
    def __getitem__(self, i: int | slice) -> Any:
        if isinstance(i, slice):
            return [self._convert(item) for item in self._items[i]]
        return self._convert(self._items[i])


def tally(items: Sequence[Any]) -> Counter[Any]:
    """How often each value occurs. A converted series of hashable elements (statuses:
    enum numbers) is counted as written, and only its distinct elements converted: a
    20,000-point series' statuses cost one C loop, not 20,000 conversions."""
    if not isinstance(items, Converted):
        return Counter(items)
    counts: Counter[Any] = Counter()
    for item, n in Counter(items._items).items():
        counts[items._convert(item)] += n
    return counts


def _timestamp(t: Any) -> str:
    return timestamp_text(t.seconds, t.nanos)


def _elements(series: pb.Series, kind: SeriesKind) -> Sequence[Any]:
    if kind is SeriesKind.DOUBLE:
        return [v if math.isfinite(v) else None for v in series.doubles.series]
    if kind is SeriesKind.TIMESTAMP:
        return Converted(series.timestamps.series, _timestamp)
    if kind is SeriesKind.UUID:
        return [u.data for u in series.uuids.series]
    if kind is SeriesKind.STRING:
        return list(series.strings.series)
    if kind is SeriesKind.STATUS:
        return Converted(series.statuses.series, status_name)
    return []


def values(data: MetricsDataView) -> Sequence[Any]:
    """The plain series (or, per category, every category's in order), drawable; `list`
    it before it goes into JSON."""
    if data.kind is None or data.is_external:
        return []
    if not data.per_category:
        return _elements(data.raw.series, data.kind)
    merged: list[Any] = []
    for series in categories(data).values():
        merged.extend(series)
    return merged


def categories(data: MetricsDataView) -> dict[str, Sequence[Any]]:
    """Per-category values: declared categories first, in order, then undeclared, sorted."""
    if data.kind is None or data.is_external or not data.per_category:
        return {}
    by_category = data.raw.series_per_category.category_to_series
    order = [*data.categories, *sorted(set(by_category) - set(data.categories))]
    return {c: _elements(by_category[c], data.kind) for c in order if c in by_category}


def exact_doubles(data: MetricsDataView) -> list[float]:
    """Doubles as written (NaN and infinities kept), for tables and counts."""
    if data.kind is not SeriesKind.DOUBLE:
        return []
    if data.per_category:
        by_category = data.raw.series_per_category.category_to_series
        return [v for s in by_category.values() for v in s.doubles.series]
    return list(data.raw.series.doubles.series)


def index_of(view: JobMetricsView, data: MetricsDataView) -> Sequence[Any] | None:
    """The values of the data's index series, or None without a (readable) index."""
    if data.index_id is None:
        return None
    index = view.data_by_id.get(data.index_id)
    return values(index) if index is not None else None


RELATIVE_BEFORE_S = 365 * 86_400
"""Timestamps before 1971 are time since a run's start (simulated time counted from 0),
drawn as seconds: as dates they would all read "Jan 1, 1970"."""


def is_relative(seconds: int) -> bool:
    return seconds < RELATIVE_BEFORE_S


def time_index(view: JobMetricsView, data: MetricsDataView) -> tuple[Sequence[Any] | None, bool]:
    """The data's index for a time axis, and whether it is relative: seconds from the
    start (floats) when every timestamp is before 1971, else UTC dates as plotly reads
    them. Another kind of index is returned as it is."""
    if data.index_id is None:
        return None, False
    index = view.data_by_id.get(data.index_id)
    if index is None:
        return None, False
    if index.kind is SeriesKind.TIMESTAMP and not index.per_category:
        stamps = index.raw.series.timestamps.series
        if stamps and all(is_relative(t.seconds) for t in stamps):
            return Converted(stamps, _seconds), True
    return values(index), False


def _seconds(t: Any) -> float:
    return float(t.seconds + t.nanos / 1e9)


def thin(ys: Sequence[Any], limit: int = MAX_DRAWN) -> Sequence[int]:
    """Positions to draw: all of them up to `limit`, else the min and max of each of
    limit/2 buckets (so peaks stay visible) plus the first gap in a bucket (so gaps stay
    gaps). Non-numeric series are sampled evenly."""
    n = len(ys)
    if n <= limit:
        return range(n)
    buckets = max(limit // 2, 1)
    numeric = any(isinstance(y, float) for y in ys[: min(n, 64)])
    kept: list[int] = []
    for b in range(buckets):
        lo, hi = (b * n) // buckets, ((b + 1) * n) // buckets
        if not numeric:
            kept.append(lo)
            continue
        low = high = gap = None
        for i in range(lo, hi):
            y = ys[i]
            if y is None:
                if gap is None:
                    gap = i
                continue
            if low is None or y < ys[low]:
                low = i
            if high is None or y > ys[high]:
                high = i
        kept.extend(sorted({i for i in (low, high, gap) if i is not None}))
    return kept


def pick(items: Sequence[Any] | None, positions: Sequence[int]) -> list[Any] | None:
    if items is None:
        return None
    if isinstance(positions, range) and len(positions) == len(items):
        return list(items)
    n = len(items)
    return [items[i] for i in positions if i < n]


def exact_text(value: float | None) -> str:
    """The shortest text that reads back as the same double: the value as written, for
    the hover text and the page's data attributes."""
    if value is None:
        return "—"
    if math.isnan(value):
        return "NaN"
    if math.isinf(value):
        return "∞" if value > 0 else "-∞"
    return repr(value)


def number_text(value: float | None) -> str:
    """A value as people read it: six significant digits with thousands separators
    ("24.0901", "0.173469", "1,234.57"), whole numbers from a million up ("1,234,567"),
    and an exponent only for the very small or very large ("1.5e-07"). A page shows
    this; the exact value (`exact_text`) goes beside it, on hover."""
    if value is None or not math.isfinite(value):
        return exact_text(value)
    if value == 0:
        return "0"  # -0.0 too: its sign is in the exact text
    magnitude = abs(value)
    if not 1e-4 <= magnitude < 1e15:
        return f"{value:.6g}"
    # 999,999.5 and up has more than six digits before the point: a "g" format would
    # switch to an exponent there, and rounding to the unit reads better.
    if magnitude >= 999_999.5:
        return f"{value:,.0f}"
    return f"{value:,.6g}"
