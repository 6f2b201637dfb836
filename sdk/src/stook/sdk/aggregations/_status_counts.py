"""Counts of job statuses, job-metric statuses and events, and the batch's pass rate.

A status outside the lists below (one the platform adds after this release, or
UNKNOWN for a job listed without one) is counted under its own name, after the known
ones. It is neither a pass nor a failure: it lowers the pass rate (the job did not
pass) but never turns a chart or the batch to FAIL_WARN or FAIL_BLOCK, since nothing
says the job failed; a status that did mean failure would also show in the job's
metric statuses. `EventCounts` counts the jobs' events by name and status, as one
stacked BAR_CHART for the batch.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import chain
from typing import Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs

#: The job statuses the status charts know, in the app's order; the commonest are shown
#: even at zero, so that charts of different batches line up. Others come after, sorted.
JOB_STATUSES = ("PASSED", "WARNING", "BLOCKER", "ERROR", "CANCELLED", "QUEUED", "RUNNING")
_ALWAYS_SHOWN_JOB_STATUSES = JOB_STATUSES[:4]
#: How many jobs' metric statuses wait to be counted in one Counter.update.
COUNT_BATCH = 256
#: The same for the statuses of job metrics, in the API's spelling.
METRIC_STATUSES = (
    "PASSED",
    "FAIL_WARN",
    "FAIL_BLOCK",
    "NOT_APPLICABLE",
    "RAW",
    "NO_STATUS_REPORTED",
)


def ordered_counts(
    counts: Counter[str], order: tuple[str, ...], always: tuple[str, ...]
) -> dict[str, float]:
    keys = [k for k in order if k in always or counts[k]]
    keys += sorted(k for k in counts if k not in order)
    return {k: float(counts[k]) for k in keys}


@dataclass
class JobStatusCounts(Aggregation[JobRecord]):
    """A BAR_CHART of the jobs' conflated statuses. Any BLOCKER job makes it FAIL_BLOCK,
    any WARNING or ERROR job FAIL_WARN, so the batch's status follows its jobs."""

    name: str = "Job statuses"
    counts: Counter[str] = field(default_factory=Counter, init=False)

    def update(self, job: JobRecord) -> None:
        self.counts[job.conflated_status] += 1

    def merge(self, other: Self) -> None:
        self.counts.update(other.counts)

    @property
    def status(self) -> MetricStatus:
        if self.counts["BLOCKER"]:
            return MetricStatus.FAIL_BLOCK
        if self.counts["WARNING"] or self.counts["ERROR"]:
            return MetricStatus.FAIL_WARN
        return MetricStatus.PASSED

    def finish(self, writer: MetricsWriter) -> None:
        writer.bar_chart_from(
            self.name,
            ordered_counts(self.counts, JOB_STATUSES, _ALWAYS_SHOWN_JOB_STATUSES),
            x_axis_name="Conflated job status",
            y_axis_name="Jobs",
            status=self.status,
            description=f"Conflated status of the batch's {sum(self.counts.values())} jobs.",
        )


@dataclass
class MetricStatusCounts(Aggregation[JobRecord]):
    """A BAR_CHART of the statuses of every job metric across the batch."""

    name: str = "Job metric statuses"
    counts: Counter[str] = field(default_factory=Counter, init=False)
    # Jobs' statuses wait here and are counted COUNT_BATCH jobs at a time: a Counter.update
    # per job cost a third more (a Python call and a Mapping check each).
    waiting: list[Sequence[str]] = field(default_factory=list, init=False)

    def update(self, job: JobRecord) -> None:
        self.waiting.append(job.metric_statuses)
        if len(self.waiting) >= COUNT_BATCH:
            self._count_waiting()

    def _count_waiting(self) -> None:
        if self.waiting:
            waiting, self.waiting = self.waiting, []
            self.counts.update(chain.from_iterable(waiting))

    def __getstate__(self) -> dict[str, object]:
        """What travels between processes (see `Aggregation`): the counts, the waiting
        statuses counted first."""
        self._count_waiting()
        return dict(self.__dict__)

    def merge(self, other: Self) -> None:
        self._count_waiting()
        other._count_waiting()
        self.counts.update(other.counts)

    def finish(self, writer: MetricsWriter) -> None:
        self._count_waiting()
        if not self.counts:
            return
        status = MetricStatus.PASSED
        if self.counts["FAIL_BLOCK"]:
            status = MetricStatus.FAIL_BLOCK
        elif self.counts["FAIL_WARN"]:
            status = MetricStatus.FAIL_WARN
        writer.bar_chart_from(
            self.name,
            ordered_counts(self.counts, METRIC_STATUSES, ("PASSED", "FAIL_WARN", "FAIL_BLOCK")),
            x_axis_name="Metric status",
            y_axis_name="Job metrics",
            status=status,
            description="Status of every metric of every job in the batch.",
        )


@dataclass
class PassRate(Aggregation[JobRecord]):
    """The share of jobs whose conflated status is PASSED, in percent."""

    name: str = "Pass rate"
    passed: int = field(default=0, init=False)
    jobs: int = field(default=0, init=False)

    def update(self, job: JobRecord) -> None:
        self.jobs += 1
        self.passed += job.conflated_status == "PASSED"

    def merge(self, other: Self) -> None:
        self.passed += other.passed
        self.jobs += other.jobs

    def finish(self, writer: MetricsWriter) -> None:
        if not self.jobs:
            return
        writer.scalar(
            self.name,
            100.0 * self.passed / self.jobs,
            unit="%",
            description=f"{self.passed} of {self.jobs} jobs passed.",
        )


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
