"""Which experiences fail most, and which flip between passing and failing."""

from __future__ import annotations

import itertools
import uuid
from collections import Counter
from dataclasses import dataclass, field
from typing import Self

from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, BatchRecord
from stook.sdk.aggregations.report._job_groups import counts, first_seen, status_in
from stook.sdk.aggregations.report._timeline import BatchPoint

# Any other status (CANCELLED, one this release does not know, UNKNOWN) is neither.
FAILED = frozenset({"BLOCKER", "ERROR"})
PASSED = frozenset({"PASSED", "WARNING"})


def _ranked(counts: dict[str, int], top_n: int) -> dict[str, float]:
    ranked = sorted(((-n, name) for name, n in counts.items() if n > 0))[:top_n]
    return {name: float(-n) for n, name in ranked}


@dataclass
class MostFailedExperiences(Aggregation[BatchRecord]):
    """A BAR_CHART of experiences ranked by how many of their jobs failed (conflated
    status BLOCKER or ERROR) across the report's batches, most first, top `top_n`."""

    name: str = "Most failed experiences"
    top_n: int = 10

    failures: Counter[str] = field(default_factory=Counter, init=False)
    seen: set[uuid.UUID] = field(default_factory=set, init=False)

    def update(self, record: BatchRecord) -> None:
        self.seen.add(record.batch_id)
        columns = record.job_columns()
        names, codes = columns.experience_names()
        failed = codes[status_in(columns, FAILED)]
        found = counts(failed, len(names))
        for code in first_seen(failed):
            self.failures[names[code]] += found[code]

    def merge(self, other: Self) -> None:
        self.failures.update(other.failures)
        self.seen |= other.seen

    def finish(self, writer: MetricsWriter) -> None:
        if not self.seen:
            return
        bars = _ranked(dict(self.failures), self.top_n)
        if not bars:
            writer.text(
                self.name,
                f"No job failed (BLOCKER or ERROR) in the report's {len(self.seen)} batches.",
            )
            return
        writer.bar_chart_from(
            self.name,
            bars,
            x_axis_name="Experience",
            y_axis_name="Failed jobs",
            status=MetricStatus.FAIL_WARN,
            description=(
                f"Failed jobs (BLOCKER or ERROR) per experience over {len(self.seen)} batches; "
                f"top {len(bars)} of {sum(1 for n in self.failures.values() if n)} that failed."
            ),
        )


@dataclass
class FlakyExperiences(Aggregation[BatchRecord]):
    """A BAR_CHART of experiences whose outcome flips between consecutive batches (by
    creation time), ranked by flips. An experience fails in a batch when any of its jobs
    is BLOCKER or ERROR, passes when all are PASSED or WARNING, and has no outcome else."""

    name: str = "Flaky experiences"
    top_n: int = 10

    outcomes: dict[str, dict[BatchPoint, bool]] = field(default_factory=dict, init=False)

    def update(self, record: BatchRecord) -> None:
        point = BatchPoint(record.created, record.batch_id, record.name)
        columns = record.job_columns()
        names, codes = columns.experience_names()
        jobs = counts(codes, len(names))
        failures = counts(codes[status_in(columns, FAILED)], len(names))
        passes = counts(codes[status_in(columns, PASSED)], len(names))
        for code in first_seen(codes):
            if failures[code]:
                failed = True
            elif passes[code] == jobs[code]:
                failed = False
            else:
                continue
            self.outcomes.setdefault(names[code], {})[point] = failed

    def merge(self, other: Self) -> None:
        for experience, by_batch in other.outcomes.items():
            self.outcomes.setdefault(experience, {}).update(by_batch)

    def flips(self) -> dict[str, int]:
        counts = {}
        for experience, by_batch in self.outcomes.items():
            ordered = [by_batch[p] for p in sorted(by_batch)]
            counts[experience] = sum(a != b for a, b in itertools.pairwise(ordered))
        return counts

    def finish(self, writer: MetricsWriter) -> None:
        if not self.outcomes:
            return
        bars = _ranked(self.flips(), self.top_n)
        if not bars:
            writer.text(
                self.name,
                "No experience flipped between passing and failing across consecutive batches.",
            )
            return
        writer.bar_chart_from(
            self.name,
            bars,
            x_axis_name="Experience",
            y_axis_name="Pass/fail flips",
            status=MetricStatus.FAIL_WARN,
            description=(
                "Times each experience's outcome changed between consecutive batches "
                "(failed: any job BLOCKER or ERROR; passed: all jobs PASSED or WARNING)."
            ),
        )
