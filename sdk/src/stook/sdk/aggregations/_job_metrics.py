"""What the built-ins read of a job's metrics and data, checked: a HISTOGRAM metric's values
and buckets, a BAR_CHART's labelled values, the labelled doubles of a metrics data item.

Anything that is not what the configured aggregation reads (a metric of another type, data
that is not doubles, a reference to data the job does not have) is a `JobDataError` naming
the job, exit code 4: the config is right, the job's data is not.
"""

from __future__ import annotations

import math
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from stook.proto import metrics_pb2 as pb
from stook.sdk._buckets import Bucket
from stook.sdk._enums import MetricType, SeriesKind
from stook.sdk.aggregations._errors import JobDataError
from stook.sdk.aggregations._record import JobRecord

if TYPE_CHECKING:
    import polars as pl

    from stook.sdk._views import MetricsDataView, MetricView


@dataclass(frozen=True, slots=True)
class HistogramOfJob:
    """One job's HISTOGRAM metric: its values (doubles) and the buckets it used."""

    values: pl.Series
    buckets: tuple[Bucket, ...]
    x_axis_name: str


def job_metric(job: JobRecord, name: str, kind: MetricType) -> MetricView | None:
    """The job's metric `name`, None when it has none; JobDataError when of another type."""
    if job.job_metrics is None:
        return None
    found = next((m for m in job.job_metrics.metrics if m.name == name), None)
    if found is None:
        return None
    if found.type is not kind:
        shown = found.type.name if isinstance(found.type, MetricType) else found.type
        raise JobDataError(
            f"job {job.job_id}: metric {name!r} is a {shown}, not a {kind.name}; "
            "check the metric named in the config"
        )
    return found


def _data_of(job: JobRecord, metric: str, ref: pb.MetricsDataId) -> MetricsDataView:
    data_id = uuid.UUID(ref.id.data) if ref.id.data else None
    found = None
    if job.job_metrics is not None and data_id is not None:
        found = job.job_metrics.data_by_id.get(data_id)
    if found is None:
        raise JobDataError(
            f"job {job.job_id}: metric {metric!r} references metrics data {data_id} "
            "that the job does not have"
        )
    return found


def _require_doubles(job: JobRecord, what: str, view: MetricsDataView) -> None:
    if view.kind is not SeriesKind.DOUBLE:
        shown = view.kind.value if view.kind is not None else f"type {view.raw.data_type}"
        raise JobDataError(f"job {job.job_id}: {what} {view.name!r} holds {shown}, not doubles")


def histogram_of(job: JobRecord, name: str) -> HistogramOfJob | None:
    """The job's HISTOGRAM metric `name` with its values and buckets; None without it."""
    metric = job_metric(job, name, MetricType.HISTOGRAM)
    if metric is None:
        return None
    hv = metric.raw.metric_values.histogram_metric_values
    values = _data_of(job, name, hv.values_data_id)
    _require_doubles(job, f"the values of histogram {name!r},", values)
    if values.per_category:
        raise JobDataError(
            f"job {job.job_id}: the values of histogram {name!r} are per category; "
            "a histogram bins one series"
        )
    buckets = tuple((b.lower, b.upper) for b in hv.buckets)
    if not buckets:
        raise JobDataError(f"job {job.job_id}: histogram {name!r} has no buckets")
    return HistogramOfJob(values.series(), buckets, hv.x_axis_name)


def _index_of(job: JobRecord, view: MetricsDataView) -> MetricsDataView | None:
    if view.index_id is None:
        return None
    if job.job_metrics is not None and (found := job.job_metrics.data_by_id.get(view.index_id)):
        return found
    return next((d for d in job.data.values() if d.id == view.index_id), None)


def _add(into: dict[str, list[float]], label: str, value: float) -> None:
    into.setdefault(label, []).append(value)


def labelled_doubles(job: JobRecord, view: MetricsDataView, what: str) -> dict[str, list[float]]:
    """label → the values under it: per-category doubles by category, or doubles indexed
    by string labels by label (a label written twice keeps both values)."""
    _require_doubles(job, what, view)
    found: dict[str, list[float]] = {}
    if view.per_category:
        for category in view.raw.series_per_category.category_to_series:
            for value in view.category_series(category).to_list():
                _add(found, category, value)
        for category in view.categories:
            found.setdefault(category, [])
        return found
    index = _index_of(job, view)
    if index is None or index.kind is not SeriesKind.STRING:
        raise JobDataError(
            f"job {job.job_id}: {what} {view.name!r} is neither per category nor doubles "
            "indexed by string labels, so it has no categories to total"
        )
    labels = index.series().to_list()
    for label, value in zip(labels, view.series().to_list(), strict=True):
        _add(found, label, value)
    return found


def bar_chart_of(job: JobRecord, name: str) -> dict[str, dict[str, list[float]]] | None:
    """The job's BAR_CHART `name` as legend → label → values; None without it. A series
    without a legend name is called after its data."""
    metric = job_metric(job, name, MetricType.BAR_CHART)
    if metric is None:
        return None
    bv = metric.raw.metric_values.bar_chart_metric_values
    legend = list(bv.legend_series_names)
    found: dict[str, dict[str, list[float]]] = {}
    for i, ref in enumerate(bv.values_data_id):
        view = _data_of(job, name, ref)
        series_name = legend[i] if i < len(legend) and legend[i] else view.name
        merged = found.setdefault(series_name, {})
        for label, values in labelled_doubles(job, view, f"bar chart {name!r} data").items():
            merged.setdefault(label, []).extend(values)
    return found


def finite(values: Mapping[str, list[float]]) -> tuple[dict[str, list[float]], int]:
    """The values without NaN and infinities, and how many were dropped."""
    kept = {k: [v for v in vs if math.isfinite(v)] for k, vs in values.items()}
    dropped = sum(len(vs) for vs in values.values()) - sum(len(vs) for vs in kept.values())
    return kept, dropped
