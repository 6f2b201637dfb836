"""Pass rate and scalar means per experience tag: a BAR_CHART each, a bar per tag."""

from __future__ import annotations

import math
from array import array
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Self

from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs, exact_mean, pick_unit

#: the bar of the jobs whose experience has no tag
UNTAGGED = "(untagged)"


@dataclass
class ByExperienceTag(Aggregation[JobRecord]):
    """Per experience tag: the share of its jobs that PASSED, and each of `metrics`' mean.

    A job counts under every tag of its experience, and under ``(untagged)`` when its
    experience has none. Tags are sorted, ``(untagged)`` last. Writes BAR_CHARTs
    ``<name>`` (pass rate, %) and ``<metric> (mean) by experience tag`` per metric
    (over the tag's jobs that have the scalar; NaN and infinite values left out).
    """

    metrics: Sequence[str] = ()
    name: str = "Pass rate by experience tag"

    jobs: Counter[str] = field(default_factory=Counter, init=False)
    passed: Counter[str] = field(default_factory=Counter, init=False)
    values: dict[str, dict[str, array[float]]] = field(default_factory=dict, init=False)
    units: dict[str, Counter[str]] = field(default_factory=dict, init=False)

    def __post_init__(self) -> None:
        if len(set(self.metrics)) != len(self.metrics):
            raise ValueError("'metrics' names one twice")

    def needs(self) -> Needs:
        return Needs(experience_tags=True, scalars=frozenset(self.metrics))

    def update(self, job: JobRecord) -> None:
        tags = sorted(set(job.experience_tags)) or [UNTAGGED]
        passed = job.conflated_status == "PASSED"
        for tag in tags:
            self.jobs[tag] += 1
            self.passed[tag] += passed
        for metric in self.metrics:
            scalar = job.scalars.get(metric)
            if scalar is None or not math.isfinite(scalar.value):
                continue
            self.units.setdefault(metric, Counter())[scalar.unit] += 1
            by_tag = self.values.setdefault(metric, {})
            for tag in tags:
                by_tag.setdefault(tag, array("d")).append(scalar.value)

    def merge(self, other: Self) -> None:
        self.jobs.update(other.jobs)
        self.passed.update(other.passed)
        for metric, by_tag in other.values.items():
            mine = self.values.setdefault(metric, {})
            for tag, values in by_tag.items():
                mine.setdefault(tag, array("d")).extend(values)
        for metric, units in other.units.items():
            self.units.setdefault(metric, Counter()).update(units)

    def tags(self) -> list[str]:
        return sorted(self.jobs, key=lambda t: (t == UNTAGGED, t))

    def pass_rates(self) -> dict[str, float]:
        return {t: 100.0 * self.passed[t] / self.jobs[t] for t in self.tags()}

    def means(self, metric: str) -> dict[str, float]:
        by_tag = self.values.get(metric, {})
        return {t: exact_mean(by_tag[t]) for t in self.tags() if by_tag.get(t)}

    def finish(self, writer: MetricsWriter) -> None:
        if not self.jobs:
            writer.text(
                self.name, "The batch has no jobs to compare.", status=MetricStatus.NOT_APPLICABLE
            )
            return
        writer.bar_chart_from(
            self.name,
            self.pass_rates(),
            x_axis_name="Experience tag",
            y_axis_name="Jobs PASSED (%)",
            description="Share of the jobs of each experience tag whose status is PASSED.",
        )
        for metric in self.metrics:
            means = self.means(metric)
            if not means:
                continue
            unit = pick_unit(self.units.get(metric, Counter()))
            writer.bar_chart_from(
                f"{metric} (mean) by experience tag",
                means,
                x_axis_name="Experience tag",
                y_axis_name=f"{metric} (mean{', ' + unit if unit else ''})",
                description=f"Mean of {metric!r} over the jobs of each experience tag.",
            )
