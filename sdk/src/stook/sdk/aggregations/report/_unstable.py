"""Which experiences' scalar metrics vary most from batch to batch: the tests a team cannot
trust a single run of, whether or not their pass/fail outcome flips."""

from __future__ import annotations

import statistics
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Self

from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, BatchRecord, Needs
from stook.sdk.aggregations.report._change_points import noise_scale
from stook.sdk.aggregations.report._timeline import BatchPoint

if TYPE_CHECKING:
    import numpy as np

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
