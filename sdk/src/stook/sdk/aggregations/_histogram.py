"""A histogram of one double series that every test wrote, appended across all jobs."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Self

from stook.sdk import _data
from stook.sdk._buckets import histogram_buckets
from stook.sdk._enums import MetricStatus, SeriesKind
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, Needs
from stook.sdk.aggregations._record import JobRecord

if TYPE_CHECKING:
    import polars as pl

DEFAULT_MAX_VALUES = 2_000_000
_CONSOLIDATE_AT = 256
_BIN_BATCH = 1 << 16


def _pooled_categories(job: JobRecord, name: str) -> pl.Series | None:
    """Per-category doubles have no single series: the histogram pools every category's
    values, on purpose (one distribution across categories; `category_totals` keeps them
    apart)."""
    view = job.data.get(name)
    if view is None or not view.per_category or view.kind is not SeriesKind.DOUBLE:
        return None
    return view.frame().get_column("value").alias(name)


@dataclass
class MergedHistogram(Aggregation[JobRecord]):
    """Appends the series `data` of every job and writes it as a HISTOGRAM.

    Per-category data (doubles) contributes the values of all its categories, pooled.

    While the appended values number at most `max_values`, the histogram's values
    are exactly the appended series. Past that, memory must stay bounded, so the
    values are replaced by exact counts per bucket: the histogram then shows each
    bucket's midpoint repeated in proportion to its count, the description says
    so, and a BAR_CHART ``<name> (counts)`` carries the exact counts.
    """

    name: str
    data: str
    lower: float
    upper: float
    buckets: int = 20
    max_values: int = DEFAULT_MAX_VALUES
    x_axis_name: str | None = None

    chunks: list[pl.Series] = field(default_factory=list, init=False)
    bucket_counts: list[int] | None = field(default=None, init=False)
    total: int = field(default=0, init=False)
    outside_counted: int = field(default=0, init=False)
    # In counts mode, values wait here and are binned _BIN_BATCH at a time: binning each
    # job's few hundred values alone cost a quarter of the client's CPU per request.
    unbinned: list[pl.Series] = field(default_factory=list, init=False)
    unbinned_values: int = field(default=0, init=False)
    dropped_nan: int = field(default=0, init=False)
    jobs: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        # Raises WriterError on bad bounds now, at configuration time, not at the end.
        self._edges = histogram_buckets(self.name, self.buckets, self.lower, self.upper)
        if self.max_values < 1:
            raise ValueError(f"{self.name!r}: max_values must be at least 1")

    def needs(self) -> Needs:
        return Needs(data=frozenset({self.data}))

    @property
    def binned(self) -> bool:
        return self.bucket_counts is not None

    @property
    def counts(self) -> list[int] | None:
        """Exact values per bucket once past the cap; None while the values are kept."""
        self._flush()
        return self.bucket_counts

    @property
    def outside(self) -> int:
        """Values outside [lower, upper], counted into the edge buckets (counts mode)."""
        self._flush()
        return self.outside_counted

    def _flush(self) -> None:
        if self.unbinned:
            import polars as pl

            pending, self.unbinned, self.unbinned_values = self.unbinned, [], 0
            self._bin(pl.concat(pending, rechunk=True))

    def _bin(self, s: pl.Series) -> None:
        import numpy as np

        assert self.bucket_counts is not None  # only called once binned
        values = s.to_numpy()
        outside = (values < self.lower) | (values > self.upper)
        self.outside_counted += int(np.count_nonzero(outside))
        # Search the bucket edges rather than divide by the width: division rounds a value
        # on an inner edge into the bucket below, against the "[lower, upper)" buckets.
        # (numpy rather than polars: a polars value_counts per batch cost 4x the search.)
        lowers = np.array([lo for lo, _ in self._edges], dtype=np.float64)
        index = np.searchsorted(lowers, values, side="right") - 1
        np.clip(index, 0, self.buckets - 1, out=index)
        counts = np.bincount(index, minlength=self.buckets)
        self.bucket_counts = [
            mine + int(new) for mine, new in zip(self.bucket_counts, counts, strict=True)
        ]

    def _switch_to_counts(self) -> None:
        self.bucket_counts = [0] * self.buckets
        chunks, self.chunks = self.chunks, []
        for chunk in chunks:
            self._bin(chunk)

    def _add(self, s: pl.Series) -> None:
        self.total += s.len()
        if self.bucket_counts is not None:
            self.unbinned.append(s)
            self.unbinned_values += s.len()
            if self.unbinned_values >= _BIN_BATCH:
                self._flush()
            return
        self.chunks.append(s)
        if len(self.chunks) >= _CONSOLIDATE_AT:
            import polars as pl

            # Thousands of small Series cost far more than their values; one big one does not.
            self.chunks = [pl.concat(self.chunks, rechunk=True)]
        if self.total > self.max_values:
            self._switch_to_counts()

    def update(self, job: JobRecord) -> None:
        s = job.series.get(self.data)
        if s is None:
            s = _pooled_categories(job, self.data)
        if s is None:
            return
        self.jobs += 1
        import polars as pl

        if s.dtype != pl.Float64:
            s = s.cast(pl.Float64)
        # A sum is NaN only when a value is (or +inf meets -inf). It is one native pass,
        # where `is_nan()` runs a polars query: ~70 µs per job-sized series, measured.
        if math.isnan(s.sum()):
            nans = int(s.is_nan().sum())
            if nans:
                self.dropped_nan += nans
                s = s.drop_nans()
        self._add(s)

    def merge(self, other: Self) -> None:
        self.jobs += other.jobs
        self.dropped_nan += other.dropped_nan
        theirs = other.counts  # flushes their unbinned values
        self.outside_counted += other.outside_counted
        if theirs is not None:
            if self.bucket_counts is None:
                self._switch_to_counts()
            mine = self.counts
            assert mine is not None
            self.bucket_counts = [a + b for a, b in zip(mine, theirs, strict=True)]
            self.total += other.total
            return
        for chunk in other.chunks:
            self._add(chunk)

    def values(self) -> pl.Series:
        """The appended series (exact mode only), sorted: jobs arrive in any order, and a
        histogram does not depend on the order of its values, so sorted output is stable."""
        import polars as pl

        if not self.chunks:
            return pl.Series(self.data, [], dtype=pl.Float64)
        values = pl.concat(self.chunks, rechunk=True)
        # -0.0 becomes 0.0: they compare equal, so sorting alone keeps their arrival order.
        # (polars folds `x + 0.0` to x, so the usual arithmetic trick does not work here.)
        return values.zip_with(values != 0.0, pl.Series([0.0] * values.len())).sort()

    def finish(self, writer: MetricsWriter) -> None:
        if self.total == 0:
            writer.text(
                self.name,
                f"No job wrote values for {self.data!r}; nothing to draw.",
                status=MetricStatus.NOT_APPLICABLE,
            )
            return
        about = f"{self.total} values of {self.data!r} from {self.jobs} jobs"
        if self.dropped_nan:
            about += f" ({self.dropped_nan} NaN values dropped)"
        counts = self.counts
        if counts is None:
            values = _data.doubles(f"{self.name} values", self.values())
            writer.histogram(
                self.name,
                values,
                buckets=self._edges,
                x_axis_name=self.x_axis_name,
                description=f"Histogram of {about}.",
            )
            return
        per_value = math.ceil(self.total / self.max_values)
        midpoints: list[float] = []
        for (lo, hi), count in zip(self._edges, counts, strict=True):
            midpoints.extend([(lo + hi) / 2] * round(count / per_value))
        shown = _data.doubles(f"{self.name} values", midpoints or [self._edges[0][0]])
        outside = (
            f"; {self.outside} values outside [{self.lower}, {self.upper}] counted in the "
            "edge buckets"
            if self.outside
            else ""
        )
        writer.histogram(
            self.name,
            shown,
            buckets=self._edges,
            x_axis_name=self.x_axis_name,
            description=(
                f"Pre-binned: {about} exceed the cap of {self.max_values} values, so each "
                f"value shown stands for {per_value} values at its bucket's midpoint; exact "
                f"counts are in {self.name + ' (counts)'!r}{outside}."
            ),
        )
        writer.bar_chart_from(
            f"{self.name} (counts)",
            {
                f"[{lo:g}, {hi:g})": float(c)
                for (lo, hi), c in zip(self._edges, counts, strict=True)
            },
            description=f"Exact bucket counts of {about}.",
        )
