"""Helpers of the report-aggregation tests: hand-made batches, folding, what was written."""

from __future__ import annotations

import uuid
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

import resim.metrics.proto.metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.sdk import (
    BarChartMetric,
    JobMetricsView,
    LinePlotMetric,
    MetricStatus,
    MetricsWriter,
    MetricType,
    MetricView,
    SeriesKind,
    TextMetric,
    read_job_metrics,
    validate_job_metrics,
)
from stook.sdk.aggregations import BatchRecord, JobSummary, ReportAggregation, Scalar

REPORT_ID = uuid.UUID("0d0d0d0d-1111-4222-8333-444444444444")
PROJECT_ID = "5e5e5e5e-1111-4222-8333-444444444444"
T0 = datetime(2024, 3, 1, 12, 0, tzinfo=UTC)


def batch(
    n: int,
    days: float,
    *,
    name: str | None = None,
    scalars: Mapping[str, Scalar | float] | None = None,
    metric_statuses: Sequence[str] = (),
    jobs: Sequence[tuple[str, str]] = (),
    job_scalars: Mapping[str, Sequence[float]] | None = None,
    job_scalar_units: Mapping[str, str] | None = None,
    job_metric_statuses: Sequence[str] = (),
) -> BatchRecord:
    """Batch number `n`, created `days` after T0; jobs as (experience, conflated status)."""
    return BatchRecord(
        # IDs run against creation order, so that sorting by ID would be caught.
        batch_id=uuid.UUID(int=1000 - n),
        name=name if name is not None else f"b{n}",
        created=T0 + timedelta(days=days),
        scalars={
            k: v if isinstance(v, Scalar) else Scalar(float(v)) for k, v in (scalars or {}).items()
        },
        metric_statuses=tuple(metric_statuses),
        jobs=tuple(
            JobSummary(uuid.UUID(int=n * 1000 + i), experience, status)
            for i, (experience, status) in enumerate(jobs)
        ),
        job_scalars=dict(job_scalars or {}),
        job_scalar_units=dict(job_scalar_units or {}),
        job_metric_statuses=tuple(job_metric_statuses),
    )


def scrambled(records: Sequence[BatchRecord]) -> list[BatchRecord]:
    """Not in creation order: odd positions first, then even ones backwards."""
    return list(records[1::2]) + list(records[::2])[::-1]


def fold(aggregation: ReportAggregation, records: Iterable[BatchRecord]) -> ReportAggregation:
    for record in records:
        aggregation.update(record)
    return aggregation


@dataclass(frozen=True)
class Line:
    x: list[float]
    y: list[float]
    statuses: list[str]
    times: list[datetime]
    y_name: str
    y_unit: str


class Output:
    """What a set of finished aggregations wrote, read back and validated."""

    def __init__(self, *aggregations: ReportAggregation) -> None:
        self.writer = MetricsWriter(REPORT_ID, deterministic=True)
        for aggregation in aggregations:
            aggregation.finish(self.writer)
        raw = self.writer.serialize()
        validate_job_metrics(self.writer.to_proto())
        resim_validate(rp.JobMetrics.FromString(raw))
        self.view: JobMetricsView = read_job_metrics(raw)
        self.by_name = {m.name: m for m in self.view.metrics}

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.view.metrics]

    def metric(self, name: str, kind: MetricType) -> MetricView:
        m = self.by_name[name]
        assert m.type is kind
        return m

    def text(self, name: str) -> tuple[str, MetricStatus | int | None]:
        m = self.view.metric(name, TextMetric)
        return m.text, m.status

    def lines(self, name: str) -> list[Line]:
        lv = self.view.metric(name, LinePlotMetric)
        out = []
        for x, y, s in zip(lv.x_doubles_data, lv.y_doubles_data, lv.statuses_data, strict=True):
            assert x.unit == "days"
            assert x.index is not None
            assert x.index_id == y.index_id == s.index_id
            assert x.index.kind is SeriesKind.TIMESTAMP
            out.append(
                Line(
                    x=x.series().to_list(),
                    y=y.series().to_list(),
                    statuses=[str(v) for v in s.series().to_list()],
                    times=x.index.series().to_list(),
                    y_name=y.name,
                    y_unit=y.unit,
                )
            )
        return out

    def line(self, name: str) -> Line:
        (only,) = self.lines(name)
        return only

    def bars(self, name: str) -> dict[str, float]:
        (values,) = self.view.metric(name, BarChartMetric).values_data
        return values.by_label()


def days(*moments: datetime) -> list[float]:
    return [(m - T0).total_seconds() / 86_400 for m in moments]
