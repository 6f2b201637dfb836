"""Counts of the jobs' events by name and status: one stacked BAR_CHART for the batch."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs
from stook.sdk.aggregations._status_counts import METRIC_STATUSES


@dataclass
class EventCounts(Aggregation[JobRecord]):
    """How many events of each name the batch's jobs had, split by the events' status.

    One BAR_CHART: a bar per event name (sorted), stacked by status, one series per
    status that occurs (the known statuses in the app's order, then others sorted).
    Without any event it writes a TEXT saying so, NOT_APPLICABLE.
    """

    name: str = "Events by name and status"

    counts: Counter[tuple[str, str]] = field(default_factory=Counter, init=False)
    jobs: int = field(default=0, init=False)
    jobs_with_events: int = field(default=0, init=False)

    def needs(self) -> Needs:
        return Needs(events=True)

    def update(self, job: JobRecord) -> None:
        self.jobs += 1
        self.jobs_with_events += bool(job.events)
        self.counts.update((event.name, event.status) for event in job.events)

    def merge(self, other: Self) -> None:
        self.jobs += other.jobs
        self.jobs_with_events += other.jobs_with_events
        self.counts.update(other.counts)

    def finish(self, writer: MetricsWriter) -> None:
        if not self.counts:
            writer.text(
                self.name,
                f"None of the batch's {self.jobs} jobs had events.",
                status=MetricStatus.NOT_APPLICABLE,
            )
            return
        names = sorted({name for name, _ in self.counts})
        seen = {status for _, status in self.counts}
        statuses = [s for s in METRIC_STATUSES if s in seen]
        statuses += sorted(seen - set(METRIC_STATUSES))
        index = _data.strings(f"{self.name} (names)", names)
        series = [
            _data.doubles(
                f"{self.name} ({status})",
                [float(self.counts[name, status]) for name in names],
                index=index,
            )
            for status in statuses
        ]
        total = sum(self.counts.values())
        writer.bar_chart(
            self.name,
            series,
            legend=statuses,
            stack_bars=True,
            x_axis_name="Event",
            y_axis_name="Events",
            description=(
                f"{total} events of {self.jobs_with_events} of the batch's {self.jobs} jobs, "
                "by name, stacked by the events' status."
            ),
        )
