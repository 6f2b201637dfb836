"""Per-category totals across jobs: a BAR_CHART of sums and one of means per job, labels kept."""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field
from typing import Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs, exact_sum
from stook.sdk.aggregations._job_metrics import bar_chart_of, finite, labelled_doubles


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
