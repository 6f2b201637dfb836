"""A parameter sweep: each scalar metric's mean per value of the jobs' parameters, as a
Markdown table and as a line per metric and parameter."""

from __future__ import annotations

import math
from array import array
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Self

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs, exact_mean, pick_unit

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
