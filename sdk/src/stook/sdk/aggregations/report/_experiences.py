"""Which experiences fail most, which flip between passing and failing, which vary most.

`MostFailedExperiences` and `FlakyExperiences` read each experience's pass/fail outcome
per batch; `UnstableExperiences` reads its scalar metrics, for the tests a team cannot
trust a single run of, whether or not their pass/fail outcome flips.
"""

from __future__ import annotations

import itertools
import statistics
import uuid
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Self

from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, BatchRecord, Needs
from stook.sdk.aggregations.report._change_points import noise_scale
from stook.sdk.aggregations.report._timeline import BatchPoint, counts, first_seen, status_in

if TYPE_CHECKING:
    import numpy as np


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


#: batches an experience must have a metric in before its spread is judged
MIN_BATCHES = 4


def _medians(groups: np.ndarray, values: np.ndarray) -> list[tuple[int, float]]:
    """The median of each group's finite values (-0.0 as 0.0), as `statistics.median`
    takes it: the middle value, or the mean of the middle two, (a + b) / 2."""
    import numpy as np

    finite = np.isfinite(values)
    values, groups = values[finite] + 0.0, groups[finite]
    if not len(values):
        return []
    order = np.lexsort((values, groups))
    values, groups = values[order], groups[order]
    starts = np.flatnonzero(np.concatenate(([True], groups[1:] != groups[:-1])))
    sizes = np.diff(np.concatenate((starts, [len(values)])))
    middle = starts + sizes // 2
    with np.errstate(over="ignore"):
        # For odd sizes the pair's mean is unused (its first index may even wrap).
        pairs = (values[middle - 1] + values[middle]) / 2
    medians = np.where(sizes % 2 == 1, values[middle], pairs)
    return list(zip(groups[starts].tolist(), medians.tolist(), strict=True))


@dataclass(frozen=True, slots=True)
class Instability:
    """How much one experience's metric varies: `spread` is the batch-to-batch noise
    scale (`noise_scale` of its per-batch values) relative to their median magnitude."""

    experience: str
    metric: str
    spread: float
    level: float
    batches: int


@dataclass
class UnstableExperiences(Aggregation[BatchRecord]):
    """A BAR_CHART ``Unstable experiences``: experiences ranked by how much their SCALAR
    job metrics (or those in `metrics`) vary from batch to batch relative to their level,
    top `top_n`, and a TEXT ``Unstable experiences (details)`` naming the metric that
    drives each.

    An experience's value of a metric in a batch is the median over its jobs there. Its
    spread is the robust noise scale of those values in creation order (successive
    differences, the largest tenth left out, so that one step change is not instability)
    divided by the median of their magnitudes; it needs `MIN_BATCHES` batches, and a
    metric whose values are 0 at the median has no relative spread. An experience's
    score is its largest spread over its metrics.
    """

    name: str = "Unstable experiences"
    top_n: int = 10
    metrics: Sequence[str] | None = None

    points: dict[uuid.UUID, BatchPoint] = field(default_factory=dict, init=False)
    values: dict[str, dict[str, dict[uuid.UUID, float]]] = field(default_factory=dict, init=False)

    def __post_init__(self) -> None:
        if self.top_n < 1:
            raise ValueError("top_n must be at least 1")

    def needs(self) -> Needs:
        return Needs(
            job_metrics=True,
            scalars=frozenset(self.metrics or ()),
            every_scalar=self.metrics is None,
        )

    def update(self, record: BatchRecord) -> None:
        self.points[record.batch_id] = BatchPoint(record.created, record.batch_id, record.name)
        wanted = set(self.metrics) if self.metrics is not None else None
        columns = record.job_columns()
        names, codes = columns.experience_names()
        for metric, column in columns.scalars.items():
            if wanted is not None and metric not in wanted:
                continue
            for code, median in _medians(codes[column.jobs], column.values):
                self.values.setdefault(names[code], {}).setdefault(metric, {})[record.batch_id] = (
                    median
                )

    def merge(self, other: Self) -> None:
        self.points.update(other.points)
        for experience, by_metric in other.values.items():
            mine = self.values.setdefault(experience, {})
            for metric, by_batch in by_metric.items():
                mine.setdefault(metric, {}).update(by_batch)

    def ranking(self) -> list[Instability]:
        """Every judged experience at its most unstable metric, most unstable first."""
        ranked = []
        for experience, by_metric in self.values.items():
            worst: Instability | None = None
            for metric in sorted(by_metric):
                by_batch = by_metric[metric]
                if len(by_batch) < MIN_BATCHES:
                    continue
                ordered = [by_batch[b] for b in sorted(by_batch, key=self.points.__getitem__)]
                level = statistics.median(abs(v) for v in ordered)
                if level == 0:
                    continue
                spread = noise_scale(ordered) / level
                if worst is None or spread > worst.spread:
                    worst = Instability(experience, metric, spread, level, len(ordered))
            if worst is not None:
                ranked.append(worst)
        ranked.sort(key=lambda i: (-i.spread, i.experience))
        return ranked

    def finish(self, writer: MetricsWriter) -> None:
        if not self.points:
            return
        ranked = self.ranking()
        if not ranked:
            writer.text(
                self.name,
                f"No experience has a scalar job metric in {MIN_BATCHES} or more of the "
                f"report's {len(self.points)} batches: no batch-to-batch spread to rank.",
                status=MetricStatus.NOT_APPLICABLE,
            )
            return
        top = ranked[: self.top_n]
        writer.bar_chart_from(
            self.name,
            {i.experience: 100.0 * i.spread for i in top},
            x_axis_name="Experience",
            y_axis_name="Batch-to-batch spread [% of level]",
            description=(
                f"Experiences by how much their most variable scalar job metric moves from "
                f"batch to batch (robust noise scale over its median); top {len(top)} of "
                f"{len(ranked)} judged. The metric behind each: {self.name} (details)."
            ),
        )
        rows = [
            f"| {i.experience} | {i.metric} | {i.spread:.1%} | {i.level:.4g} | {i.batches} |"
            for i in top
        ]
        writer.text(
            f"{self.name} (details)",
            "| Experience | Metric | Spread | Median | Batches |\n|---|---|---|---|---|\n"
            + "\n".join(rows),
        )
