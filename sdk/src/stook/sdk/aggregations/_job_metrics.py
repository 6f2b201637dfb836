"""What the built-ins read of a job's metrics and data, checked: a HISTOGRAM metric's values
and buckets, a BAR_CHART's labelled values, the labelled doubles of a metrics data item.

Anything that is not what the configured aggregation reads (a metric of another type, data
that is not doubles, a reference to data the job does not have) is a `JobDataError` naming
the job, exit code 4: the config is right, the job's data is not.

`CategoryTotals`, the built-in that reads a job's labelled doubles, is here too:
per-category totals across jobs, a BAR_CHART of sums and one of means per job, labels
kept.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Self, TypeVar

from stook.sdk import _data
from stook.sdk._enums import MetricStatus, MetricType, SeriesKind
from stook.sdk._errors import JobDataError, ReadError, WriterError
from stook.sdk._views import BarChartMetric, HistogramMetric, TypedMetric
from stook.sdk._writer import Bucket, MetricsWriter, histogram_buckets
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs, exact_sum

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


@dataclass
class CategoryTotals(Aggregation[JobRecord]):
    """Sums the values of each category (or string label) across the jobs.

    The source is `data`, metrics data per category or doubles indexed by string labels,
    or `metric`, a BAR_CHART the jobs wrote (exactly one of them); data indexed by
    labels is fetched with its labels (`Needs.data_with_index`). A label's total is the
    sum of every value under it in every job; its mean per job is that total over the
    jobs that wrote the source (a job without the label adds 0). Labels are sorted, so
    the chart does not depend on the order jobs arrive in; a BAR_CHART source with
    several series keeps one series per legend name, also sorted. NaN and infinite
    values are left out and counted in the description.

    Writes BAR_CHARTs ``<name>`` (the totals) and ``<name> (mean per job)``; ``name``
    defaults to ``<source> (total)``.
    """

    data: str | None = None
    metric: str | None = None
    name: str = ""
    x_axis_name: str | None = None
    y_axis_name: str | None = None

    # series (legend name, "" for data) → label → one exact sum per job that had the label:
    # a job's values summed at once keep memory at jobs x labels, and the total of the
    # per-job sums (exact, correctly rounded) does not depend on the order jobs arrive in.
    values: dict[str, dict[str, array[float]]] = field(default_factory=dict, init=False)
    jobs: int = field(default=0, init=False)
    dropped: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if (self.data is None) == (self.metric is None):
            raise ValueError("give exactly one of 'data' (per-category data) or 'metric'")
        self.name = self.name or f"{self.source} (total)"

    @property
    def source(self) -> str:
        source = self.data if self.data is not None else self.metric
        assert source is not None
        return source

    def needs(self) -> Needs:
        if self.metric is not None:
            return Needs(metrics=frozenset({self.metric}))
        return Needs(data=frozenset({self.source}), data_with_index=frozenset({self.source}))

    def _read(self, job: JobRecord) -> dict[str, dict[str, list[float]]] | None:
        if self.metric is not None:
            return bar_chart_of(job, self.metric)
        view = job.data.get(self.source)
        if view is None:
            return None
        return {"": labelled_doubles(job, view, "metrics data")}

    def update(self, job: JobRecord) -> None:
        found = self._read(job)
        if found is None:
            return
        self.jobs += 1
        for series, labelled in found.items():
            kept, dropped = finite(labelled)
            self.dropped += dropped
            mine = self.values.setdefault(series, {})
            for label, values in kept.items():
                mine.setdefault(label, array("d")).append(exact_sum(values))

    def merge(self, other: Self) -> None:
        self.jobs += other.jobs
        self.dropped += other.dropped
        for series, labelled in other.values.items():
            mine = self.values.setdefault(series, {})
            for label, values in labelled.items():
                mine.setdefault(label, array("d")).extend(values)

    def totals(self) -> dict[str, dict[str, float]]:
        """series → label → exact sum, series and labels sorted; every series has every label."""
        labels = sorted({label for labelled in self.values.values() for label in labelled})
        return {
            series: {label: exact_sum(self.values[series].get(label, ())) for label in labels}
            for series in sorted(self.values)
        }

    def finish(self, writer: MetricsWriter) -> None:
        totals = self.totals()
        labels = next(iter(totals.values()), {})
        if not labels:
            writer.text(
                self.name,
                f"No job wrote categories for {self.source!r}; nothing to total.",
                status=MetricStatus.NOT_APPLICABLE,
            )
            return
        about = f"{self.source!r} across {self.jobs} jobs"
        if self.dropped:
            about += f" ({self.dropped} NaN or infinite values left out)"
        index = _data.strings(f"{self.name} (labels)", list(labels))
        legend = [series or self.source for series in totals]
        for name, what, per in (
            (self.name, "Total", 1),
            (f"{self.name} (mean per job)", "Mean per job", self.jobs),
        ):
            series = [
                _data.doubles(
                    f"{name} ({series})" if series else name,
                    [value / per for value in by_label.values()],
                    index=index,
                )
                for series, by_label in totals.items()
            ]
            writer.bar_chart(
                name,
                series,
                legend=legend,
                x_axis_name=self.x_axis_name or "Category",
                y_axis_name=self.y_axis_name or what,
                description=f"{what} of each category of {about}.",
            )
