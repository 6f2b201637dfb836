"""For every SCALAR job metric: how its values spread across each batch's jobs, over time."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, BatchRecord, Needs, pick_unit
from stook.sdk.aggregations.report._timeline import BatchPoint, axis, axis_name

QUANTILES = (("p10", 0.10), ("median", 0.50), ("p90", 0.90))


def quantile(sorted_values: Sequence[float], q: float) -> float:
    """Linear interpolation between closest ranks (numpy's default, polars' "linear")."""
    position = q * (len(sorted_values) - 1)
    low = int(position)
    high = min(low + 1, len(sorted_values) - 1)
    return sorted_values[low] + (sorted_values[high] - sorted_values[low]) * (position - low)


@dataclass(frozen=True, slots=True)
class _Summary:
    jobs: int
    quantiles: tuple[float, ...]


@dataclass
class JobScalarDistributions(Aggregation[BatchRecord]):
    """A LINE_PLOT ``N per batch`` for every SCALAR job metric ``N`` (or those in
    `metrics`): the 10th percentile, median and 90th percentile of its values across each
    batch's jobs, by batch creation time. Batches without the metric leave a gap."""

    name: str = "job metric distributions"
    metrics: Sequence[str] | None = None

    summaries: dict[str, dict[BatchPoint, _Summary]] = field(default_factory=dict, init=False)
    units: dict[str, Counter[str]] = field(default_factory=dict, init=False)
    batches: set[BatchPoint] = field(default_factory=set, init=False)

    def needs(self) -> Needs:
        return Needs(
            job_metrics=True,
            scalars=frozenset(self.metrics or ()),
            every_scalar=self.metrics is None,
        )

    def update(self, record: BatchRecord) -> None:
        point = BatchPoint(record.created, record.batch_id, record.name)
        self.batches.add(point)
        import numpy as np

        wanted = set(self.metrics) if self.metrics is not None else None
        columns = record.job_columns()
        for metric in columns.metrics():
            if wanted is not None and metric not in wanted:
                continue
            values = columns.values(metric)
            # + 0.0: -0.0 and 0.0 are one value
            finite: list[float] = np.sort(values[np.isfinite(values)] + 0.0).tolist()
            if not finite:
                continue
            self.summaries.setdefault(metric, {})[point] = _Summary(
                len(finite), tuple(quantile(finite, q) for _, q in QUANTILES)
            )
            self.units.setdefault(metric, Counter())[record.job_scalar_units.get(metric, "")] += 1

    def merge(self, other: Self) -> None:
        self.batches |= other.batches
        for metric, by_batch in other.summaries.items():
            self.summaries.setdefault(metric, {}).update(by_batch)
        for metric, units in other.units.items():
            self.units.setdefault(metric, Counter()).update(units)

    def finish(self, writer: MetricsWriter) -> None:
        if not self.batches:
            return
        origin = min(self.batches).created
        for metric in sorted(self.summaries):
            by_batch = self.summaries[metric]
            points = sorted(by_batch)
            unit = pick_unit(self.units[metric])
            label = f"{metric} per batch"
            times, x = axis(label, origin, points)
            ys = [
                _data.doubles(
                    f"{label} ({q_name})",
                    [by_batch[p].quantiles[i] for p in points],
                    unit=unit,
                    index=times,
                )
                for i, (q_name, _) in enumerate(QUANTILES)
            ]
            statuses = _data.status_like(ys[0], MetricStatus.PASSED, name=f"{label} (statuses)")
            writer.line_plot(
                label,
                [x] * len(ys),
                ys,
                statuses=[statuses] * len(ys),
                x_axis_name=axis_name(origin),
                y_axis_name=f"{metric} [{unit}]" if unit else metric,
                legend=[q for q, _ in QUANTILES],
                description=(
                    f"10th percentile, median and 90th percentile of {metric!r} across each "
                    f"batch's jobs ({sum(s.jobs for s in by_batch.values())} job values in "
                    f"{len(points)} batches)."
                ),
            )
