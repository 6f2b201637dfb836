"""Mean of a scalar job metric, optionally weighted by another scalar of the same job."""

from __future__ import annotations

import math
from array import array
from collections import Counter
from dataclasses import dataclass, field
from typing import Self

from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs, exact_sum, pick_unit


@dataclass
class WeightedMean(Aggregation[JobRecord]):
    """``sum(w * x) / sum(w)`` over the jobs that report both `metric` and `weight`.

    Without a weight every job weighs 1. Jobs that report the metric but not the
    weight are left out and counted in the metric's description.
    """

    name: str
    metric: str
    weight: str | None = None
    unit: str | None = None

    # Terms are kept (16 bytes a job) and summed with fsum at the end: the result is
    # then correctly rounded and independent of the order jobs arrive in.
    products: array[float] = field(default_factory=lambda: array("d"), init=False)
    weights: array[float] = field(default_factory=lambda: array("d"), init=False)
    jobs: int = field(default=0, init=False)
    jobs_without_weight: int = field(default=0, init=False)
    jobs_not_finite: int = field(default=0, init=False)
    units: Counter[str] = field(default_factory=Counter, init=False)

    def needs(self) -> Needs:
        names = {self.metric} | ({self.weight} if self.weight else set())
        return Needs(scalars=frozenset(names))

    def update(self, job: JobRecord) -> None:
        x = job.scalars.get(self.metric)
        if x is None:
            return
        w = 1.0
        if self.weight is not None:
            weight = job.scalars.get(self.weight)
            if weight is None:
                self.jobs_without_weight += 1
                return
            w = weight.value
        if not (math.isfinite(w) and math.isfinite(x.value)):
            self.jobs_not_finite += 1
            return
        self.products.append(w * x.value)
        self.weights.append(w)
        self.jobs += 1
        self.units[x.unit] += 1

    def merge(self, other: Self) -> None:
        self.products.extend(other.products)
        self.weights.extend(other.weights)
        self.jobs += other.jobs
        self.jobs_without_weight += other.jobs_without_weight
        self.jobs_not_finite += other.jobs_not_finite
        self.units.update(other.units)

    @property
    def value(self) -> float | None:
        weight_sum = exact_sum(self.weights)
        if weight_sum == 0:
            return None
        return exact_sum(self.products) / weight_sum

    def finish(self, writer: MetricsWriter) -> None:
        value = self.value
        how = f"weighted by {self.weight!r}" if self.weight else "unweighted"
        if value is None or not math.isfinite(value):
            writer.text(
                self.name,
                f"No job reported both {self.metric!r} and a non-zero weight; nothing to average.",
                status=MetricStatus.NOT_APPLICABLE,
            )
            return
        note = ""
        if self.jobs_without_weight:
            note += f"; {self.jobs_without_weight} jobs without {self.weight!r} left out"
        if self.jobs_not_finite:
            note += f"; {self.jobs_not_finite} jobs with non-finite values left out"
        writer.scalar(
            self.name,
            value,
            unit=self.unit if self.unit is not None else pick_unit(self.units),
            description=f"Mean of {self.metric!r} over {self.jobs} jobs, {how}{note}.",
        )
