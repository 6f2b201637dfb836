"""Scalar job metrics across the jobs of a batch, reduced per metric, per tag or per parameter.

`ScalarDefaults`, which every batch gets, writes every SCALAR job metric's mean and its
distribution across the batch's jobs. Configured: `ScalarStats` writes a metric's mean,
min, max and quantiles; `WeightedMean` its mean, optionally weighted by another scalar
of the same job; `ByExperienceTag` the pass rate and scalar means per experience tag (a
BAR_CHART each, a bar per tag); `ParameterSweep` each scalar metric's mean per value of
the jobs' parameters, as a Markdown table and as a line per metric and parameter.
"""

from __future__ import annotations

import math
import operator
import re
import struct
from array import array
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._errors import WriterError
from stook.sdk._writer import MetricsWriter, histogram_buckets
from stook.sdk.aggregations._base import (
    Aggregation,
    JobRecord,
    Needs,
    Scalar,
    exact_mean,
    exact_sum,
    pick_unit,
)
from stook.sdk.aggregations._columns import values_by_name

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


#: how a job without one of the parameters is shown in the table
UNSET = "(unset)"

# A combination of parameter values, None where the job does not have the parameter.
Key = tuple[str | None, ...]


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def value_order(values: Iterable[str]) -> list[str]:
    """A parameter's values sorted numerically when every one is a finite number
    (ties, like "1" and "1.0", by their text), else lexically."""
    distinct = set(values)
    numbers = {v: _number(v) for v in distinct}
    if all(n is not None for n in numbers.values()):
        return sorted(distinct, key=lambda v: (numbers[v], v))
    return sorted(distinct)


@dataclass
class ParameterSweep(Aggregation[JobRecord]):
    """Means of SCALAR job metrics per value of the jobs' parameters.

    Writes a TEXT ``<name>``: a Markdown table with a row per combination of the
    `parameters`' values that some job had, the number of jobs, and each of `metrics`'
    mean over the row's jobs that have it. Jobs without a parameter appear under
    ``(unset)``, after the values. Then for each metric and parameter whose values are
    all numbers, a LINE_PLOT ``<name>: <metric> by <parameter>`` of the metric's mean
    per value (over the other parameters; jobs without the parameter are left out),
    or a BAR_CHART of the same when a value is not a number. Values sort numerically
    when every value is a number, else lexically. NaN and infinite scalars are left out.
    """

    parameters: Sequence[str]
    metrics: Sequence[str]
    name: str = "Parameter sweep"

    # parameter-value combination → metric → values; and jobs per combination
    values: dict[Key, dict[str, array[float]]] = field(default_factory=dict, init=False)
    jobs: Counter[Key] = field(default_factory=Counter, init=False)
    units: dict[str, Counter[str]] = field(default_factory=dict, init=False)

    def __post_init__(self) -> None:
        for key in ("parameters", "metrics"):
            names = list(getattr(self, key))
            if not names:
                raise ValueError(f"{key!r} must name at least one")
            if len(set(names)) != len(names):
                raise ValueError(f"{key!r} names one twice")

    def needs(self) -> Needs:
        return Needs(scalars=frozenset(self.metrics))

    def update(self, job: JobRecord) -> None:
        key = tuple(job.parameters.get(p) for p in self.parameters)
        self.jobs[key] += 1
        row = self.values.setdefault(key, {})
        for metric in self.metrics:
            scalar = job.scalars.get(metric)
            if scalar is None or not math.isfinite(scalar.value):
                continue
            row.setdefault(metric, array("d")).append(scalar.value)
            self.units.setdefault(metric, Counter())[scalar.unit] += 1

    def merge(self, other: Self) -> None:
        self.jobs.update(other.jobs)
        for key, row in other.values.items():
            mine = self.values.setdefault(key, {})
            for metric, values in row.items():
                mine.setdefault(metric, array("d")).extend(values)
        for metric, units in other.units.items():
            self.units.setdefault(metric, Counter()).update(units)

    def _sorted_keys(self) -> list[Key]:
        orders = []
        for p in range(len(self.parameters)):
            present = [v for k in self.jobs if (v := k[p]) is not None]
            orders.append({v: i for i, v in enumerate(value_order(present))})
        # An unset value sorts after every value of its parameter.
        return sorted(
            self.jobs,
            key=lambda k: [len(o) if v is None else o[v] for v, o in zip(k, orders, strict=True)],
        )

    def table(self) -> str:
        """The Markdown table of the TEXT metric."""
        heads = [*self.parameters, "jobs", *(self._head(m) for m in self.metrics)]
        lines = ["| " + " | ".join(map(_cell, heads)) + " |", "|" + "---|" * len(heads)]
        for key in self._sorted_keys():
            row = self.values.get(key, {})
            cells = [UNSET if v is None else v for v in key]
            cells.append(str(self.jobs[key]))
            cells += [f"{exact_mean(row[m]):.6g}" if row.get(m) else "–" for m in self.metrics]
            lines.append("| " + " | ".join(map(_cell, cells)) + " |")
        return "\n".join(lines)

    def _head(self, metric: str) -> str:
        unit = pick_unit(self.units.get(metric, Counter()))
        return f"{metric} (mean{', ' + unit if unit else ''})"

    def means_by(self, parameter: str, metric: str) -> dict[str, float]:
        """metric's mean per value of one parameter, over jobs that have both; sorted."""
        p = list(self.parameters).index(parameter)
        pooled: dict[str, list[float]] = {}
        for key, row in self.values.items():
            if (value := key[p]) is not None and row.get(metric):
                pooled.setdefault(value, []).extend(row[metric])
        return {v: exact_mean(pooled[v]) for v in value_order(pooled)}

    def finish(self, writer: MetricsWriter) -> None:
        if not self.jobs:
            writer.text(
                self.name, "The batch has no jobs to compare.", status=MetricStatus.NOT_APPLICABLE
            )
            return
        writer.text(
            self.name,
            f"Means per value of {', '.join(self.parameters)} over "
            f"{sum(self.jobs.values())} jobs.\n\n{self.table()}\n",
            description="Each metric's mean over the jobs of each row that have it.",
        )
        for metric in self.metrics:
            unit = pick_unit(self.units.get(metric, Counter()))
            for parameter in self.parameters:
                self._plot(writer, metric, parameter, unit)

    def _plot(self, writer: MetricsWriter, metric: str, parameter: str, unit: str) -> None:
        means = self.means_by(parameter, metric)
        if not means:
            return
        name = f"{self.name}: {metric} by {parameter}"
        y_axis = f"{metric} (mean{', ' + unit if unit else ''})"
        description = f"Mean of {metric!r} per value of parameter {parameter!r}."
        xs = [_number(v) for v in means]
        if any(x is None for x in xs):
            writer.bar_chart_from(
                name, means, x_axis_name=parameter, y_axis_name=y_axis, description=description
            )
            return
        # Values that are one number ("1", "1.0") are one point, their jobs pooled.
        pooled: dict[float, list[str]] = {}
        for value, x in zip(means, xs, strict=True):
            assert x is not None
            pooled.setdefault(x, []).append(value)
        ys = [self._pooled_mean(parameter, metric, texts) for texts in pooled.values()]
        writer.line_plot(
            name,
            _data.doubles(f"{name} ({parameter})", list(pooled)),
            _data.doubles(f"{name} ({metric})", ys),
            x_axis_name=parameter,
            y_axis_name=y_axis,
            legend=[metric],
            description=description,
        )

    def _pooled_mean(self, parameter: str, metric: str, texts: list[str]) -> float:
        p = list(self.parameters).index(parameter)
        return exact_mean(
            [v for key, row in self.values.items() if key[p] in texts for v in row.get(metric, [])]
        )


def _cell(text: str) -> str:
    """A table cell: a '|' or a line break inside would end it."""
    return text.replace("|", "\\|").replace("\n", " ")


def auto_buckets(low: float, high: float, count: int) -> tuple[float, float, int]:
    """Bounds and a bucket count that cover [low, high]: about sqrt(count) buckets, 1..20,
    fewer where the range is too narrow (or too wide) for distinct floating-point edges."""
    if low == high:
        half = max(abs(low) * 0.05, 0.5)
        lo, hi = low - half, high + half
        if not (math.isfinite(lo) and math.isfinite(hi)):
            lo, hi = math.nextafter(low, -math.inf), math.nextafter(high, math.inf)
        return lo, hi, 1
    buckets = max(1, min(20, math.ceil(math.sqrt(count))))
    while buckets > 1:
        try:
            histogram_buckets("auto", buckets, low, high)
            break
        except WriterError:
            buckets //= 2
    return low, high, buckets


_BATCH = 256
_VALUE = operator.attrgetter("value")
_UNIT = operator.attrgetter("unit")


@dataclass
class _Column:
    values: array[float] = field(default_factory=lambda: array("d"))
    units: Counter[str] = field(default_factory=Counter)


def _count_units(counts: Counter[str], units: list[str]) -> None:
    """`counts.update(units)`. A metric's scalars nearly always share one unit: then
    counted by one comparison each (a Counter hashes and looks up each, ~5x the cost)."""
    if units and units.count(units[0]) == len(units):
        counts[units[0]] += len(units)
    else:
        counts.update(units)


def _sorted_finite(values: array[float]) -> list[float]:
    """The finite values, sorted, and -0.0 made 0.0 (they compare equal, so sorting keeps
    arrival order): the output must not depend on the order jobs arrived in."""
    # The common case in C loops: a sum is finite only when every value is, and with no
    # zero there is no -0.0 to make 0.0 (-0.0 == 0.0, so `in` finds either).
    if math.isfinite(sum(values)) and 0.0 not in values:
        return sorted(values)
    return sorted(v + 0.0 for v in values if math.isfinite(v))


@dataclass
class ScalarDefaults(Aggregation[JobRecord]):
    """Writes ``N (mean)`` (a SCALAR, unit carried over) and ``N (distribution)`` (a
    HISTOGRAM of the per-job values) for every SCALAR job metric ``N`` in the batch."""

    name: str = "(mean) and (distribution) of every scalar"
    columns: dict[str, _Column] = field(default_factory=dict, init=False)
    # Jobs' scalars wait here and join `columns` _BATCH jobs at a time, a metric at a
    # time, in C loops (map, filter): a Python loop over every job's scalars cost ~5x.
    waiting: list[Mapping[str, Scalar]] = field(default_factory=list, init=False)

    def needs(self) -> Needs:
        return Needs(every_scalar=True)

    def update(self, job: JobRecord) -> None:
        self.waiting.append(job.scalars)
        if len(self.waiting) >= _BATCH:
            self._add_waiting()

    def _add_waiting(self) -> None:
        """Add the waiting jobs' scalars to `columns`, in the order the jobs came."""
        waiting, self.waiting = self.waiting, []
        metrics = list(set().union(*waiting))
        for metric, column in zip(metrics, values_by_name(waiting, metrics), strict=True):
            # The jobs without `metric` left out (a Scalar is never false).
            found = list(filter(None, column))
            mine = self.columns.get(metric)
            if mine is None:
                mine = self.columns[metric] = _Column()
            # Packed by struct, then copied in: array.extend converts each value through
            # a format parser (~4x the cost a value).
            mine.values.frombytes(struct.pack(f"={len(found)}d", *map(_VALUE, found)))
            _count_units(mine.units, list(map(_UNIT, found)))

    def __getstate__(self) -> dict[str, object]:
        """What travels between processes (see `Aggregation`): the columns, the waiting
        jobs added to them first."""
        self._add_waiting()
        return dict(self.__dict__)

    def merge(self, other: Self) -> None:
        self._add_waiting()
        other._add_waiting()
        for metric, theirs in other.columns.items():
            mine = self.columns.setdefault(metric, _Column())
            mine.values.extend(theirs.values)
            mine.units.update(theirs.units)

    def finish(self, writer: MetricsWriter) -> None:

        self._add_waiting()
        for metric in sorted(self.columns):
            column = self.columns[metric]
            values = column.values
            finite = _sorted_finite(values)
            unit = pick_unit(column.units)
            if not finite:
                continue
            writer.scalar(
                f"{metric} (mean)",
                exact_mean(finite),
                unit=unit,
                description=f"Mean of {metric!r} over the {len(finite)} jobs that reported it.",
            )
            low, high, buckets = auto_buckets(min(finite), max(finite), len(finite))
            writer.histogram(
                f"{metric} (distribution)",
                _data.doubles(f"{metric} (distribution) values", finite, unit=unit),
                buckets=buckets,
                lower=low,
                upper=high,
                x_axis_name=f"{metric} [{unit}]" if unit else metric,
                description=f"{metric!r} of each of the {len(finite)} jobs that reported it.",
            )
