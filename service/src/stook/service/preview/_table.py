"""A metrics.binproto as a text table: one line per metric (`stook show`, `stook demo`)."""

from __future__ import annotations

import enum

from stook.sdk import JobMetricsView, MetricsDataView, MetricType, MetricView, SeriesKind


def _value(metric: MetricView, view: JobMetricsView) -> str:
    if metric.type is MetricType.SCALAR and metric.value is not None:
        return f"{metric.value:.6g} {metric.unit or ''}".rstrip()
    if metric.type is MetricType.TEXT:
        text = (metric.raw.metric_values.text_metric_values.text.splitlines() or [""])[0]
        return text if len(text) <= 48 else text[:45] + "..."
    sizes = []
    for data_id in metric.data_ids:
        data = view.data_by_id.get(data_id)
        if data is None or data.is_external or data.kind in (None, SeriesKind.STATUS):
            continue  # no values to count
        sizes.append(_length(data))
    if not sizes:
        return ""
    total = sum(sizes)
    return f"{total} value" if total == 1 else f"{total} values"


def _length(data: MetricsDataView) -> int:
    """How many values `data.frame()` has. Doubles and strings always convert, so they are
    counted in the message, without importing polars; other kinds are converted, so that
    a value the reader refuses fails here as it would in a frame."""
    if data.kind is SeriesKind.DOUBLE or data.kind is SeriesKind.STRING:
        field = "doubles" if data.kind is SeriesKind.DOUBLE else "strings"
        if data.per_category:
            by_category = data.raw.series_per_category.category_to_series
            return sum(len(getattr(s, field).series) for s in by_category.values())
        return len(getattr(data.raw.series, field).series)
    return data.frame().height


def _enum_name(value: enum.IntEnum | int | None) -> str:
    """A member's name; ``?`` when unset; the number of a value this schema does not know."""
    if value is None:
        return "?"
    return value.name if isinstance(value, enum.IntEnum) else f"unknown ({value})"


def summary_lines(view: JobMetricsView, *, full: bool = False) -> list[str]:
    """A readable table: one line per metric with its type, status and value; `full`
    keeps long names whole and prints each TEXT metric's text whole below the table."""
    rows = [
        (m.name, _enum_name(m.type), _enum_name(m.status), _value(m, view)) for m in view.metrics
    ]
    widths = [max([len(h), *(len(r[i]) for r in rows)]) for i, h in enumerate(_HEADER)]
    if not full:
        widths[0] = min(widths[0], 56)

    def line(cells: tuple[str, ...]) -> str:
        return "  ".join(c[: widths[i]].ljust(widths[i]) for i, c in enumerate(cells)).rstrip()

    status = "unset" if view.status is None else _enum_name(view.status)
    lines = [
        f"{len(view.metrics)} metrics, {len(view.data)} metrics data, overall status {status}",
        line(_HEADER),
        line(tuple("-" * w for w in widths)),
        *(line(r) for r in rows),
    ]
    if full:
        for metric in view.metrics:
            if metric.type is MetricType.TEXT:
                text = metric.raw.metric_values.text_metric_values.text
                lines += ["", f"== {metric.name} ==", *text.splitlines()]
    return lines


_HEADER = ("metric", "type", "status", "value")
