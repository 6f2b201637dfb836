"""The aggregation protocol, and what an aggregation sees of the jobs it folds in.

An `Aggregation` folds in one job at a time (`update`), merges with a partial state
built from other jobs (`merge`) and writes its metrics (`finish`). A `JobRecord` is what
it sees of one job: its facts, its scalar metrics and the data it asked for (`Needs`);
a `BatchRecord`, what a report aggregation sees of one batch. `SeriesByName` is the
mapping of a job's plain double series that a fetch hands over as `JobRecord.series`:
building a polars Series per job cost more than some aggregations' whole update, so
each is made on first access and kept, and `values_of` gives the values as numpy
without polars.

The helpers every aggregation writes with keep results independent of the order jobs
arrive in: `exact_sum` and `exact_mean` are math.fsum, exact and correctly rounded,
without its overflow error where the exact sum leaves the double range but the quantity
wanted (a mean, a ratio) does not; `pick_unit` reports the most common unit when jobs
disagree, ties broken by name (keeping "the first unit seen" would depend on order).
"""

from __future__ import annotations

import dataclasses
import math
import uuid
from abc import ABC, abstractmethod
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import TYPE_CHECKING, Any, Generic, Self, TypeVar, overload

from stook.sdk._enums import SeriesKind
from stook.sdk.aggregations._columns import (
    JobColumns,
    JobSummaries,
    JobSummary,
    PooledScalars,
    StatusList,
    columns_of,
)

if TYPE_CHECKING:
    import numpy as np
    import polars as pl

    from stook.sdk._views import JobMetricsView, MetricsDataView, TypedMetric
    from stook.sdk._writer import MetricsWriter


def pick_unit(units: Counter[str]) -> str:
    named = [(-count, unit) for unit, count in units.items() if unit]
    return min(named)[1] if named else ""


def exact_sum(values: Sequence[float]) -> float:
    """fsum, or ±inf where the exact sum is beyond the largest double."""
    try:
        return math.fsum(values)
    except OverflowError:
        # The scaled sum is exact in sign; its magnitude is what overflowed.
        return math.copysign(math.inf, math.fsum(v / 2.0**64 for v in values))


def exact_mean(values: Sequence[float]) -> float:
    """The mean of finite values; sums first, or divides first when the sum would overflow."""
    try:
        return math.fsum(values) / len(values)
    except OverflowError:
        return math.fsum(v / len(values) for v in values)


_T = TypeVar("_T", bound="TypedMetric")

#: The conflated status of a job the API listed without one. A status the platform adds
#: later is kept under its own name; either way it is a category of its own in the charts,
#: counts as not passed and makes nothing fail (see `JobStatusCounts`).
UNKNOWN_STATUS = "UNKNOWN"


@dataclass(frozen=True, slots=True)
class Scalar:
    """One SCALAR job metric, as the API lists it (no download needed)."""

    value: float
    unit: str = ""
    status: str = "PASSED"


@dataclass(frozen=True, slots=True)
class JobEvent:
    """One event of a job, as the API lists it (`Needs.events`).

    `status` is the API's spelling (PASSED, FAIL_WARN, ...; an unknown one as it came,
    NO_STATUS_REPORTED when absent); `timestamp_type` is the API's ABSOLUTE or RELATIVE
    (or what the API sent; "" when absent); `timestamp` is None when absent.
    """

    event_id: uuid.UUID
    name: str
    status: str = "NO_STATUS_REPORTED"
    timestamp: datetime | None = None
    timestamp_type: str = ""
    description: str = ""
    tags: tuple[str, ...] = ()
    metric_ids: tuple[uuid.UUID, ...] = ()


@dataclass(frozen=True, slots=True)
class JobRecord:
    """One job folded into aggregations.

    `scalars` holds every SCALAR job metric by name; `series` holds the plain (not per
    category) double metrics data the aggregation plan asked for, by data name, as
    Float64 (batch mode hands a `SeriesByName`, which makes each on first access);
    `data` holds every metrics data the plan asked for (`Needs.data`), of any kind, as
    typed views that keep indexes and category names; `metric_statuses` holds
    the status of every job metric, scalar or not. `job_metrics` holds the metrics the
    plan named (`Needs.metrics`, or all of them for `Needs.every_metric`) with the data
    they reference, read as one `JobMetricsView`; None when the plan named none.
    `parameters` are the job's parameters (from the job listing, always present);
    `events` the job's events when the plan asked for them (`Needs.events`);
    `experience_tags` the names of its experience's tags when asked
    (`Needs.experience_tags`), sorted.
    Statuses are the API's spellings; one this SDK does not know is kept as it came,
    a job without a conflated status has `UNKNOWN_STATUS`, and a metric without a
    status NO_STATUS_REPORTED.
    """

    job_id: uuid.UUID
    conflated_status: str
    experience_name: str = ""
    experience_id: uuid.UUID | None = None
    scalars: Mapping[str, Scalar] = field(default_factory=dict)
    series: Mapping[str, pl.Series] = field(default_factory=dict)
    metric_statuses: Sequence[str] = ()
    data: Mapping[str, MetricsDataView] = field(default_factory=dict)
    job_metrics: JobMetricsView | None = None
    parameters: Mapping[str, str] = field(default_factory=dict)
    events: Sequence[JobEvent] = ()
    experience_tags: Sequence[str] = ()

    @overload
    def metric(self, name: str) -> TypedMetric | None: ...
    @overload
    def metric(self, name: str, kind: type[_T]) -> _T | None: ...
    def metric(self, name: str, kind: type[TypedMetric] | None = None) -> TypedMetric | None:
        """The typed view of the job metric `name` (`JobMetricsView.metric`), or None when
        the job has no such metric or `job_metrics` is None. With `kind`, the view must be
        of that class (TypeError otherwise)."""
        if self.job_metrics is None or self.job_metrics.find_metric(name) is None:
            return None
        if kind is None:
            return self.job_metrics.metric(name)
        return self.job_metrics.metric(name, kind)

    def scalars_frame(self) -> pl.DataFrame:
        """The scalars as a frame with columns name, value, unit, status."""
        import polars as pl

        return pl.DataFrame(
            {
                "name": list(self.scalars),
                "value": [s.value for s in self.scalars.values()],
                "unit": [s.unit for s in self.scalars.values()],
                "status": [s.status for s in self.scalars.values()],
            },
            schema={"name": pl.String, "value": pl.Float64, "unit": pl.String, "status": pl.String},
        )


@dataclass(frozen=True, slots=True)
class BatchRecord:
    """One batch folded into report aggregations.

    `scalars` holds the batch's SCALAR batch metrics by name; `metric_statuses` the
    status of every batch metric. `jobs` lists its jobs. When the plan asks for job
    metrics, `job_scalars` holds each SCALAR job metric's values across the batch's
    jobs and `job_metric_statuses` every job metric's status. `build_id` is the build the
    batch ran, when the API said.

    `columns` holds the same job data as arrays (`JobColumns`), which report
    aggregations reduce per batch; report mode sets it, and then `jobs`, `job_scalars`
    and `job_metric_statuses` are views made from it when read (`with_columns`). A
    record built from the per-job fields alone gets its columns from them
    (`job_columns`).
    """

    batch_id: uuid.UUID
    name: str
    created: datetime
    conflated_status: str = ""
    scalars: Mapping[str, Scalar] = field(default_factory=dict)
    metric_statuses: Sequence[str] = ()
    jobs: Sequence[JobSummary] = ()
    job_scalars: Mapping[str, Sequence[float]] = field(default_factory=dict)
    job_scalar_units: Mapping[str, str] = field(default_factory=dict)
    job_metric_statuses: Sequence[str] = ()
    build_id: uuid.UUID | None = None
    columns: JobColumns | None = field(default=None, repr=False)

    @classmethod
    def with_columns(
        cls,
        batch_id: uuid.UUID,
        name: str,
        created: datetime,
        columns: JobColumns,
        *,
        conflated_status: str = "",
        scalars: Mapping[str, Scalar] | None = None,
        metric_statuses: Sequence[str] = (),
        build_id: uuid.UUID | None = None,
    ) -> BatchRecord:
        """A record whose job data is `columns`; its per-job fields are made from them
        only when read."""
        return cls(
            batch_id=batch_id,
            name=name,
            created=created,
            conflated_status=conflated_status,
            scalars=dict(scalars or {}),
            metric_statuses=metric_statuses,
            jobs=JobSummaries(columns),
            job_scalars=PooledScalars(columns),
            job_scalar_units=columns.units(),
            job_metric_statuses=StatusList(columns.metric_statuses),
            build_id=build_id,
            columns=columns,
        )

    def job_columns(self) -> JobColumns:
        """The batch's job data as columns: `columns`, or made from the per-job fields."""
        if self.columns is not None:
            return self.columns
        return columns_of(self.jobs, self.job_scalars, self.job_metric_statuses)


_DOUBLE = SeriesKind.DOUBLE  # an enum member read off its class costs a lookup


class SeriesByName(Mapping[str, "pl.Series"]):
    """Data name -> `MetricsDataView.series` of plain double data, made on first access.

    Reads like the dict of those series it stands for (iteration in the order given);
    batch mode hands each job's `JobRecord.series` over as one. Every view must be of
    plain (not per-category) double data (ValueError otherwise). An aggregation that
    reduces the values with numpy can take them with `values_of` instead, and then no
    polars Series is made for it.
    """

    __slots__ = ("_made", "_views")

    def __init__(self, views: Mapping[str, MetricsDataView]) -> None:
        for name, view in views.items():
            if view.kind is not _DOUBLE or view.per_category:
                raise ValueError(f"metrics data {name!r} is not a plain double series")
        self._views = views
        self._made: dict[str, pl.Series] = {}

    def __getitem__(self, name: str) -> pl.Series:
        made = self._made.get(name)
        if made is None:
            made = self._made[name] = self._views[name].series()
        return made

    def __iter__(self) -> Iterator[str]:
        return iter(self._views)

    def __len__(self) -> int:
        return len(self._views)

    def __contains__(self, name: object) -> bool:
        return name in self._views

    def __repr__(self) -> str:
        return repr(dict(self.items()))

    def values_of(self, name: str) -> np.ndarray[Any, np.dtype[np.float64]] | None:
        """The values of `name` as a read-only float64 array (None without such data),
        bit for bit the series' values, without a polars Series."""
        view = self._views.get(name)
        if view is None:
            return None
        from stook.sdk._series import doubles_array  # numpy, with the first values asked for

        return doubles_array(view.raw.series.doubles)


@dataclass(frozen=True, slots=True)
class Needs:
    """What an aggregation reads, so that the fetcher downloads no more than that.

    Scalars, job parameters and the job's facts come with the listings at no extra cost.
    Each name in `data` costs a download per job that has it (any kind of metrics data:
    doubles, strings, statuses, timestamps, UUIDs, indexed or per category); each name in
    `metrics` costs the job's metric blob plus the blobs of the data it references, and
    `every_metric` asks for every metric and metrics data of every job (the load of
    ReSim's own fetcher). `events` costs one listing per job, `experience_tags` one per
    experience (not per job). Data in `data` comes without its index data unless named in
    `data_with_index` too (labels of a bar chart's values, timestamps of a series): one
    more download per job whose data is indexed. In report mode, `job_metrics` asks for
    the metric listing of every job of every batch (one request per job).

    `scalars` names the SCALAR metrics an aggregation reads, and `every_scalar` says it
    reads all of them, whatever their names. The API may list a scalar without its value
    (`value: null`); the value is then downloaded from the metric itself, but only for the
    scalars declared here, so a scalar that no aggregation declares may be missing from
    `JobRecord.scalars` when the API lists it without a value.
    """

    scalars: frozenset[str] = frozenset()
    data: frozenset[str] = frozenset()
    job_metrics: bool = False
    every_scalar: bool = False
    metrics: frozenset[str] = frozenset()
    every_metric: bool = False
    events: bool = False
    experience_tags: bool = False
    data_with_index: frozenset[str] = frozenset()

    def __or__(self, other: Needs) -> Needs:
        return Needs(
            scalars=self.scalars | other.scalars,
            data=self.data | other.data,
            job_metrics=self.job_metrics or other.job_metrics,
            every_scalar=self.every_scalar or other.every_scalar,
            metrics=self.metrics | other.metrics,
            every_metric=self.every_metric or other.every_metric,
            events=self.events or other.events,
            experience_tags=self.experience_tags or other.experience_tags,
            data_with_index=self.data_with_index | other.data_with_index,
        )

    def wants_metric(self, name: str) -> bool:
        """Whether an aggregation reads the job metric `name` with the data it references."""
        return self.every_metric or name in self.metrics

    def wants_scalar(self, name: str) -> bool:
        """Whether an aggregation reads the SCALAR metric `name`."""
        return self.every_scalar or name in self.scalars


R = TypeVar("R")


class Aggregation(ABC, Generic[R]):
    """A metric computed as a mergeable partial state over records: the jobs of a batch
    (`JobRecord`, batch mode) or the batches of a report (`BatchRecord`, report mode).

    Subclasses are dataclasses: their init fields are the configuration (what the
    TOML table holds) and their non-init fields the partial state. `update` folds in
    one record, `merge` folds in another partial state of the same configuration (built
    from other records), and `finish` writes the result. Folding records into several
    partials and merging them must give what folding them all into one gives, in any
    order.

    Partial states travel between processes: the processes and Ray engines fold each
    shard in a worker and pickle its partial back to be merged. So a partial must pickle
    (no lambdas, locks, open files or generators in its state) and unpickle to one that
    updates, merges and finishes as the original would; `stook.sdk.testing.check_merge_laws`
    checks both. Keep what is pickled compact: counts where the output needs only counts,
    per-record values packed (``array("d")``, 8 bytes each) where it needs the values;
    ``__getstate__`` / ``__setstate__`` may pack a state that is cheaper to update unpacked.
    """

    #: the name of the first metric it writes; used in errors and logs
    name: str

    def needs(self) -> Needs:
        return Needs()

    @abstractmethod
    def update(self, record: R) -> None: ...

    @abstractmethod
    def merge(self, other: Self) -> None: ...

    @abstractmethod
    def finish(self, writer: MetricsWriter) -> None: ...

    def fresh(self) -> Self:
        """An empty partial state with this one's configuration."""
        return dataclasses.replace(self)  # type: ignore[type-var]


#: an aggregation over the jobs of a batch (batch mode)
BatchAggregation = Aggregation[JobRecord]
#: an aggregation over the batches of a report (report mode)
ReportAggregation = Aggregation[BatchRecord]
