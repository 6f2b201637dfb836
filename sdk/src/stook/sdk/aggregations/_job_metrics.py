"""What the built-ins read of a job's metrics and data, checked: a HISTOGRAM metric's values
and buckets, a BAR_CHART's labelled values, the labelled doubles of a metrics data item.

Anything that is not what the configured aggregation reads (a metric of another type, data
that is not doubles, a reference to data the job does not have) is a `JobDataError` naming
the job, exit code 4: the config is right, the job's data is not.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

from stook.sdk._enums import MetricType, SeriesKind
from stook.sdk._errors import JobDataError, ReadError, WriterError
from stook.sdk._views import BarChartMetric, HistogramMetric, TypedMetric
from stook.sdk._writer import Bucket, histogram_buckets
from stook.sdk.aggregations._base import JobRecord

if TYPE_CHECKING:
    import polars as pl

    from stook.sdk._views import MetricsDataView

_T = TypeVar("_T", bound=TypedMetric)


@dataclass(frozen=True, slots=True)
class HistogramOfJob:
    """One job's HISTOGRAM metric: its values (doubles) and the buckets it used."""

    values: pl.Series
    buckets: tuple[Bucket, ...]
    x_axis_name: str


def job_metric(job: JobRecord, name: str, kind: MetricType, view: type[_T]) -> _T | None:
    """The job's metric `name` as a typed view, None when it has none; JobDataError when
    it is of another type or cannot be read (data it references missing, say)."""
    if job.job_metrics is None:
        return None
    found = job.job_metrics.find_metric(name)
    if found is None:
        return None
    if found.type is not kind:
        shown = found.type.name if isinstance(found.type, MetricType) else found.type
        raise JobDataError(
            f"job {job.job_id}: metric {name!r} is a {shown}, not a {kind.name}; "
            "check the metric named in the config"
        )
    try:
        return job.job_metrics.metric(name, view)
    except ReadError as exc:
        raise JobDataError(f"job {job.job_id}: {exc}") from None


def _require_doubles(job: JobRecord, what: str, view: MetricsDataView | None) -> MetricsDataView:
    if view is None:
        raise JobDataError(f"job {job.job_id}: {what} has no values data")
    if view.kind is not SeriesKind.DOUBLE:
        shown = view.kind.value if view.kind is not None else f"type {view.raw.data_type}"
        raise JobDataError(f"job {job.job_id}: {what} {view.name!r} holds {shown}, not doubles")
    return view


def histogram_of(job: JobRecord, name: str) -> HistogramOfJob | None:
    """The job's HISTOGRAM metric `name` with its values and buckets; None without it."""
    metric = job_metric(job, name, MetricType.HISTOGRAM, HistogramMetric)
    if metric is None:
        return None
    values = _require_doubles(job, f"histogram {name!r}", metric.values_data)
    if values.per_category:
        raise JobDataError(
            f"job {job.job_id}: the values of histogram {name!r} are per category; "
            "a histogram bins one series"
        )
    buckets = tuple((b.lower, b.upper) for b in metric.buckets)
    if not buckets:
        raise JobDataError(f"job {job.job_id}: histogram {name!r} has no buckets")
    checked: list[Bucket] = []
    for i, (lower, upper) in enumerate(buckets):
        if lower is None or upper is None:
            raise JobDataError(f"job {job.job_id}: bucket {i} of histogram {name!r} has no bounds")
        checked.append((lower, upper))
    try:  # contiguous, each lower < upper: what the output's histogram will need
        checked = histogram_buckets(name, checked, None, None)
    except WriterError as exc:
        raise JobDataError(f"job {job.job_id}: {exc}") from None
    return HistogramOfJob(values.series(), tuple(checked), metric.x_axis_name or "")


def _index_of(job: JobRecord, view: MetricsDataView) -> MetricsDataView | None:
    if view.index is not None or view.index_id is None:
        return view.index
    # Data read alone (not with the output holding its index): look among the job's data.
    return next((d for d in job.data.values() if d.id == view.index_id), None)


def _add(into: dict[str, list[float]], label: str, value: float) -> None:
    into.setdefault(label, []).append(value)


def labelled_doubles(job: JobRecord, view: MetricsDataView, what: str) -> dict[str, list[float]]:
    """label → the values under it: per-category doubles by category, or doubles indexed
    by string labels by label (a label written twice keeps both values)."""
    _require_doubles(job, what, view)
    found: dict[str, list[float]] = {}
    if view.per_category:
        for category, series in view.by_category().items():
            found[category] = series.to_list()
        for category in view.categories:
            found.setdefault(category, [])
        return found
    if view.index_id is None:
        raise JobDataError(
            f"job {job.job_id}: {what} {view.name!r} is neither per category nor doubles "
            "indexed by string labels, so it has no categories to total"
        )
    index = _index_of(job, view)
    if index is None:
        raise JobDataError(
            f"job {job.job_id}: {what} {view.name!r} is indexed by data {view.index_id} "
            "that was not fetched (declare it in Needs.data_with_index)"
        )
    if index.kind is not SeriesKind.STRING:
        raise JobDataError(
            f"job {job.job_id}: {what} {view.name!r} is indexed by {index.kind}, not by "
            "string labels, so it has no categories to total"
        )
    labels, values = index.values(), view.values()
    if len(labels) != len(values):
        raise JobDataError(
            f"job {job.job_id}: {what} {view.name!r} has {len(values)} values but its "
            f"labels {index.name!r} have {len(labels)}"
        )
    for label, value in zip(labels, values, strict=True):
        _add(found, label, value)
    return found


def bar_chart_of(job: JobRecord, name: str) -> dict[str, dict[str, list[float]]] | None:
    """The job's BAR_CHART `name` as legend → label → values; None without it. A series
    without a legend name is called after its data."""
    metric = job_metric(job, name, MetricType.BAR_CHART, BarChartMetric)
    if metric is None:
        return None
    found: dict[str, dict[str, list[float]]] = {}
    for i, view in enumerate(metric.values_data):
        legend = metric.legend[i] if i < len(metric.legend) else ""
        merged = found.setdefault(legend or view.name, {})
        for label, values in labelled_doubles(job, view, f"bar chart {name!r} data").items():
            merged.setdefault(label, []).extend(values)
    return found


def finite(values: Mapping[str, list[float]]) -> tuple[dict[str, list[float]], int]:
    """The values without NaN and infinities, and how many were dropped."""
    kept = {k: [v for v in vs if math.isfinite(v)] for k, vs in values.items()}
    dropped = sum(len(vs) for vs in values.values()) - sum(len(vs) for vs in kept.values())
    return kept, dropped
