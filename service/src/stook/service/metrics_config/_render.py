"""A metric's query result into the writer, one function per system template.

Columns are read by position and count, not by name (the reference's table): the
aliases only title the axes.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from stook.sdk import MetricOptions, MetricStatus, MetricsWriter, data
from stook.service.metrics_config._errors import QueryError
from stook.service.metrics_config._model import Metric
from stook.service.metrics_config._query_engine import Result
from stook.service.metrics_config._values import label, number, plain, timestamp_ns

DEFAULT_BINS = 20
NO_DATA_TEXT = "No data: the query returned no rows."


def options_for(metric: Metric, status: MetricStatus) -> MetricOptions:
    options: MetricOptions = {"status": status, "description": metric.description}
    if status is MetricStatus.FAIL_BLOCK:
        options["blocking"] = True
    return options


def render_no_data(writer: MetricsWriter, metric: Metric) -> None:
    """The platform's NO_DATA: shown, not applicable, no status query run."""
    writer.text(
        metric.name,
        NO_DATA_TEXT,
        status=MetricStatus.NOT_APPLICABLE,
        description=metric.description,
    ).tag("no_data", "true")


def render(
    writer: MetricsWriter, metric: Metric, result: Result, status: MetricStatus
) -> list[str]:
    """Write `metric`; the attached files it references (image, video, artifact)."""
    options = options_for(metric, status)
    if metric.template in ("image", "video", "artifact"):
        return _media(writer, metric, result, options)
    _RENDERERS[metric.template](writer, metric, result, options)
    return []


def _bad(metric: Metric, why: str) -> QueryError:
    return QueryError(metric.name, metric.query.strip(), why, what="result")


def _need(metric: Metric, result: Result, least: int) -> None:
    if len(result.columns) < least:
        raise _bad(
            metric,
            f"a {metric.template} needs at least {least} column(s), the query returns "
            f"{len(result.columns)}",
        )


def _numbers(metric: Metric, values: list[Any], column: str) -> list[float]:
    out = []
    for value in values:
        n = number(value)
        if n is None:
            raise _bad(metric, f"column {column!r} holds {value!r}, not a number")
        out.append(n)
    return out


def _groups(rows: list[tuple[Any, ...]], key: int) -> dict[str, list[tuple[Any, ...]]]:
    """Rows by the label of column `key`, in the order each label first appears."""
    grouped: dict[str, list[tuple[Any, ...]]] = {}
    for row in rows:
        grouped.setdefault(label(row[key]), []).append(row)
    return grouped


def _scalar(writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions) -> None:
    value = number(result.rows[0][0])
    if value is None:
        raise _bad(metric, f"a scalar needs a number, the query returns {result.rows[0][0]!r}")
    writer.scalar(metric.name, value, unit=metric.units, **options)


def _line(writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions) -> None:
    _need(metric, result, 2)
    cols = result.columns
    if len(cols) == 2:
        x_at, y_at, grouped = 0, 1, {cols[1]: result.rows}
    else:
        x_at, y_at, grouped = 1, 2, _groups(result.rows, 0)
    xs, ys, legend = [], [], []
    for series, rows in grouped.items():
        points = [r for r in rows if r[x_at] is not None and r[y_at] is not None]
        if not points:
            continue
        prefix = f"{metric.name} / {series}"
        x_values = _numbers(metric, [r[x_at] for r in points], cols[x_at])
        y_values = _numbers(metric, [r[y_at] for r in points], cols[y_at])
        xs.append(data.doubles(f"{prefix} / x", x_values))
        ys.append(data.doubles(f"{prefix} / y", y_values))
        legend.append(series)
    if not xs:
        raise _bad(metric, "every point has a NULL x or y")
    writer.line_plot(
        metric.name,
        xs,
        ys,
        x_axis_name=_setting(metric, "x_axis_name", cols[x_at]),
        y_axis_name=_setting(metric, "y_axis_name", cols[y_at]),
        legend=legend,
        **options,
    )


def _bar(writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions) -> None:
    _need(metric, result, 2)
    cols = result.columns
    if len(cols) == 2:
        c_at, v_at, grouped = 0, 1, {cols[1]: result.rows}
    else:
        c_at, v_at, grouped = 1, 2, _groups(result.rows, 0)
    series = []
    for group, rows in grouped.items():
        prefix = f"{metric.name} / {group}"
        categories = data.strings(f"{prefix} / categories", [label(r[c_at]) for r in rows])
        values = _numbers(metric, [r[v_at] for r in rows], cols[v_at])
        series.append(data.doubles(prefix, values, index=categories))
    writer.bar_chart(
        metric.name,
        series,
        x_axis_name=_setting(metric, "x_axis_name", cols[c_at]),
        y_axis_name=_setting(metric, "y_axis_name", cols[v_at]),
        legend=list(grouped),
        stack_bars=bool(_display(metric).get("stack", False)),
        **options,
    )


def _histogram(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> None:
    cols = result.columns
    bins = _display(metric).get("bins", DEFAULT_BINS)
    if not isinstance(bins, int) or isinstance(bins, bool) or bins < 1:
        raise _bad(metric, f"template_settings.display.bins must be a positive int, not {bins!r}")
    if len(cols) == 1:
        grouped = {metric.name: result.rows}
        v_at = 0
    else:
        grouped = {f"{metric.name} ({g})": rows for g, rows in _groups(result.rows, 0).items()}
        v_at = 1
    for name, rows in grouped.items():
        values = _numbers(metric, [r[v_at] for r in rows if r[v_at] is not None], cols[v_at])
        if not values:
            continue
        lower, upper = min(values), max(values)
        if lower == upper:
            lower, upper = lower - 0.5, upper + 0.5
        writer.histogram(
            name,
            data.doubles(f"{name} / values", values),
            buckets=bins,
            lower=lower,
            upper=upper,
            x_axis_name=_setting(metric, "x_axis_name", cols[v_at]),
            **options,
        )


def _state_timeline(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> None:
    _need(metric, result, 3)
    series, legend = [], []
    for system, rows in _groups(result.rows, 0).items():
        points = []
        for row in rows:
            at = timestamp_ns(row[1])
            if at is None:
                raise _bad(metric, f"column {result.columns[1]!r} holds {row[1]!r}, not a time")
            if row[2] is not None:
                points.append((at, label(row[2])))
        if not points:
            continue
        prefix = f"{metric.name} / {system}"
        times = data.timestamps(f"{prefix} / time", [p[0] for p in points])
        series.append(data.strings(prefix, [p[1] for p in points], index=times))
        legend.append(system)
    writer.states_over_time(metric.name, series, legend=legend, **options)


def _pie(writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions) -> None:
    _need(metric, result, 2)
    figure = {
        "data": [
            {
                "type": "pie",
                "labels": [label(r[0]) for r in result.rows],
                "values": _numbers(metric, [r[1] for r in result.rows], result.columns[1]),
            }
        ],
        "layout": {"title": {"text": metric.name}},
    }
    writer.plotly(metric.name, figure, **options)


def markdown_table(result: Result) -> str:
    """The result as a Markdown table, every value as the engine returned it."""

    def cell(value: Any) -> str:
        text = (
            ""
            if value is None
            else json.dumps(plain(value))
            if isinstance(value, list | dict)
            else str(value)
        )
        return text.replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ")

    lines = [
        "| " + " | ".join(cell(c) for c in result.columns) + " |",
        "|" + "---|" * len(result.columns),
    ]
    lines.extend("| " + " | ".join(cell(v) for v in row) + " |" for row in result.rows)
    return "\n".join(lines)


def _table(writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions) -> None:
    writer.text(metric.name, markdown_table(result), **options)


def _media(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> list[str]:
    names = []
    for value in result.column(0):
        if value is None:
            continue
        if not isinstance(value, str) or not value or "/" in value or "\\" in value:
            raise _bad(
                metric, f"an {metric.template} is the basename of an attached file, not {value!r}"
            )
        names.append(value)
    files = [data.external_file(f"{metric.name} / {name}", name) for name in dict.fromkeys(names)]
    if len(files) == 1:
        writer.image(metric.name, files[0], **options)
    else:
        writer.image_list(metric.name, files, **options)
    return list(dict.fromkeys(names))


def _display(metric: Metric) -> dict[str, Any]:
    display = metric.settings.get("display")
    return display if isinstance(display, dict) else {}


def _setting(metric: Metric, key: str, default: str) -> str:
    value = metric.settings.get(key)
    return value if isinstance(value, str) and value else default


_RENDERERS: dict[str, Callable[[MetricsWriter, Metric, Result, MetricOptions], None]] = {
    "scalar": _scalar,
    "line": _line,
    "bar": _bar,
    "histogram": _histogram,
    "state_timeline": _state_timeline,
    "pie": _pie,
    "table": _table,
}
