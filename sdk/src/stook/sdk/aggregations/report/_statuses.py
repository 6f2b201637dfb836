"""Job statuses per batch over time, and counts of job-metric and batch-metric statuses.

As in batch mode (see `_status_counts`), a status this release does not know is a
category of its own (grey in the batchwise chart) and makes no chart fail.
"""

from __future__ import annotations

import uuid
from collections import Counter
from dataclasses import dataclass, field
from typing import Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, BatchRecord, Needs
from stook.sdk.aggregations._status_counts import JOB_STATUSES, METRIC_STATUSES, ordered_counts
from stook.sdk.aggregations.report._timeline import BatchPoint, counts, first_seen

STATUS_COLORS = {
    "PASSED": "#2e7d32",
    "WARNING": "#f9a825",
    "BLOCKER": "#c62828",
    "ERROR": "#6a1b9a",
    "CANCELLED": "#757575",
    "QUEUED": "#90a4ae",
    "RUNNING": "#1565c0",
}
_OTHER_COLOR = "#9e9e9e"


@dataclass
class TestStatusOverTime(Aggregation[BatchRecord]):
    """A BATCHWISE_BAR_CHART of job counts per conflated status, per batch."""

    __test__ = False  # not a pytest test class, whatever its name says

    project_id: str
    name: str = "Test status over time"

    counts: dict[BatchPoint, Counter[str]] = field(default_factory=dict, init=False)

    def update(self, record: BatchRecord) -> None:
        point = BatchPoint(record.created, record.batch_id, record.name)
        columns = record.job_columns()
        found = counts(columns.status, len(columns.statuses))
        self.counts[point] = Counter(
            {columns.statuses[code]: found[code] for code in first_seen(columns.status)}
        )

    def merge(self, other: Self) -> None:
        self.counts.update(other.counts)

    def finish(self, writer: MetricsWriter) -> None:
        if not self.counts:
            return
        points = sorted(self.counts)
        seen: Counter[str] = Counter()
        for counter in self.counts.values():
            seen.update(counter)
        statuses = list(ordered_counts(seen, JOB_STATUSES, ("PASSED",)))
        ids = _data.uuids(f"{self.name} (batches)", [p.batch_id for p in points])
        times, values = [], []
        for status in statuses:
            times.append(
                _data.timestamps(
                    f"{self.name}: {status} (times)", [p.created for p in points], index=ids
                )
            )
            values.append(
                _data.doubles(
                    f"{self.name}: {status}",
                    [float(self.counts[p][status]) for p in points],
                    index=ids,
                )
            )
        writer.batchwise_bar_chart(
            self.name,
            project_id=uuid.UUID(self.project_id),
            times=times,
            values=values,
            categories=statuses,
            colors=[STATUS_COLORS.get(s, _OTHER_COLOR) for s in statuses],
            x_axis_name="Batch",
            y_axis_name="Jobs",
            stack_bars=True,
            description=f"Jobs per conflated status in each of {len(points)} batches.",
        )


@dataclass
class JobMetricStatusCounts(Aggregation[BatchRecord]):
    """A BAR_CHART of the statuses of every job metric of every batch in the report."""

    name: str = "Job metric statuses"
    counts: Counter[str] = field(default_factory=Counter, init=False)

    def needs(self) -> Needs:
        return Needs(job_metrics=True)

    def update(self, record: BatchRecord) -> None:
        self.counts.update({s: n for s, n in record.job_columns().metric_statuses.items() if n > 0})

    def merge(self, other: Self) -> None:
        self.counts.update(other.counts)

    def finish(self, writer: MetricsWriter) -> None:
        _status_chart(writer, self.name, self.counts, "Job metrics")


@dataclass
class BatchMetricStatusCounts(Aggregation[BatchRecord]):
    """A BAR_CHART of the statuses of every batch metric of the report's batches."""

    name: str = "Batch metric statuses"
    counts: Counter[str] = field(default_factory=Counter, init=False)

    def update(self, record: BatchRecord) -> None:
        self.counts.update(record.metric_statuses)

    def merge(self, other: Self) -> None:
        self.counts.update(other.counts)

    def finish(self, writer: MetricsWriter) -> None:
        _status_chart(writer, self.name, self.counts, "Batch metrics")


def _status_chart(writer: MetricsWriter, name: str, counts: Counter[str], what: str) -> None:
    if not counts:
        return
    status = MetricStatus.PASSED
    if counts["FAIL_BLOCK"]:
        status = MetricStatus.FAIL_BLOCK
    elif counts["FAIL_WARN"]:
        status = MetricStatus.FAIL_WARN
    writer.bar_chart_from(
        name,
        ordered_counts(counts, METRIC_STATUSES, ("PASSED", "FAIL_WARN", "FAIL_BLOCK")),
        x_axis_name="Metric status",
        y_axis_name=what,
        status=status,
        description=f"{sum(counts.values())} {what.lower()} by status.",
    )
