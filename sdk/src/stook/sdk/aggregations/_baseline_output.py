"""What a baseline comparison writes: the text, the flips chart, pass rate and metric charts."""

from __future__ import annotations

from typing import TYPE_CHECKING

from stook.sdk import _data as data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.stats import ComparisonVerdict, Interval

if TYPE_CHECKING:
    from stook.sdk.aggregations._baseline import (
        BaselineComparison,
        ComparisonResult,
        MetricComparison,
        PassRateComparison,
    )

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
