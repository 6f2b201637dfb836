"""Every scalar metric across the report's batches: its line over time, its spread per batch.

`ScalarLines` draws ``N over time`` for every SCALAR batch metric with the regression
verdict on its latest batch (`RegressionSummary` gathers the verdicts);
`JobScalarDistributions` shows, for every SCALAR job metric, how its values spread across
each batch's jobs, over time.
"""

from __future__ import annotations

import uuid
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, BatchRecord, Needs, pick_unit
from stook.sdk.aggregations.report._change_points import (
    DEFAULT_PENALTY,
    MIN_BASELINE,
    Shift,
    Verdict,
    check,
    fitted_levels,
    level_shifts,
)
from stook.sdk.aggregations.report._timeline import BatchPoint, api_status, axis, axis_name


@dataclass(frozen=True, slots=True)
class _Value:
    point: BatchPoint
    value: float
    status: str


@dataclass(frozen=True, slots=True)
class RegressionSummary:
    """The verdict on the latest batch, as the ``Regressions`` text metric says it.

    `moved` names the batch metrics that moved, in name order; empty when none did.
    """

    status: MetricStatus
    text: str
    moved: tuple[str, ...] = ()


@dataclass
class ScalarLines(Aggregation[BatchRecord]):
    """A LINE_PLOT ``N over time`` per SCALAR batch metric ``N``: its value in each batch
    that has it (gaps stay gaps), by creation time, with each batch's status.

    The latest batch is compared with the median and MAD of up to `window` batches
    before it; past `threshold` robust deviations the line's status is FAIL_WARN.
    A TEXT metric ``Regressions`` says what moved, by how much, since which batch.

    With `change_points`, a line whose level moved within the report (penalised change
    points, see `level_shifts`; `change_penalty` multiplies ln n in the penalty) gets a
    second series, ``level``: the mean of each stretch between change points, its point
    FAIL_WARN at the first batch of each new level. `ChangePoints` says it in words.
    """

    name: str = "Regressions"
    window: int = 10
    threshold: float = 3.5
    change_points: bool = True
    change_penalty: float = DEFAULT_PENALTY

    values: dict[str, dict[uuid.UUID, _Value]] = field(default_factory=dict, init=False)
    units: dict[str, Counter[str]] = field(default_factory=dict, init=False)
    batches: set[BatchPoint] = field(default_factory=set, init=False)

    def __post_init__(self) -> None:
        if self.window < 1 or self.threshold <= 0:
            raise ValueError("window must be at least 1 and threshold positive")
        if self.change_penalty <= 0:
            raise ValueError("change_penalty must be positive")

    def needs(self) -> Needs:
        return Needs(every_scalar=True)  # every SCALAR batch metric

    def update(self, record: BatchRecord) -> None:
        point = BatchPoint(record.created, record.batch_id, record.name)
        self.batches.add(point)
        for metric, scalar in record.scalars.items():
            self.values.setdefault(metric, {})[record.batch_id] = _Value(
                point, scalar.value, scalar.status
            )
            self.units.setdefault(metric, Counter())[scalar.unit] += 1

    def merge(self, other: Self) -> None:
        self.batches |= other.batches
        for metric, by_batch in other.values.items():
            self.values.setdefault(metric, {}).update(by_batch)
        for metric, units in other.units.items():
            self.units.setdefault(metric, Counter()).update(units)

    def verdicts(self) -> dict[str, tuple[Verdict, list[_Value]]]:
        latest = max(self.batches) if self.batches else None
        out = {}
        for metric in sorted(self.values):
            series = sorted(self.values[metric].values(), key=lambda v: v.point)
            if latest is not None and series[-1].point != latest:
                # Judging an older batch would report it as "moved in the latest batch".
                verdict = Verdict(
                    None,
                    series[-1].value,
                    reason=f"the latest batch ({latest.name}) does not report it",
                )
            else:
                verdict = check(
                    [v.value for v in series], window=self.window, threshold=self.threshold
                )
            out[metric] = (verdict, series)
        return out

    def finish(self, writer: MetricsWriter) -> None:
        if not self.batches:
            return
        origin = min(self.batches).created
        verdicts = self.verdicts()
        for metric, (verdict, series) in verdicts.items():
            unit = pick_unit(self.units[metric])
            label = f"{metric} over time"
            times, x = axis(label, origin, [v.point for v in series])
            y = _data.doubles(label, [v.value for v in series], unit=unit, index=times)
            statuses = _data.statuses(
                f"{label} (statuses)", [api_status(v.status) for v in series], index=times
            )
            xs, ys, all_statuses, legend = [x], [y], [statuses], [metric]
            description = _describe(metric, verdict, series, unit)
            shifts = self._shifts(series)
            if shifts:
                starts = {s.index for s in shifts}
                xs.append(x)
                ys.append(
                    _data.doubles(
                        f"{label} (level)",
                        fitted_levels(len(series), shifts),
                        unit=unit,
                        index=times,
                    )
                )
                all_statuses.append(
                    _data.statuses(
                        f"{label} (level statuses)",
                        [
                            MetricStatus.FAIL_WARN if i in starts else MetricStatus.PASSED
                            for i in range(len(series))
                        ],
                        index=times,
                    )
                )
                legend.append("level")
                description += " " + " ".join(_describe_shift(s, series, unit) for s in shifts)
            writer.line_plot(
                label,
                xs,
                ys,
                statuses=all_statuses,
                x_axis_name=axis_name(origin),
                y_axis_name=f"{metric} [{unit}]" if unit else metric,
                legend=legend,
                status=MetricStatus.FAIL_WARN if verdict.regressed else MetricStatus.PASSED,
                description=description,
            )
        summary = self.regressions()
        if summary is not None:
            writer.text(self.name, summary.text, status=summary.status)

    def _shifts(self, series: list[_Value]) -> list[Shift]:
        if not self.change_points:
            return []
        return level_shifts([v.value for v in series], factor=self.change_penalty)

    def regressions(self) -> RegressionSummary | None:
        """What the latest batch did against its baseline; None before any batch."""
        if not self.batches:
            return None
        latest = max(self.batches)
        if len(self.batches) == 1:
            return RegressionSummary(
                MetricStatus.NOT_APPLICABLE,
                f"Only one batch in the report ({latest.name}): no regression verdict.",
            )
        verdicts = self.verdicts()
        moved = {
            m: _describe(m, v, s, pick_unit(self.units[m]))
            for m, (v, s) in verdicts.items()
            if v.regressed
        }
        judged = sum(v.regressed is not None for v, _ in verdicts.values())
        if moved:
            return RegressionSummary(
                MetricStatus.FAIL_WARN,
                f"{len(moved)} of {judged} batch metrics moved in the latest batch "
                f"({latest.name}, {latest.created:%Y-%m-%d %H:%M} UTC):\n"
                + "\n".join(f"- {line}" for line in moved.values()),
                moved=tuple(moved),
            )
        if judged == 0:
            return RegressionSummary(
                MetricStatus.NOT_APPLICABLE,
                f"No regression verdict: no batch metric has {MIN_BASELINE} or more earlier "
                "batches to compare the latest one with.",
            )
        return RegressionSummary(
            MetricStatus.PASSED,
            f"No regression: in the latest batch ({latest.name}) all {judged} judged batch "
            f"metrics are within {self.threshold:g} robust deviations of the median of "
            f"up to {self.window} earlier batches.",
        )


def _describe(metric: str, verdict: Verdict, series: list[_Value], unit: str) -> str:
    u = f" {unit}" if unit else ""
    if verdict.regressed is None:
        return f"{metric!r}: no regression verdict ({verdict.reason})."
    first = series[verdict.baseline_span[0]].point
    since = series[verdict.baseline_span[1]].point
    relative = verdict.relative_change
    pct = f" ({relative:+.1%})" if relative is not None else ""
    state = "moved" if verdict.regressed else "is stable"
    return (
        f"{metric!r} {state}: {verdict.latest:.6g}{u} in {series[-1].point.name} against a "
        f"median of {verdict.baseline_median:.6g}{u} (MAD {verdict.baseline_mad:.3g}) over "
        f"{verdict.baseline_size} batches from {first.name} to {since.name}: "
        f"{verdict.change:+.6g}{u}{pct}, {verdict.deviations:.1f} robust deviations, "
        f"since batch {since.name} ({since.created:%Y-%m-%d})."
    )


def _describe_shift(shift: Shift, series: list[_Value], unit: str) -> str:
    u = f" {unit}" if unit else ""
    at = series[shift.index].point
    relative = shift.relative_change
    pct = f" ({relative:+.1%})" if relative is not None else ""
    return (
        f"Level moved at {at.name} ({at.created:%Y-%m-%d}): "
        f"{shift.before:.6g}{u} -> {shift.after:.6g}{u}{pct}."
    )


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
