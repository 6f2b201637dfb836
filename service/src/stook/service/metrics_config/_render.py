"""A metric's query result into the writer, one function per system template.

Columns are read by position and count, not by name (the reference's table): the
aliases title the axes unless `template_settings` labels them. Every metric keeps its
configured name whatever its group column holds: the groups are series inside the one
metric (metrics sets and dashboards find it by name).

`template_settings` goes where JobMetrics has a field for it (axis labels, a
histogram's range and bins, a pie's text and legend, which is a Plotly figure); the
whole of it is also carried as the metric's `template_settings` tag (JSON), so that
what JobMetrics cannot hold (series colours, a y range, the legend's place) reaches the
preview. What a template cannot draw raises `RenderError`, naming the metric.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from stook.sdk import MetricHandle, MetricOptions, MetricStatus, MetricsWriter, data
from stook.service.metrics_config._errors import TemplateError
from stook.service.metrics_config._model import Metric
from stook.service.metrics_config._query_engine import Result
from stook.service.metrics_config._values import label, number, plain, timestamp_ns

DEFAULT_BINS = 20
NO_DATA_TEXT = "No data: the query returned no rows."

# The tags a config metric may carry (the preview and a reader go by them).
NO_DATA_TAG = "no_data"  # "true": the query returned nothing
ERROR_TAG = "error"  # "ERROR" (a query failed) or "RENDER_ERROR" (the template did)
TEMPLATE_TAG = "template"  # the template, where the metric's type does not say it
SETTINGS_TAG = "template_settings"  # the metric's template_settings, canonical JSON
LINK_PATHS_TAG = "link_paths"  # a bar's link_path column: {group: {category: path}}


class RenderError(TemplateError):
    """A query's result that its template cannot draw: a template failure, as a Liquid
    template's is (exit 4 with --strict)."""

    def __init__(self, metric: Metric, why: str) -> None:
        self.metric = metric.name
        super().__init__(f"metric {metric.name!r}: its {metric.template} cannot show this: {why}")


def options_for(metric: Metric, status: MetricStatus) -> MetricOptions:
    options: MetricOptions = {"status": status, "description": metric.description}
    if status is MetricStatus.FAIL_BLOCK:
        options["blocking"] = True
    return options


def render_no_data(writer: MetricsWriter, metric: Metric) -> MetricHandle:
    """The platform's NO_DATA: shown, not applicable, no status query run."""
    return writer.text(
        metric.name,
        NO_DATA_TEXT,
        status=MetricStatus.NOT_APPLICABLE,
        description=metric.description,
    ).tag(NO_DATA_TAG, "true")


def render_error(writer: MetricsWriter, metric: Metric, mark: str, message: str) -> MetricHandle:
    """The platform's ERROR / RENDER_ERROR: the metric under its name, its message as
    the text, NOT_APPLICABLE (JobMetrics has no error status; a failed metric gives no
    verdict) and the `error` tag saying which."""
    return writer.text(
        metric.name,
        message or mark,
        status=MetricStatus.NOT_APPLICABLE,
        description=metric.description,
    ).tag(ERROR_TAG, mark)


def render(
    writer: MetricsWriter,
    metric: Metric,
    result: Result,
    status: MetricStatus,
    attached: Callable[[str], bool] | None = None,
    job_media: Callable[[str], list[str]] | None = None,
) -> tuple[MetricHandle, list[str]]:
    """Write `metric`: its handle, and the attached files it references (image, video,
    artifact). `attached` says whether a file is among the job's (None: not checked);
    `job_media` gives a job's files of the metric's kind, by its ID (see `_media`)."""
    options = options_for(metric, status)
    if metric.template in ("image", "video", "artifact"):
        return _media(writer, metric, result, options, attached, job_media)
    handle = _RENDERERS[metric.template](writer, metric, result, options)
    return with_settings(handle, metric), []


def with_settings(handle: MetricHandle, metric: Metric) -> MetricHandle:
    if metric.settings:
        text = json.dumps(plain(dict(metric.settings)), sort_keys=True, separators=(",", ":"))
        handle.tag(SETTINGS_TAG, text)
    return handle


@dataclass(frozen=True, slots=True)
class _Axis:
    label: str | None = None
    min: float | None = None
    max: float | None = None


def _axis(metric: Metric, key: str) -> _Axis:
    """`template_settings.xaxis` / `.yaxis`: `{label, min, max}`."""
    value = metric.settings.get(key)
    if value is None:
        return _Axis()
    if not isinstance(value, Mapping):
        raise RenderError(metric, f"template_settings.{key} must be a mapping, not {value!r}")
    text = value.get("label")
    bounds = []
    for end in ("min", "max"):
        given = value.get(end)
        if given is not None and (number(given) is None or isinstance(given, bool)):
            raise RenderError(metric, f"template_settings.{key}.{end} must be a number")
        bounds.append(None if given is None else number(given))
    return _Axis(None if text is None else str(text), bounds[0], bounds[1])


def _display(metric: Metric) -> Mapping[str, Any]:
    display = metric.settings.get("display")
    return display if isinstance(display, Mapping) else {}


def _colours(metric: Metric) -> dict[str, str]:
    """`template_settings.series`: `[{group_name, color}]`, a colour per series."""
    series = metric.settings.get("series")
    out: dict[str, str] = {}
    if isinstance(series, list):
        for item in series:
            if isinstance(item, Mapping) and item.get("color") is not None:
                out[label(item.get("group_name"))] = str(item["color"])
    return out


def _need(metric: Metric, result: Result, least: int) -> None:
    if len(result.columns) < least:
        raise RenderError(
            metric, f"it needs at least {least} columns, the query returns {len(result.columns)}"
        )


def _numbers(metric: Metric, values: list[Any], column: str) -> list[float]:
    out = []
    for value in values:
        n = number(value)
        if n is None:
            raise RenderError(metric, f"column {column!r} holds {value!r}, not a number")
        out.append(n)
    return out


def _groups(rows: list[tuple[Any, ...]], key: int) -> dict[str, list[tuple[Any, ...]]]:
    """Rows by the label of column `key`, in the order each label first appears."""
    grouped: dict[str, list[tuple[Any, ...]]] = {}
    for row in rows:
        grouped.setdefault(label(row[key]), []).append(row)
    return grouped


def _scalar(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> MetricHandle:
    value = result.rows[0][0]
    as_number = number(value)
    if as_number is not None:
        return writer.scalar(metric.name, as_number, unit=metric.units, **options)
    if not isinstance(value, str):
        raise RenderError(metric, f"a scalar is a number or a text, the query returns {value!r}")
    if not value.strip():
        raise RenderError(metric, "the query returns an empty text")
    # A text scalar (a duration formatted 'HH:MM:SS', say) is shown as that text.
    text = f"{value} {metric.units}" if metric.units else value
    return writer.text(metric.name, text, **options).tag(TEMPLATE_TAG, "scalar")


def _line(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> MetricHandle:
    _need(metric, result, 2)
    cols = result.columns
    if len(cols) == 2:
        x_at, y_at, grouped = 0, 1, {cols[1]: result.rows}
    else:
        x_at, y_at, grouped = 1, 2, _groups(result.rows, 0)
    if any(isinstance(r[x_at], str) for r in result.rows):
        return _category_line(writer, metric, cols[x_at], cols[y_at], grouped, x_at, y_at, options)
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
        raise RenderError(metric, "every point has a NULL x or y")
    return writer.line_plot(
        metric.name,
        xs,
        ys,
        x_axis_name=_axis(metric, "xaxis").label or cols[x_at],
        y_axis_name=_axis(metric, "yaxis").label or cols[y_at],
        legend=legend,
        **options,
    )


def _category_line(
    writer: MetricsWriter,
    metric: Metric,
    x_name: str,
    y_name: str,
    grouped: Mapping[str, list[tuple[Any, ...]]],
    x_at: int,
    y_at: int,
    options: MetricOptions,
) -> MetricHandle:
    """A line over text x values (a build's date formatted by `date_format`, say): the
    platform draws them as categories in row order; JobMetrics' line plot holds numbers
    only, so it is a Plotly figure, tagged as the line it is."""
    colours = _colours(metric)
    traces = []
    for series, rows in grouped.items():
        points = [r for r in rows if r[x_at] is not None and r[y_at] is not None]
        if not points:
            continue
        trace: dict[str, Any] = {
            "type": "scatter",
            "mode": "lines+markers",
            "name": series,
            "x": [label(r[x_at]) for r in points],
            "y": _numbers(metric, [r[y_at] for r in points], y_name),
        }
        if series in colours:
            trace["line"] = {"color": colours[series]}
        traces.append(trace)
    if not traces:
        raise RenderError(metric, "every point has a NULL x or y")
    x_axis, y_axis = _axis(metric, "xaxis"), _axis(metric, "yaxis")
    layout: dict[str, Any] = {
        "xaxis": {"title": {"text": x_axis.label or x_name}, "type": "category"},
        "yaxis": {"title": {"text": y_axis.label or y_name}},
    }
    if y_axis.min is not None and y_axis.max is not None:
        layout["yaxis"]["range"] = [y_axis.min, y_axis.max]
    figure = {"data": traces, "layout": layout}
    return writer.plotly(metric.name, figure, **options).tag(TEMPLATE_TAG, "line")


def _bar(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> MetricHandle:
    _need(metric, result, 2)
    cols = result.columns
    if len(cols) == 2:
        c_at, v_at, grouped = 0, 1, {cols[1]: result.rows}
    else:
        c_at, v_at, grouped = 1, 2, _groups(result.rows, 0)
    # A fourth column is the platform's link_path: where clicking the bar leads.
    link_at = 3 if len(cols) >= 4 else None
    series = []
    links: dict[str, dict[str, str]] = {}
    for group, rows in grouped.items():
        prefix = f"{metric.name} / {group}"
        names = [label(r[c_at]) for r in rows]
        categories = data.strings(f"{prefix} / categories", names)
        values = _numbers(metric, [r[v_at] for r in rows], cols[v_at])
        series.append(data.doubles(prefix, values, index=categories))
        if link_at is not None:
            paths = {c: str(r[link_at]) for c, r in zip(names, rows, strict=True) if r[link_at]}
            if paths:
                links[group] = paths
    stack = _display(metric).get("stack")
    handle = writer.bar_chart(
        metric.name,
        series,
        x_axis_name=_axis(metric, "xaxis").label or cols[c_at],
        y_axis_name=_axis(metric, "yaxis").label or cols[v_at],
        legend=list(grouped),
        stack_bars=stack if isinstance(stack, bool) else None,
        **options,
    )
    if links:
        handle.tag(LINK_PATHS_TAG, json.dumps(links, sort_keys=True, separators=(",", ":")))
    return handle


def _histogram(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> MetricHandle:
    cols = result.columns
    bins = _display(metric).get("bins", DEFAULT_BINS)
    if not isinstance(bins, int) or isinstance(bins, bool) or bins < 1:
        raise RenderError(metric, f"template_settings.display.bins must be a positive int: {bins}")
    v_at = 0 if len(cols) == 1 else 1
    rows = [r for r in result.rows if r[v_at] is not None]
    values = _numbers(metric, [r[v_at] for r in rows], cols[v_at])
    if not values:
        raise RenderError(metric, f"column {cols[v_at]!r} holds only NULLs")
    axis = _axis(metric, "xaxis")
    lower = min(values) if axis.min is None else axis.min
    upper = max(values) if axis.max is None else axis.max
    if lower == upper:
        lower, upper = lower - 0.5, upper + 0.5
    if lower > upper:
        raise RenderError(metric, f"its range is empty: min {lower} is above max {upper}")
    index = None
    if v_at == 1:
        # The groups in the one histogram: its values indexed by each value's group.
        index = data.strings(f"{metric.name} / groups", [label(r[0]) for r in rows])
    return writer.histogram(
        metric.name,
        data.doubles(f"{metric.name} / values", values, index=index),
        buckets=bins,
        lower=lower,
        upper=upper,
        x_axis_name=axis.label or cols[v_at],
        **options,
    )


def _state_timeline(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> MetricHandle:
    _need(metric, result, 3)
    series, legend = [], []
    for system, rows in _groups(result.rows, 0).items():
        points = []
        for row in rows:
            at = timestamp_ns(row[1])
            if at is None:
                raise RenderError(metric, f"column {result.columns[1]!r} holds {row[1]!r}, no time")
            if row[2] is not None:
                points.append((at, label(row[2])))
        if not points:
            continue
        prefix = f"{metric.name} / {system}"
        times = data.timestamps(f"{prefix} / time", [p[0] for p in points])
        series.append(data.strings(prefix, [p[1] for p in points], index=times))
        legend.append(system)
    if not series:
        raise RenderError(metric, "every state is NULL")
    return writer.states_over_time(metric.name, series, legend=legend, **options)


# `display.text_info` as the platform spells it -> Plotly's `textinfo`.
_TEXT_INFO = {"none": "none"}


def _pie(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> MetricHandle:
    _need(metric, result, 2)
    labels = [label(r[0]) for r in result.rows]
    trace: dict[str, Any] = {
        "type": "pie",
        "labels": labels,
        "values": _numbers(metric, [r[1] for r in result.rows], result.columns[1]),
    }
    display = _display(metric)
    text_info = display.get("text_info")
    if text_info is not None:
        # label_percent -> label+percent: the platform's names join Plotly's flags by "_".
        flags = str(text_info)
        trace["textinfo"] = _TEXT_INFO.get(flags, flags.replace("_", "+"))
    colours = _colours(metric)
    if colours:
        trace["marker"] = {"colors": [colours.get(name) for name in labels]}
    layout: dict[str, Any] = {"title": {"text": metric.name}}
    legend = display.get("legend")
    if isinstance(legend, bool):
        layout["showlegend"] = legend
    elif legend == "bottom":
        layout["legend"] = {"orientation": "h", "y": -0.1}
    return writer.plotly(metric.name, {"data": [trace], "layout": layout}, **options)


def markdown_table(result: Result) -> str:
    """The result as a Markdown table, every value as the engine returned it."""
    return markdown_rows(result.columns, result.rows)


def markdown_rows(columns: list[str], rows: list[tuple[Any, ...]] | list[list[Any]]) -> str:
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
        "| " + " | ".join(cell(c) for c in columns) + " |",
        "|" + "---|" * len(columns),
    ]
    lines.extend("| " + " | ".join(cell(v) for v in row) + " |" for row in rows)
    return "\n".join(lines)


def _table(
    writer: MetricsWriter, metric: Metric, result: Result, options: MetricOptions
) -> MetricHandle:
    return writer.text(metric.name, markdown_table(result), **options)


def _basename(metric: Metric, value: Any) -> str:
    if not isinstance(value, str) or not value or "/" in value or "\\" in value:
        raise RenderError(metric, f"it names an attached file by its basename, not {value!r}")
    return value


def _media(
    writer: MetricsWriter,
    metric: Metric,
    result: Result,
    options: MetricOptions,
    attached: Callable[[str], bool] | None,
    job_media: Callable[[str], list[str]] | None,
) -> tuple[MetricHandle, list[str]]:
    """An image, video or artifact metric. Its query names the files by basename
    (`SELECT filename FROM camera`), or, where it has a `job_id` column, by job: a batch
    query `SELECT experience_name, job_id FROM camera` shows each row's job's files of
    the metric's kind (the one the row names, if it names one), as `<job_id>/<file>`,
    since every job may attach a file of the same name."""
    lowered = [c.lower() for c in result.columns]
    if job_media is not None and "job_id" in lowered and len(lowered) > 1:
        names = _job_files(metric, result, lowered.index("job_id"), job_media)
    else:
        names = [_basename(metric, v) for v in result.column(0) if v is not None]
    for name in names:
        if attached is not None and not attached(name):
            raise RenderError(metric, f"attached file {name!r} is in no job's folder")
    unique = list(dict.fromkeys(names))
    files = [data.external_file(f"{metric.name} / {name}", name) for name in unique]
    if len(files) == 1:
        handle = writer.image(metric.name, files[0], **options)
    else:
        handle = writer.image_list(metric.name, files, **options)
    if metric.template != "image":
        # JobMetrics has no video or artifact type: an external file, tagged with its kind.
        handle.tag(TEMPLATE_TAG, metric.template)
    return with_settings(handle, metric), unique


def _job_files(
    metric: Metric, result: Result, job_at: int, job_media: Callable[[str], list[str]]
) -> list[str]:
    label_at = 1 if job_at == 0 else 0
    names: list[str] = []
    for row in result.rows:
        if row[job_at] is None:
            continue
        job = str(row[job_at])
        files = [_basename(metric, f) for f in job_media(job)]
        if not files:
            raise RenderError(metric, f"job {job} has no {metric.template} file")
        chosen = [f for f in files if f == row[label_at]] or files
        names.extend(f"{job}/{f}" for f in chosen)
    return names


_RENDERERS: dict[str, Callable[[MetricsWriter, Metric, Result, MetricOptions], MetricHandle]] = {
    "scalar": _scalar,
    "line": _line,
    "bar": _bar,
    "histogram": _histogram,
    "state_timeline": _state_timeline,
    "pie": _pie,
    "table": _table,
}
