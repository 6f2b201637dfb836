"""Which experiences' scalar metrics vary most from batch to batch: the tests a team cannot
trust a single run of, whether or not their pass/fail outcome flips."""

from __future__ import annotations

import math
import statistics
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Self

from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, Needs
from stook.sdk.aggregations._record import BatchRecord
from stook.sdk.aggregations.report._change_points import noise_scale
from stook.sdk.aggregations.report._timeline import BatchPoint

#: batches an experience must have a metric in before its spread is judged
MIN_BATCHES = 4


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
        per_experience: dict[str, dict[str, list[float]]] = {}
        for job in record.jobs:
            for metric, value in job.scalars.items():
                if (wanted is None or metric in wanted) and math.isfinite(value):
                    by_metric = per_experience.setdefault(job.experience_name, {})
                    by_metric.setdefault(metric, []).append(value + 0.0)
        for experience, by_metric in per_experience.items():
            for metric, found in by_metric.items():
                self.values.setdefault(experience, {}).setdefault(metric, {})[record.batch_id] = (
                    statistics.median(sorted(found))
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
