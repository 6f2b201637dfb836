"""What an aggregation sees of one job: its facts, its scalar metrics and the data it asked for."""

from __future__ import annotations

import uuid
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import TYPE_CHECKING, TypeVar, overload

from stook.sdk.aggregations._columns import (
    JobColumns,
    JobSummaries,
    JobSummary,
    PooledScalars,
    StatusList,
    columns_of,
)

if TYPE_CHECKING:
    import polars as pl

    # The typed views (and protobuf with them) are imported once a job's metrics are read:
    # `stook run` builds its aggregations, which name records, before its first request.
    from stook.sdk._views import JobMetricsView, MetricsDataView, TypedMetric

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
