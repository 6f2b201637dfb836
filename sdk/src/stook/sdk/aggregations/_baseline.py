"""Compare a batch with a baseline batch: pass/fail per experience, pass rate, scalar means.

The candidate's jobs are folded in by `update` as every batch aggregation's are; the
baseline's by `update_baseline`, fed by a second fetch running alongside. What the
baseline is (or why there is none) and which way each metric is better come from the
service (`set_baseline` / `no_baseline`, `set_directions`). `result()` computes the
comparison (pure, deterministic: the bootstrap is seeded from the two batch IDs and the
metric's name) and `finish` writes it (`write_comparison`: the text, the flips chart,
the pass rate and metric charts). See docs/statistics.md for the statistics.
"""

from __future__ import annotations

import math
import uuid
from array import array
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime
from typing import Self

from stook.sdk import _data as data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs
from stook.sdk.stats import (
    Better,
    ComparisonVerdict,
    Interval,
    MeanDifference,
    bootstrap_mean_difference,
    comparison_verdict,
    holm_adjusted,
    mean_interval,
    newcombe_difference,
    seed_from,
    wilson_interval,
)

__all__ = [
    "BaselineComparison",
    "BaselineInfo",
    "ComparisonResult",
    "MetricComparison",
    "PassRateComparison",
]

_FAILED = frozenset({"WARNING", "BLOCKER", "ERROR"})
CORRECTIONS = ("holm", "none")


@dataclass(frozen=True, slots=True)
class BaselineInfo:
    """The batch compared with, and how it was chosen (for the text)."""

    batch_id: uuid.UUID
    friendly_name: str = ""
    build: str = ""
    created: datetime | None = None
    chosen_as: str = ""
    missing_jobs: int = 0


@dataclass(slots=True)
class _Experience:
    name: str
    passed: int = 0
    failed: int = 0
    values: dict[str, array[float]] = field(default_factory=dict)

    @property
    def outcome(self) -> str | None:
        """ "failed" if any job failed, "passed" if all counted jobs passed, else None."""
        if self.failed:
            return "failed"
        return "passed" if self.passed else None


@dataclass(slots=True)
class _Side:
    """One batch's jobs as the comparison needs them: per experience, outcomes and values."""

    jobs: int = 0
    passed: int = 0
    experiences: dict[str, _Experience] = field(default_factory=dict)
    # Per metric, the smallest job ID that has it: where its failure definition is read.
    example_jobs: dict[str, uuid.UUID] = field(default_factory=dict)

    def add(self, job: JobRecord, wanted: frozenset[str] | None) -> None:
        self.jobs += 1
        key = (
            str(job.experience_id)
            if job.experience_id is not None
            else (f"name:{job.experience_name}" if job.experience_name else f"job:{job.job_id}")
        )
        experience = self.experiences.get(key)
        if experience is None:
            experience = self.experiences[key] = _Experience(job.experience_name or key)
        if job.conflated_status == "PASSED":
            self.passed += 1
            experience.passed += 1
        elif job.conflated_status in _FAILED:
            experience.failed += 1
        for name, scalar in job.scalars.items():
            if (wanted is not None and name not in wanted) or not math.isfinite(scalar.value):
                continue
            experience.values.setdefault(name, array("d")).append(scalar.value)
            known = self.example_jobs.get(name)
            if known is None or job.job_id < known:
                self.example_jobs[name] = job.job_id

    def merge(self, other: _Side) -> None:
        self.jobs += other.jobs
        self.passed += other.passed
        for key, theirs in other.experiences.items():
            mine = self.experiences.setdefault(key, _Experience(theirs.name))
            mine.passed += theirs.passed
            mine.failed += theirs.failed
            for name, values in theirs.values.items():
                mine.values.setdefault(name, array("d")).extend(values)
        for name, job_id in other.example_jobs.items():
            known = self.example_jobs.get(name)
            if known is None or job_id < known:
                self.example_jobs[name] = job_id

    def metric_names(self) -> set[str]:
        return {n for e in self.experiences.values() for n in e.values}

    def values(self, metric: str) -> list[float]:
        # Sorted by experience key and kept in arrival order within one: the sort makes
        # the input to the (seeded) bootstrap independent of the order jobs arrived in.
        out: list[float] = []
        for key in sorted(self.experiences):
            out.extend(sorted(self.experiences[key].values.get(metric, ())))
        return out

    def experience_means(self, metric: str) -> dict[str, float]:
        return {
            key: math.fsum(e.values[metric]) / len(e.values[metric])
            for key, e in self.experiences.items()
            if e.values.get(metric)
        }


@dataclass(frozen=True, slots=True)
class PassRateComparison:
    """The two batches' pass rates (Wilson intervals), their difference (Newcombe's) and
    its verdict."""

    baseline: Interval  # Wilson, as proportions
    candidate: Interval
    difference: Interval  # Newcombe, candidate - baseline
    verdict: ComparisonVerdict


@dataclass(frozen=True, slots=True)
class MetricComparison:
    """One SCALAR job metric of both batches: each side's mean, their difference (the
    seeded bootstrap), its Holm-adjusted p-value, and the verdict."""

    name: str
    unit: str
    verdict: ComparisonVerdict
    better: Better | None
    better_from: str  # "config", "failure definition" or "" (two-sided)
    baseline: Interval | None  # each side's mean with its t interval
    candidate: Interval | None
    difference: MeanDifference | None  # None: too few values to compare
    p_adjusted: float | None


@dataclass(frozen=True, slots=True)
class ComparisonResult:
    """What `BaselineComparison.result()` computes: the baseline it compared with, the pass
    rates, the experiences that flipped or still fail, every metric's comparison, and the
    overall status (`regressed` when it is a failure)."""

    baseline: BaselineInfo
    pass_rate: PassRateComparison | None
    newly_failing: list[str]
    fixed: list[str]
    still_failing: list[str]
    metrics: list[MetricComparison]
    status: MetricStatus
    # SCALAR job metrics only one of the two batches has: not compared.
    only_candidate: list[str] = field(default_factory=list)
    only_baseline: list[str] = field(default_factory=list)

    @property
    def regressed(self) -> bool:
        return self.status in (MetricStatus.FAIL_WARN, MetricStatus.FAIL_BLOCK)


@dataclass
class BaselineComparison(Aggregation[JobRecord]):
    """`[batch.baseline]`: this batch against a baseline batch (see the module docstring)."""

    name: str = "Compared with baseline"
    metrics: tuple[str, ...] | None = None  # None: every SCALAR both batches have
    better: Mapping[str, Better] = field(default_factory=dict)
    min_effect: float = 0.05
    confidence: float = 0.95
    correction: str = "holm"
    resamples: int = 2000
    block_on_regression: bool = False

    candidate: _Side = field(default_factory=_Side, init=False)
    baseline: _Side = field(default_factory=_Side, init=False)
    found: BaselineInfo | None = field(default=None, init=False)
    not_found: str = field(default="no baseline was looked for", init=False)
    candidate_id: uuid.UUID | None = field(default=None, init=False)
    directions: dict[str, Better | None] = field(default_factory=dict, init=False)
    units: dict[str, str] = field(default_factory=dict, init=False)

    def __post_init__(self) -> None:
        if self.correction not in CORRECTIONS:
            raise ValueError(f"correction must be one of {CORRECTIONS}, got {self.correction!r}")
        if not 0.0 < self.confidence < 1.0:
            raise ValueError(f"confidence must lie between 0 and 1, got {self.confidence}")
        if self.min_effect < 0.0:
            raise ValueError(f"min_effect cannot be negative, got {self.min_effect}")

    def needs(self) -> Needs:
        if self.metrics is None:
            return Needs(every_scalar=True)
        return Needs(scalars=frozenset(self.metrics))

    @property
    def _wanted(self) -> frozenset[str] | None:
        return None if self.metrics is None else frozenset(self.metrics)

    def update(self, job: JobRecord) -> None:
        self.candidate.add(job, self._wanted)
        for name, scalar in job.scalars.items():
            self._unit(name, scalar.unit)

    def update_baseline(self, job: JobRecord) -> None:
        self.baseline.add(job, self._wanted)

    def merge(self, other: Self) -> None:
        self.candidate.merge(other.candidate)
        self.baseline.merge(other.baseline)
        for name, unit in other.units.items():
            self._unit(name, unit)

    def _unit(self, name: str, unit: str) -> None:
        # The least of the units jobs gave, not the first: the same bytes in any job order.
        if unit and (name not in self.units or unit < self.units[name]):
            self.units[name] = unit

    def set_baseline(self, info: BaselineInfo, candidate_id: uuid.UUID) -> None:
        self.found, self.candidate_id = info, candidate_id

    def no_baseline(self, reason: str) -> None:
        self.found, self.not_found = None, reason

    def compared_metrics(self) -> list[str]:
        both = self.candidate.metric_names() & self.baseline.metric_names()
        return sorted(both)

    def direction_probes(self) -> dict[str, uuid.UUID]:
        """Metrics with no configured direction, and a candidate job that has each."""
        return {
            name: self.candidate.example_jobs[name]
            for name in self.compared_metrics()
            if name not in self.better and name in self.candidate.example_jobs
        }

    def set_directions(self, directions: Mapping[str, Better | None]) -> None:
        self.directions.update(directions)

    # ---- the comparison ----

    def result(self) -> ComparisonResult | None:
        """The comparison, or None when there is no baseline to compare with."""
        if self.found is None:
            return None
        newly, fixed, still = self._flips()
        pass_rate = self._pass_rate()
        metrics = self._metrics()
        regressed = any(m.verdict is ComparisonVerdict.REGRESSED for m in metrics) or (
            pass_rate is not None and pass_rate.verdict is ComparisonVerdict.REGRESSED
        )
        if not regressed:
            status = MetricStatus.PASSED
        elif self.block_on_regression:
            status = MetricStatus.FAIL_BLOCK
        else:
            status = MetricStatus.FAIL_WARN
        mine, theirs = self.candidate.metric_names(), self.baseline.metric_names()
        return ComparisonResult(
            self.found,
            pass_rate,
            newly,
            fixed,
            still,
            metrics,
            status,
            only_candidate=sorted(mine - theirs),
            only_baseline=sorted(theirs - mine),
        )

    def _flips(self) -> tuple[list[str], list[str], list[str]]:
        newly: list[str] = []
        fixed: list[str] = []
        still: list[str] = []
        for key, now in self.candidate.experiences.items():
            before = self.baseline.experiences.get(key)
            if before is None:
                continue
            pair = (before.outcome, now.outcome)
            if pair == ("passed", "failed"):
                newly.append(now.name)
            elif pair == ("failed", "passed"):
                fixed.append(now.name)
            elif pair == ("failed", "failed"):
                still.append(now.name)
        return sorted(newly), sorted(fixed), sorted(still)

    def _pass_rate(self) -> PassRateComparison | None:
        base, cand = self.baseline, self.candidate
        if base.jobs == 0 or cand.jobs == 0:
            return None
        difference = newcombe_difference(
            cand.passed, cand.jobs, base.passed, base.jobs, self.confidence
        )
        verdict = comparison_verdict(
            estimate=difference.estimate,
            low=difference.low,
            high=difference.high,
            significant=difference.excludes_zero(),
            level=base.passed / base.jobs,
            better="higher",
            min_effect=self.min_effect,
        )
        return PassRateComparison(
            wilson_interval(base.passed, base.jobs, self.confidence),
            wilson_interval(cand.passed, cand.jobs, self.confidence),
            difference,
            verdict,
        )

    def _difference(self, metric: str) -> MeanDifference | None:
        base_means = self.baseline.experience_means(metric)
        cand_means = self.candidate.experience_means(metric)
        common = sorted(base_means.keys() & cand_means.keys())
        # Paired when most experiences ran in both: a pair's difference cancels what the
        # experience itself contributes, the largest source of spread between jobs.
        paired = len(common) >= 2 and 2 * len(common) >= max(len(base_means), len(cand_means))
        if paired:
            base = [base_means[k] for k in common]
            cand = [cand_means[k] for k in common]
        else:
            base, cand = self.baseline.values(metric), self.candidate.values(metric)
        if len(base) < 2 or len(cand) < 2:
            return None
        assert self.found is not None
        assert self.candidate_id is not None
        return bootstrap_mean_difference(
            base,
            cand,
            paired=paired,
            seed=seed_from(self.candidate_id.bytes, self.found.batch_id.bytes, metric),
            resamples=self.resamples,
            confidence=self.confidence,
        )

    def _metrics(self) -> list[MetricComparison]:
        names = self.compared_metrics()
        differences = {name: self._difference(name) for name in names}
        tested = [n for n in names if differences[n] is not None]
        raw = [d.p_value for n in tested if (d := differences[n]) is not None]
        ps = holm_adjusted(raw) if self.correction == "holm" else raw
        adjusted = dict(zip(tested, ps, strict=True))
        alpha = 1.0 - self.confidence
        out: list[MetricComparison] = []
        for name in names:
            difference = differences[name]
            base_values = self.baseline.values(name)
            cand_values = self.candidate.values(name)
            if name in self.better:
                better: Better | None = self.better[name]
                source = "config"
            else:
                better = self.directions.get(name)
                source = "failure definition" if better is not None else ""
            if difference is None:
                verdict = ComparisonVerdict.INCONCLUSIVE
            else:
                verdict = comparison_verdict(
                    estimate=difference.estimate,
                    low=difference.low,
                    high=difference.high,
                    significant=adjusted[name] < alpha,
                    level=math.fsum(base_values) / len(base_values),
                    better=better,
                    min_effect=self.min_effect,
                )
            out.append(
                MetricComparison(
                    name=name,
                    unit=self.units.get(name, ""),
                    verdict=verdict,
                    better=better,
                    better_from=source,
                    baseline=mean_interval(base_values, self.confidence) if base_values else None,
                    candidate=mean_interval(cand_values, self.confidence) if cand_values else None,
                    difference=difference,
                    p_adjusted=adjusted.get(name),
                )
            )
        return out

    # ---- writing ----

    def finish(self, writer: MetricsWriter) -> None:

        result = self.result()
        if result is None:
            writer.text(
                self.name,
                f"No baseline to compare with: {self.not_found}.",
                status=MetricStatus.NOT_APPLICABLE,
            )
            return
        write_comparison(writer, self, result)


FLIPS_CHART = "Newly failing and fixed experiences"
PASS_RATE_CHART = "Pass rate vs baseline"
PASS_RATE_DIFFERENCE = "Pass rate difference vs baseline"
# Experiences named in the text per list, and bars in the flips chart: a batch where
# thousands flip needs the count and the first names, not a page of them.
MAX_NAMED = 50
MAX_BARS = 100


def _num(value: float, unit: str = "") -> str:
    text = f"{value:+.4g}"
    return f"{text} {unit}" if unit else text


def _plain(value: float) -> str:
    return f"{value:.4g}"


def _status(verdict: ComparisonVerdict, comparison: BaselineComparison) -> MetricStatus:
    if verdict is not ComparisonVerdict.REGRESSED:
        return MetricStatus.PASSED
    return MetricStatus.FAIL_BLOCK if comparison.block_on_regression else MetricStatus.FAIL_WARN


def _names(label: str, names: list[str]) -> str:
    shown = ", ".join(names[:MAX_NAMED]) if names else "none"
    more = f" and {len(names) - MAX_NAMED} more" if len(names) > MAX_NAMED else ""
    return f"{label} ({len(names)}): {shown}{more}"


def chart_name(metric: str, taken: set[str]) -> str:
    """The chart of `metric`, kept apart from the comparison's own metric names."""
    name = f"{metric} vs baseline"
    return name if name not in taken else f"{metric} (job metric) vs baseline"


def _pass_rate_line(p: PassRateComparison, percent: int) -> str:
    d = p.difference
    return (
        f"Pass rate: {100 * p.baseline.estimate:.1f} % -> {100 * p.candidate.estimate:.1f} %, "
        f"difference {100 * d.estimate:+.1f} points, {percent} % interval "
        f"[{100 * d.low:+.1f}, {100 * d.high:+.1f}] (Newcombe): {p.verdict.value}"
    )


def _direction(m: MetricComparison) -> str:
    if m.better is None:
        return "two-sided: no direction known"
    return f"{m.better} is better, from the {m.better_from}"


def _metric_line(m: MetricComparison, percent: int) -> str:
    d = m.difference
    if d is None:
        return f"- {m.name}: {m.verdict.value}, too few values to compare"
    pairing = (
        f"paired over {d.n_candidate} experiences"
        if d.paired
        else f"unpaired, {d.n_baseline} vs {d.n_candidate} jobs"
    )
    p_text = f"p = {d.p_value:.3g}"
    if m.p_adjusted is not None and m.p_adjusted != d.p_value:
        p_text += f", adjusted {m.p_adjusted:.3g}"
    return (
        f"- {m.name}: {m.verdict.value}, change {_num(d.estimate, m.unit)}, {percent} % interval "
        f"[{_num(d.low)}, {_num(d.high)}] ({pairing}; {_direction(m)}; {p_text})"
    )


def comparison_text(comparison: BaselineComparison, result: ComparisonResult) -> str:
    b = result.baseline
    percent = round(100 * comparison.confidence)
    created = f", created {b.created:%Y-%m-%d %H:%M %Z}".rstrip() if b.created else ""
    build = f", build {b.build}" if b.build else ""
    lines = [
        f"Baseline: {b.friendly_name or 'unnamed batch'} (batch {b.batch_id}{build}{created})"
        + (f", {b.chosen_as}" if b.chosen_as else "")
        + ".",
    ]
    if b.missing_jobs:
        lines.append(f"{b.missing_jobs} baseline jobs could not be fetched and are left out.")
    lines.append("")
    if result.pass_rate is not None:
        lines.append(_pass_rate_line(result.pass_rate, percent))
    lines.append(_names("Newly failing experiences", result.newly_failing))
    lines.append(_names("Fixed experiences", result.fixed))
    lines.append(_names("Still failing experiences", result.still_failing))
    lines.append("")
    if result.metrics:
        correction = (
            f"Holm-adjusted across {len(result.metrics)} metrics"
            if comparison.correction == "holm"
            else "not adjusted for multiple comparisons"
        )
        lines.append(
            f"Scalar metrics, candidate mean - baseline mean, {percent} % bootstrap intervals "
            f"({comparison.resamples} resamples), p-values {correction}; changes under "
            f"{100 * comparison.min_effect:g} % of the baseline's mean count as NO CHANGE:"
        )
        lines.extend(_metric_line(m, percent) for m in result.metrics)
    else:
        lines.append("No SCALAR job metric is in both batches, so no metric was compared.")
    if result.only_candidate:
        lines.append(f"Not in the baseline, not compared: {', '.join(result.only_candidate)}.")
    if result.only_baseline:
        lines.append(f"Only in the baseline, not compared: {', '.join(result.only_baseline)}.")
    return "\n".join(lines)


def _interval_bars(
    writer: MetricsWriter,
    name: str,
    base: Interval,
    cand: Interval,
    *,
    scale: float,
    unit: str,
    status: MetricStatus,
    description: str,
    percent: int,
) -> None:
    labels = data.strings(f"{name} (labels)", ["Baseline", "Candidate"])
    series = [
        data.doubles(
            f"{name} ({part})",
            [scale * getattr(base, attr), scale * getattr(cand, attr)],
            unit=unit,
            index=labels,
        )
        for part, attr in (
            ("estimate", "estimate"),
            (f"{percent} % low", "low"),
            (f"{percent} % high", "high"),
        )
    ]
    writer.bar_chart(
        name,
        series,
        legend=["Mean" if scale == 1.0 else "Rate", f"{percent} % low", f"{percent} % high"],
        x_axis_name="Batch",
        y_axis_name=f"{name.removesuffix(' vs baseline')}" + (f" ({unit})" if unit else ""),
        status=status,
        description=description,
    )


def write_comparison(
    writer: MetricsWriter, comparison: BaselineComparison, result: ComparisonResult
) -> None:
    percent = round(100 * comparison.confidence)
    writer.text(comparison.name, comparison_text(comparison, result), status=result.status)
    flips = {n: 1.0 for n in result.newly_failing} | {n: -1.0 for n in result.fixed}
    total = len(flips)
    flips = dict(list(flips.items())[:MAX_BARS])
    if flips:
        writer.bar_chart_from(
            FLIPS_CHART,
            flips,
            x_axis_name="Experience",
            y_axis_name="+1 newly failing, -1 fixed",
            description=(
                f"{len(result.newly_failing)} experiences passed in the baseline and fail now; "
                f"{len(result.fixed)} failed in the baseline and pass now"
                + (f" (the first {MAX_BARS} shown)." if total > MAX_BARS else ".")
            ),
        )
    if (p := result.pass_rate) is not None:
        status = _status(p.verdict, comparison)
        _interval_bars(
            writer,
            PASS_RATE_CHART,
            p.baseline,
            p.candidate,
            scale=100.0,
            unit="%",
            status=status,
            description=f"Share of jobs PASSED, with {percent} % Wilson intervals.",
            percent=percent,
        )
        writer.scalar(
            PASS_RATE_DIFFERENCE,
            100.0 * p.difference.estimate,
            unit="percentage points",
            status=status,
            description=(
                f"{p.verdict.value}: candidate - baseline pass rate, {percent} % Newcombe "
                f"interval [{100 * p.difference.low:+.1f}, {100 * p.difference.high:+.1f}] points."
            ),
        )
    taken = {comparison.name, FLIPS_CHART, PASS_RATE_CHART, PASS_RATE_DIFFERENCE}
    for m in result.metrics:
        if m.baseline is None or m.candidate is None:
            continue
        d = m.difference
        detail = (
            f"change {_num(d.estimate, m.unit)}, {percent} % interval "
            f"[{_num(d.low)}, {_num(d.high)}]"
            if d is not None
            else "too few values to compare"
        )
        _interval_bars(
            writer,
            chart_name(m.name, taken),
            m.baseline,
            m.candidate,
            scale=1.0,
            unit=m.unit,
            status=_status(m.verdict, comparison),
            description=(
                f"{m.verdict.value}: {detail}. Bars: each batch's mean with its {percent} % "
                "t interval."
            ),
            percent=percent,
        )
