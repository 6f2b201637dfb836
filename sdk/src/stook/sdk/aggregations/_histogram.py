"""A histogram of one double series that every test wrote, or of the values of one HISTOGRAM
metric that every test wrote (on the buckets the tests used), appended across all jobs."""

from __future__ import annotations

import math
import uuid
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus, SeriesKind
from stook.sdk._errors import JobDataError
from stook.sdk._writer import Bucket, MetricsWriter, histogram_buckets
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs
from stook.sdk.aggregations._job_metrics import histogram_of

if TYPE_CHECKING:
    import numpy as np
    import polars as pl

    Doubles = np.ndarray[Any, np.dtype[np.float64]]

DEFAULT_MAX_VALUES = 2_000_000
DEFAULT_BUCKETS = 20
_CONSOLIDATE_AT = 256
_BIN_BATCH = 1 << 16
# Up to this many buckets, values are binned by a comparison pass per edge, past it by a
# binary search of the edges per value. Measured on 65,536 values: 0.15 ms against 3.1 at
# 10 buckets, 4.2 against 6.5 ms at 160; the search grows with the log of the buckets.
_COMPARE_UP_TO = 128


def _doubles_of(job: JobRecord, name: str) -> Doubles | None:
    """The job's values of double data `name` as float64 (None without such data).

    From the job's view of the data when it has one (`JobRecord.data`, which a fetch
    fills): the doubles straight from the message, without a polars Series. Otherwise
    from `JobRecord.series` (a hand-made record's). Per-category doubles contribute
    every category's values, pooled on purpose: one distribution across categories
    (`category_totals` keeps them apart).
    """
    view = job.data.get(name)
    if view is not None and view.kind is SeriesKind.DOUBLE:
        if view.per_category:
            return _float64(view.frame().get_column("value"))
        from stook.sdk._series import doubles_array

        return doubles_array(view.raw.series.doubles)
    series = job.series.get(name)
    return None if series is None else _float64(series)


def _float64(series: pl.Series) -> Doubles:
    """A Series' values as a float64 array; nulls (only a hand-made record's series has
    them) read as zeros, as they always have."""
    import polars as pl

    if series.dtype != pl.Float64:
        series = series.cast(pl.Float64)
    return series.fill_null(0.0).to_numpy()


@dataclass
class MergedHistogram(Aggregation[JobRecord]):
    """Appends the series `data` of every job and writes it as a HISTOGRAM.

    With `metric` instead of `data` (exactly one of them), it appends the values of the
    jobs' own HISTOGRAM metric of that name and writes them on the buckets the jobs used,
    which every job must share (JobDataError naming two jobs otherwise); `lower`, `upper`
    and `buckets` then come from the jobs and cannot be given. Per-category `data`
    (doubles) contributes the values of all its categories, pooled.

    While the appended values number at most `max_values`, the histogram's values
    are exactly the appended series. Past that, memory must stay bounded, so the
    values are replaced by exact counts per bucket: the histogram then shows each
    bucket's midpoint repeated in proportion to its count, the description says
    so, and a BAR_CHART ``<name> (counts)`` carries the exact counts.
    """

    name: str
    data: str | None = None
    lower: float | None = None
    upper: float | None = None
    buckets: int | None = None
    max_values: int = DEFAULT_MAX_VALUES
    x_axis_name: str | None = None
    metric: str | None = None

    # The appended values, float64 with their NaNs dropped: an array per job, or per run
    # of jobs once joined. While the values are kept, they are joined into one array
    # _CONSOLIDATE_AT arrays at a time (thousands of small arrays cost more than their
    # values). Once past the cap, they wait here to be binned into `bucket_counts`
    # _BIN_BATCH values at a time (`waiting`): binning each job's few hundred values
    # alone cost a quarter of the client's CPU per request.
    arrays: list[Doubles] = field(default_factory=list, init=False)
    waiting: int = field(default=0, init=False)
    bucket_counts: list[int] | None = field(default=None, init=False)
    total: int = field(default=0, init=False)
    outside_counted: int = field(default=0, init=False)
    dropped_nan: int = field(default=0, init=False)
    jobs: int = field(default=0, init=False)
    # Metric mode: the buckets the jobs used, learnt from the first job that had the metric
    # (`edges_job`), and the x-axis names they gave.
    edges: list[Bucket] | None = field(default=None, init=False)
    edges_job: uuid.UUID | None = field(default=None, init=False)
    axis_names: set[str] = field(default_factory=set, init=False)

    def __post_init__(self) -> None:
        if (self.data is None) == (self.metric is None):
            raise ValueError("give exactly one of 'data' (a double series) or 'metric'")
        if self.max_values < 1:
            raise ValueError(f"{self.name!r}: max_values must be at least 1")
        if self.metric is not None:
            given = [k for k in ("lower", "upper", "buckets") if getattr(self, k) is not None]
            if given:
                raise ValueError(
                    f"{given[0]!r} cannot be given with 'metric': the buckets are the ones "
                    f"the jobs' histogram {self.metric!r} used"
                )
            return
        missing = [k for k in ("lower", "upper") if getattr(self, k) is None]
        if missing:
            raise ValueError(
                f"missing key{'s' if len(missing) > 1 else ''} "
                + ", ".join(repr(k) for k in missing)
                + " (the histogram's bounds, needed with 'data')"
            )
        # Raises WriterError on bad bounds now, at configuration time, not at the end.
        if self.buckets is None:
            self.buckets = DEFAULT_BUCKETS
        self.edges = histogram_buckets(self.name, self.buckets, self.lower, self.upper)

    @property
    def source(self) -> str:
        """What is appended, for messages: the data or the histogram metric."""
        return repr(self.data) if self.data is not None else f"histogram metric {self.metric!r}"

    def needs(self) -> Needs:
        if self.metric is not None:
            return Needs(metrics=frozenset({self.metric}))
        assert self.data is not None
        return Needs(data=frozenset({self.data}))

    def _edges(self) -> list[Bucket]:
        assert self.edges is not None  # known before any value is added
        return self.edges

    def _adopt_edges(self, edges: list[Bucket], job: uuid.UUID | None) -> None:
        """Metric mode: the first buckets seen are the histogram's; others are an error."""
        if self.edges is None:
            self.edges, self.edges_job = edges, job
        elif edges != self.edges:
            raise JobDataError(
                f"{self.name!r}: jobs {self.edges_job} and {job} wrote histogram "
                f"{self.metric!r} with different buckets ({_difference(self.edges, edges)}); "
                "values binned differently cannot be merged"
            )

    @property
    def binned(self) -> bool:
        return self.bucket_counts is not None

    @property
    def counts(self) -> list[int] | None:
        """Exact values per bucket once past the cap; None while the values are kept."""
        self._bin_waiting()
        return self.bucket_counts

    @property
    def outside(self) -> int:
        """Values outside [lower, upper], counted into the edge buckets (counts mode)."""
        self._bin_waiting()
        return self.outside_counted

    def update(self, job: JobRecord) -> None:
        if self.metric is not None:
            found = histogram_of(job, self.metric)
            if found is None:
                return
            self._adopt_edges(list(found.buckets), job.job_id)
            if found.x_axis_name:
                self.axis_names.add(found.x_axis_name)
            values = _float64(found.values)
        else:
            assert self.data is not None
            got = _doubles_of(job, self.data)
            if got is None:
                return
            values = got
        self.jobs += 1
        # The minimum is NaN exactly when a value is (numpy's propagates NaN): one pass.
        # Not a dot product: BLAS runs one of many thousands of values in threads, whose
        # spinning cost more CPU than the whole fold.
        if len(values) and math.isnan(values.min()):
            import numpy as np

            nan = np.isnan(values)
            self.dropped_nan += int(np.count_nonzero(nan))
            values = values[~nan]
        self._append(values)

    def merge(self, other: Self) -> None:
        if self.metric is not None and other.edges is not None:
            self._adopt_edges(other.edges, other.edges_job)
            self.axis_names |= other.axis_names
        self.jobs += other.jobs
        self.dropped_nan += other.dropped_nan
        theirs = other.counts  # bins their waiting values
        self.outside_counted += other.outside_counted
        if theirs is not None:
            if self.bucket_counts is None:
                self._switch_to_counts()
            mine = self.counts
            assert mine is not None
            self.bucket_counts = [a + b for a, b in zip(mine, theirs, strict=True)]
            self.total += other.total
            return
        for values in other.arrays:
            self._append(values)

    def __getstate__(self) -> dict[str, object]:
        """What travels between processes (see `Aggregation`): waiting values binned first,
        so a histogram in counts mode is its bucket counts (a few hundred bytes, whatever
        the number of values), and kept values as one array (8 bytes a value) rather than
        an array per job, each with its own framing."""
        if self.bucket_counts is not None:
            self._bin_waiting()
        elif len(self.arrays) > 1:
            self._join()
        return dict(self.__dict__)

    def values(self) -> pl.Series:
        """The appended values (exact mode only), sorted: jobs arrive in any order, and a
        histogram does not depend on the order of its values, so sorted output is stable."""
        import polars as pl

        name = self.data or self.metric
        if not self.arrays:
            return pl.Series(name, [], dtype=pl.Float64)
        # -0.0 becomes 0.0 (-0.0 + 0.0 is 0.0; they compare equal, so sorting alone would
        # keep their arrival order), and the sum is a copy to sort in place. Sorted in
        # numpy: a fifth of polars' zip_with and sort (0.2 against 1.1 ms for 30,000
        # values), and the same bits, as no two other equal doubles differ in bits.
        array = self._join() + 0.0
        array.sort()
        return pl.Series(name, array)

    def _append(self, values: Doubles) -> None:
        """Append values without NaNs: kept, or waiting to be binned past the cap."""
        self.total += len(values)
        self.arrays.append(values)
        if self.bucket_counts is not None:
            self.waiting += len(values)
            if self.waiting >= _BIN_BATCH:
                self._bin_waiting()
        elif self.total > self.max_values:
            self._switch_to_counts()
        elif len(self.arrays) >= _CONSOLIDATE_AT:
            self._join()

    def _join(self) -> Doubles:
        """The kept values as one array, which then is `arrays`' only one."""
        import numpy as np

        if len(self.arrays) != 1:
            self.arrays = [np.concatenate(self.arrays)]
        return self.arrays[0]

    def _switch_to_counts(self) -> None:
        self.bucket_counts = [0] * len(self._edges())
        self.waiting = sum(len(a) for a in self.arrays)
        self._bin_waiting()

    def _bin_waiting(self) -> None:
        """Bin the values waiting in `arrays` (counts mode; nothing otherwise)."""
        if self.bucket_counts is None or not self.arrays:
            return
        import numpy as np

        values = np.concatenate(self.arrays)
        self.arrays, self.waiting = [], 0
        edges = self._edges()
        # Two counts rather than one of an or: lower < upper, so no value is in both.
        below = int(np.count_nonzero(values < edges[0][0]))
        self.outside_counted += below + int(np.count_nonzero(values > edges[-1][1]))
        # Compare with the bucket edges rather than divide by the width: division rounds a
        # value on an inner edge into the bucket below, against the "[lower, upper)" buckets.
        # (numpy rather than polars: a polars value_counts per batch cost 4x the search.)
        if len(edges) <= _COMPARE_UP_TO:
            # A bucket holds the values below its upper edge less those below its lower
            # one, the edge buckets also the values beyond them. Each edge is one
            # vectorized pass over the values.
            below_inner = [int(np.count_nonzero(values < lo)) for lo, _ in edges[1:]]
            counts = np.diff(np.array([0, *below_inner, len(values)]))
        else:
            lowers = np.array([lo for lo, _ in edges], dtype=np.float64)
            index = np.searchsorted(lowers, values, side="right") - 1
            np.clip(index, 0, len(edges) - 1, out=index)
            counts = np.bincount(index, minlength=len(edges))
        self.bucket_counts = [
            mine + int(new) for mine, new in zip(self.bucket_counts, counts, strict=True)
        ]

    def finish(self, writer: MetricsWriter) -> None:
        if self.total == 0:
            writer.text(
                self.name,
                f"No job wrote values for {self.source}; nothing to draw.",
                status=MetricStatus.NOT_APPLICABLE,
            )
            return
        about = f"{self.total} values of {self.source} from {self.jobs} jobs"
        edges = self._edges()
        x_axis_name = self.x_axis_name
        if x_axis_name is None and len(self.axis_names) == 1:
            x_axis_name = next(iter(self.axis_names))  # only when every job agrees
        if self.dropped_nan:
            about += f" ({self.dropped_nan} NaN values dropped)"
        counts = self.counts
        if counts is None:
            values = _data.doubles(f"{self.name} values", self.values())
            writer.histogram(
                self.name,
                values,
                buckets=edges,
                x_axis_name=x_axis_name,
                description=f"Histogram of {about}.",
            )
            return
        per_value = math.ceil(self.total / self.max_values)
        midpoints: list[float] = []
        for (lo, hi), count in zip(edges, counts, strict=True):
            midpoints.extend([(lo + hi) / 2] * round(count / per_value))
        shown = _data.doubles(f"{self.name} values", midpoints or [edges[0][0]])
        outside = (
            f"; {self.outside} values outside [{edges[0][0]}, {edges[-1][1]}] counted in the "
            "edge buckets"
            if self.outside
            else ""
        )
        writer.histogram(
            self.name,
            shown,
            buckets=edges,
            x_axis_name=x_axis_name,
            description=(
                f"Pre-binned: {about} exceed the cap of {self.max_values} values, so each "
                f"value shown stands for {per_value} values at its bucket's midpoint; exact "
                f"counts are in {self.name + ' (counts)'!r}{outside}."
            ),
        )
        writer.bar_chart_from(
            f"{self.name} (counts)",
            {f"[{lo:g}, {hi:g})": float(c) for (lo, hi), c in zip(edges, counts, strict=True)},
            description=f"Exact bucket counts of {about}.",
        )


def _difference(mine: list[Bucket], theirs: list[Bucket]) -> str:
    """Where two sets of buckets part: their counts and ranges, or the first bucket."""

    def about(edges: list[Bucket]) -> str:
        return f"{len(edges)} from {edges[0][0]:g} to {edges[-1][1]:g}"

    if about(mine) != about(theirs):
        return f"{about(mine)} vs {about(theirs)}"
    i = next(i for i, (a, b) in enumerate(zip(mine, theirs, strict=True)) if a != b)
    return f"bucket {i} is [{mine[i][0]:g}, {mine[i][1]:g}) vs [{theirs[i][0]:g}, {theirs[i][1]:g})"
