"""Mean, min, max and quantiles of a scalar job metric across the jobs of a batch."""

from __future__ import annotations

import math
import re
from array import array
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Self

from stook.sdk._errors import WriterError
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs, exact_mean, pick_unit

if TYPE_CHECKING:
    pass

_QUANTILE = re.compile(r"^p(\d{1,2}(?:\.\d+)?)$")
_PLAIN = ("mean", "min", "max", "std", "count")


def _check_stats(stats: Sequence[str]) -> None:
    for stat in stats:
        if stat not in _PLAIN and not _QUANTILE.match(stat):
            raise WriterError(
                f"unknown statistic {stat!r}: use {', '.join(_PLAIN)} or a quantile like p50, p95"
            )


@dataclass
class ScalarStats(Aggregation[JobRecord]):
    """Statistics of one scalar job metric, each written as a SCALAR named ``metric (stat)``.

    One value per job is kept (8 bytes each), so quantiles are exact.
    """

    metric: str
    stats: Sequence[str] = ("mean", "min", "max", "p50", "p95")
    name: str = ""
    unit: str | None = None

    values: array[float] = field(default_factory=lambda: array("d"), init=False)
    not_finite: int = field(default=0, init=False)
    units: Counter[str] = field(default_factory=Counter, init=False)

    def __post_init__(self) -> None:
        _check_stats(self.stats)
        self.name = self.name or self.metric

    def needs(self) -> Needs:
        return Needs(scalars=frozenset({self.metric}))

    def update(self, job: JobRecord) -> None:
        x = job.scalars.get(self.metric)
        if x is None:
            return
        if not math.isfinite(x.value):
            self.not_finite += 1
            return
        self.values.append(x.value)
        self.units[x.unit] += 1

    def merge(self, other: Self) -> None:
        self.values.extend(other.values)
        self.not_finite += other.not_finite
        self.units.update(other.units)

    def compute(self) -> dict[str, float]:
        """Each statistic's value; empty when no job reported the metric."""
        if not self.values:
            return {}
        import polars as pl

        # Sorted, so that the result does not depend on the order jobs arrived in.
        s = pl.Series(self.metric, self.values, dtype=pl.Float64).sort()
        out: dict[str, float] = {}
        for stat in self.stats:
            match = _QUANTILE.match(stat)
            if match:
                q = s.quantile(float(match.group(1)) / 100, interpolation="linear")
            elif stat == "count":
                q = float(s.len())
            elif stat == "std":
                q = float(s.std()) if s.len() > 1 else 0.0  # type: ignore[arg-type]
            elif stat == "mean":
                q = exact_mean(self.values)
            else:
                q = float(getattr(s, stat)())
            out[stat] = float(q or 0.0)
        return out

    def finish(self, writer: MetricsWriter) -> None:
        unit = self.unit if self.unit is not None else pick_unit(self.units)
        for stat, value in self.compute().items():
            name = f"{self.name} ({stat})"
            if writer.has_metric(name):
                # The default batch metrics already wrote "N (mean)": the same number.
                continue
            writer.scalar(
                name,
                value,
                unit="" if stat == "count" else unit,
                description=f"{stat} of {self.metric!r} over {len(self.values)} jobs"
                + (f" ({self.not_finite} non-finite values left out)." if self.not_finite else "."),
            )
