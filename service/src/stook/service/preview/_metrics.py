"""One metric's body, per metric type: a figure, a value, a table, text or images.

Every renderer reads the metric's values message and the metrics data it references
through the reader's views. What a file lacks (data it references but does not hold, an
image not beside it) is said in place, so a broken file still renders the rest.
"""

from __future__ import annotations

import base64
import html
import json
import re
import uuid
from bisect import bisect_right
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricsDataView, MetricType, MetricView, SeriesKind
from stook.service.preview._figures import Figures, bound_lines
from stook.service.preview._sources import Source, human_size
from stook.service.preview._style import PALETTE, category_colors, status_color
from stook.service.preview._values import (
    MAX_DRAWN,
    categories,
    exact_doubles,
    exact_text,
    index_of,
    number_text,
    pick,
    status_name,
    tally,
    thin,
    time_index,
    timestamp_text,
    values,
)

if TYPE_CHECKING:
    from markdown_it import MarkdownIt

# Larger image files are named, not embedded: a preview stays a file one can mail.
MAX_IMAGE_BYTES = 8_000_000
_IMAGE_TYPES = {
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".gif": "image/gif",
    ".webp": "image/webp",
    ".bmp": "image/bmp",
    ".svg": "image/svg+xml",
}


@dataclass
class Context:
    source: Source
    figures: Figures

    def data(self, ref: pb.MetricsDataId) -> MetricsDataView | None:
        try:
            return self.source.view.data_by_id.get(uuid.UUID(hex=ref.id.data))
        except ValueError:
            return None


def esc(text: object) -> str:
    return html.escape(str(text))


def missing(what: str) -> str:
    return f'<p class="placeholder">{esc(what)}</p>'


def _with_unit(name: str, unit: str) -> str:
    """An axis title with its unit once, in parentheses: "Distance [m]" as a writer may
    put it reads "Distance (m)", beside the "(m/s)" of a chart whose unit is the data's."""
    bracketed = _BRACKETED_UNIT.fullmatch(name)
    if bracketed is not None:
        name = f"{bracketed[1]} ({bracketed[2]})"
    return f"{name} ({unit})" if unit and unit.lower() not in name.lower() else name


_BRACKETED_UNIT = re.compile(r"(.*\S)\s*\[([^\[\]]+)\]")


def _thinned_note(longest: int) -> str | None:
    if longest <= MAX_DRAWN:
        return None
    return f"drawn thinned: ≤{MAX_DRAWN:,} of {longest:,} points per series (min/max kept)"


def _own_status(metric: MetricView) -> str:
    return status_name(int(metric.status or 0)) if isinstance(metric.status, int) else "NO_STATUS"


def telling(statuses: Sequence[str] | None, metric: MetricView) -> Sequence[str] | None:
    """Per-point statuses worth colouring by, or None when every point only repeats the
    metric's own status (what a writer records when given none): colours then follow
    what the chart shows, not a status its chip already says."""
    if not statuses:
        return None
    own = _own_status(metric)
    return statuses if set(tally(statuses)) - {own} else None


_FAILING = ("FAIL_WARN", "FAIL_BLOCK")


def _points_note(shown: Sequence[Sequence[str]], metric: MetricView, bounded: bool) -> str | None:
    """Why points beyond a chart's failure bound can sit in a passing metric: the
    points' statuses and the metric's are each as written, and only the metric's counts."""
    own = _own_status(metric)
    if not bounded or own in _FAILING:
        return None
    total = sum(len(s) for s in shown)
    counts = sum((tally(s) for s in shown), Counter[str]())
    failing = {f: counts[f] for f in _FAILING}
    said = [f"{n:,} {name}" for name, n in failing.items() if n]
    if not said:
        return None
    return (
        f"Points failing by their own status, in its colour: {' and '.join(said)} of "
        f"{total:,}. The metric's status, as written, is {own}, and the file's follows it."
    )


def _trace(
    name: str,
    xs: Sequence[Any] | None,
    ys: Sequence[Any],
    statuses: Sequence[str] | None,
    color: str,
) -> dict[str, Any]:
    """A line of (x, y) points, thinned for drawing; a failing point's marker in its
    status's colour, the others in the line's, so that what fails stands out."""
    positions = thin(ys)
    y = pick(ys, positions) or []
    x = pick(xs, positions) if xs is not None else list(positions)
    trace: dict[str, Any] = {
        "type": "scatter",
        "mode": "lines+markers" if len(y) <= 300 or statuses else "lines",
        "name": name,
        "x": x,
        "y": y,
        "line": {"color": color, "width": 1.5},
        "marker": {"color": color, "size": 5},
        "connectgaps": False,
    }
    if statuses:
        shown = pick(statuses, positions) or []
        colors = [status_color(s) if s in _FAILING else color for s in shown]
        trace["marker"] = {"color": colors, "size": 6}
        trace["text"] = shown
        trace["hovertemplate"] = "%{x}<br>%{y}<br>%{text}<extra>" + esc(name) + "</extra>"
    return trace


def _legend(names: Sequence[str], i: int, fallback: str) -> str:
    return names[i] if i < len(names) and names[i] else fallback


def _opt(message: Any, name: str) -> Any:
    return getattr(message, name) if message.HasField(name) else None


# ---------------------------------------------------------------- per type


def scalar(metric: MetricView, ctx: Context) -> str:
    del ctx
    mv = metric.raw.metric_values.scalar_metric_values
    if metric.value is None:
        body = '<p class="scalar">no value</p>'
    else:
        unit = f'<span class="unit">{esc(metric.unit)}</span>' if metric.unit else ""
        exact = esc(exact_text(metric.value))
        body = f'<p class="scalar" data-value="{exact}" title="{exact}">'
        body += f"{esc(number_text(metric.value))}{unit}</p>"
    failure = mv.failure_definition if mv.HasField("failure_definition") else None
    return body + _failure_text(failure)


def _failure_text(failure: pb.DoubleFailureDefinition | None) -> str:
    if failure is None:
        return ""
    parts = []
    if failure.HasField("fails_above"):
        parts.append(f"fails above {_number(failure.fails_above)}")
    if failure.HasField("fails_below"):
        parts.append(f"fails below {_number(failure.fails_below)}")
    return f'<p class="note">{", ".join(parts)}</p>' if parts else ""


def _number(value: float | None) -> str:
    """A value as people read it, the exact value on hover."""
    return f'<span title="{esc(exact_text(value))}">{esc(number_text(value))}</span>'


def double_summary(metric: MetricView, ctx: Context) -> str:
    mv = metric.raw.metric_values.double_metric_values
    data = ctx.data(mv.value_data_id)
    if data is None:
        return missing("its values data is not in the file")
    statuses = ctx.data(mv.status_data_id) if mv.HasField("status_data_id") else None
    which = mv.WhichOneof("index")
    index_values: Sequence[Any] | None = None
    if which is None or which == "series_index":
        wanted: Any = mv.series_index
        where = f"element {mv.series_index}"
    elif which == "timestamp_index":
        index_values, relative = time_index(ctx.source.view, data)
        stamp = mv.timestamp_index
        if relative:
            wanted = stamp.seconds + stamp.nanos / 1e9
            where = f"{number_text(wanted)} s"
        else:
            wanted = timestamp_text(stamp.seconds, stamp.nanos)
            where = wanted.removesuffix(".000000") + " UTC"
    else:
        wanted = mv.uuid_index.data if which == "uuid_index" else mv.string_index
        where = f"index {wanted}"
        index_values = index_of(ctx.source.view, data)

    def position(length: int, index: Sequence[Any] | None) -> int | None:
        if index is None:
            return wanted if isinstance(wanted, int) and wanted < length else None
        return index.index(wanted) if wanted in index else None

    rows: list[tuple[str, float | None, str | None]] = []
    status_by_category = categories(statuses) if statuses is not None else {}
    if data.per_category:
        for category, series in _double_categories(data).items():
            at = position(len(series), index_values)
            status = status_by_category.get(category, [])
            rows.append(
                (
                    category,
                    series[at] if at is not None else None,
                    status[at] if at is not None and at < len(status) else None,
                )
            )
    else:
        series = exact_doubles(data)
        at = position(len(series), index_values)
        status_series = values(statuses) if statuses is not None else []
        rows.append(
            (
                data.name,
                series[at] if at is not None else None,
                status_series[at] if at is not None and at < len(status_series) else None,
            )
        )
    cells = "".join(
        f"<tr><td>{esc(name)}</td><td class='num'>{_number(value)}</td>"
        f"<td>{_chip(status) if status else ''}</td></tr>"
        for name, value, status in rows
    )
    unit = f" ({esc(data.unit)})" if data.unit else ""
    table = (
        f"<table class='summary'><tr><th>{'category' if data.per_category else 'data'}</th>"
        f"<th>value{unit} at {esc(where)}</th><th>status</th></tr>{cells}</table>"
    )
    return table + _failure_text(
        mv.failure_definition if mv.HasField("failure_definition") else None
    )


def _double_categories(data: MetricsDataView) -> dict[str, list[float]]:
    by_category = data.raw.series_per_category.category_to_series
    order = [*data.categories, *sorted(set(by_category) - set(data.categories))]
    return {c: list(by_category[c].doubles.series) for c in order if c in by_category}


def _time_axis(relative: bool) -> dict[str, Any]:
    if relative:
        return {"title": {"text": "time from the start (s)"}}
    return {"title": {"text": "time (UTC)"}, "type": "date"}


def _time_text(at: Any, relative: bool) -> Any:
    return at.seconds + at.nanos / 1e9 if relative else timestamp_text(at.seconds, at.nanos)


def _notes(said: Sequence[str | None]) -> str:
    return "".join(f'<p class="note">{esc(s)}</p>' for s in said if s)


def double_over_time(metric: MetricView, ctx: Context) -> str:
    mv = metric.raw.metric_values.double_over_time_metric_values
    traces: list[dict[str, Any]] = []
    shapes: list[dict[str, Any]] = []
    labels: list[dict[str, Any]] = []
    points: list[Sequence[str]] = []
    longest, unit, said, relative = 0, "", [], True
    for i, ref in enumerate(mv.doubles_over_time_data_id):
        data = ctx.data(ref)
        if data is None:
            said.append(f"series {i + 1}: data not in the file")
            continue
        ys = values(data)
        longest = max(longest, len(ys))
        unit = unit or data.unit
        status_data = (
            ctx.data(mv.statuses_over_time_data_id[i])
            if i < len(mv.statuses_over_time_data_id)
            else None
        )
        statuses = telling(values(status_data) if status_data is not None else None, metric)
        points += [statuses] if statuses else []
        times, series_relative = time_index(ctx.source.view, data)
        relative = relative and series_relative
        name = _legend(mv.legend_series_names, i, data.name)
        traces.append(_trace(name, times, ys, statuses, PALETTE[i % len(PALETTE)]))
        if i < len(mv.failure_definition):
            failure = mv.failure_definition[i]
            s, a = bound_lines(_opt(failure, "fails_above"), _opt(failure, "fails_below"))
            shapes += s
            labels += a
    relative = relative and bool(traces)
    xaxis = _time_axis(relative)
    if mv.HasField("start_time") and mv.HasField("end_time"):
        xaxis["range"] = [_time_text(mv.start_time, relative), _time_text(mv.end_time, relative)]
    y_name = mv.y_axis_name if mv.HasField("y_axis_name") else (traces and traces[0]["name"])
    layout = {
        "xaxis": xaxis,
        "yaxis": {"title": {"text": _with_unit(str(y_name or ""), unit)}},
        "shapes": shapes,
        "annotations": labels,
        "showlegend": len(traces) > 1,
    }
    figure = ctx.figures.add(traces, layout, metric=metric.name, thinned=_thinned_note(longest))
    return figure + _notes([*said, _points_note(points, metric, bool(shapes))])


# The report's line plots count days from its first batch; drawn as the batches' dates.
_DAYS_SINCE = re.compile(r"Days since (\d{4}-\d{2}-\d{2} \d{2}:\d{2}) UTC")


def _days_as_dates(x_name: str, xs: Sequence[Any]) -> list[Any] | None:
    since = _DAYS_SINCE.fullmatch(x_name)
    if since is None:
        return None
    origin = datetime.fromisoformat(since[1])
    return [
        (origin + timedelta(days=x)).isoformat(sep=" ", timespec="seconds")
        if isinstance(x, float)
        else None
        for x in xs
    ]


def line_plot(metric: MetricView, ctx: Context) -> str:
    mv = metric.raw.metric_values.line_plot_metric_values
    traces: list[dict[str, Any]] = []
    longest, x_unit, y_unit, said = 0, "", "", []
    x_name = mv.x_axis_name if mv.HasField("x_axis_name") else ""
    y_name = mv.y_axis_name if mv.HasField("y_axis_name") else ""
    dated = _DAYS_SINCE.fullmatch(x_name) is not None
    for i, (x_ref, y_ref) in enumerate(
        zip(mv.x_doubles_data_id, mv.y_doubles_data_id, strict=False)
    ):
        x_data, y_data = ctx.data(x_ref), ctx.data(y_ref)
        if x_data is None or y_data is None:
            said.append(f"series {i + 1}: data not in the file")
            continue
        ys = values(y_data)
        longest = max(longest, len(ys))
        x_unit, y_unit = x_unit or x_data.unit, y_unit or y_data.unit
        status_data = ctx.data(mv.statuses_data_id[i]) if i < len(mv.statuses_data_id) else None
        statuses = telling(values(status_data) if status_data is not None else None, metric)
        xs = values(x_data)
        traces.append(
            _trace(
                _legend(mv.legend_series_names, i, y_data.name),
                _days_as_dates(x_name, xs) or xs,
                ys,
                statuses,
                PALETTE[i % len(PALETTE)],
            )
        )
    xaxis = (
        {"title": {"text": "batch time (UTC)"}, "type": "date"}
        if dated
        else {"title": {"text": _with_unit(x_name, x_unit)}}
    )
    layout = {
        "xaxis": xaxis,
        "yaxis": {"title": {"text": _with_unit(y_name, y_unit)}},
        "showlegend": len(traces) > 1,
    }
    figure = ctx.figures.add(traces, layout, metric=metric.name, thinned=_thinned_note(longest))
    return figure + _notes(said)


@dataclass
class _Bars:
    name: str
    labels: list[str]
    ys: list[Any]
    statuses: Sequence[str] | None


def bar_chart(metric: MetricView, ctx: Context) -> str:
    mv = metric.raw.metric_values.bar_chart_metric_values
    series: list[_Bars] = []
    unit = ""
    for i, ref in enumerate(mv.values_data_id):
        data = ctx.data(ref)
        if data is None:
            continue
        unit = unit or data.unit
        ys = values(data)
        labels = index_of(ctx.source.view, data) or [str(n) for n in range(len(ys))]
        status_data = ctx.data(mv.statuses_data_id[i]) if i < len(mv.statuses_data_id) else None
        statuses = values(status_data) if status_data is not None else None
        name = _legend(mv.legend_series_names, i, data.name)
        series.append(_Bars(name, [str(label) for label in labels], list(ys), statuses))
    interval = _interval_bars(series)
    traces = (
        [interval] if interval else [_bars(b, i, len(series), metric) for i, b in enumerate(series)]
    )
    stacked = mv.stack_bars if mv.HasField("stack_bars") else False
    layout = {
        "barmode": "stack" if stacked else "group",
        "xaxis": {
            "title": {"text": mv.x_axis_name if mv.HasField("x_axis_name") else ""},
            "type": "category",
        },
        "yaxis": {"title": {"text": _with_unit(mv.y_axis_name, unit)}},
        "showlegend": len(traces) > 1,
    }
    return ctx.figures.add(traces, layout, metric=metric.name)


def _bars(bars: _Bars, i: int, count: int, metric: MetricView) -> dict[str, Any]:
    """One series of bars. Alone, its bars take the colours of what they are (bars named
    PASSED, BLOCKER...) or else of their own statuses where these say more than the
    metric's; beside others, the series' colour."""
    color: Any = PALETTE[i % len(PALETTE)]
    statuses = telling(bars.statuses, metric)
    if count == 1:
        by_name = category_colors(bars.labels)
        if by_name is not None:
            color = by_name
        elif statuses:
            color = [status_color(s) for s in statuses]
    trace: dict[str, Any] = {
        "type": "bar",
        "name": bars.name,
        "x": bars.labels,
        "y": bars.ys,
        "marker": {"color": color},
    }
    if bars.statuses:
        trace["text"] = list(bars.statuses)
        trace["textposition"] = "none"
    return trace


_INTERVAL_PART = re.compile(r"(\d+(?:\.\d+)?) % (low|high)")


def _interval_bars(series: Sequence[_Bars]) -> dict[str, Any] | None:
    """A value and its interval written as three series ("Mean", "95 % low", "95 % high":
    a baseline comparison's), drawn as one series of bars with error bars; None for any
    other chart."""
    if len(series) != 3:
        return None
    value, low, high = series
    low_name, high_name = _INTERVAL_PART.fullmatch(low.name), _INTERVAL_PART.fullmatch(high.name)
    if (
        low_name is None
        or high_name is None
        or (low_name[2], high_name[2]) != ("low", "high")
        or low_name[1] != high_name[1]
        or not value.labels == low.labels == high.labels
    ):
        return None

    def distance(a: Any, b: Any) -> float:
        return a - b if isinstance(a, float) and isinstance(b, float) else 0.0

    return {
        "type": "bar",
        "name": value.name,
        "x": value.labels,
        "y": value.ys,
        "error_y": {
            "type": "data",
            "symmetric": False,
            "array": [distance(h, y) for h, y in zip(high.ys, value.ys, strict=True)],
            "arrayminus": [distance(y, lo) for y, lo in zip(value.ys, low.ys, strict=True)],
            "color": "#202124",
            "thickness": 1.5,
            "width": 10,
        },
        "customdata": [[lo, h] for lo, h in zip(low.ys, high.ys, strict=True)],
        "hovertemplate": f"%{{x}}: %{{y}}<br>{low_name[1]} % interval "
        "[%{customdata[0]}, %{customdata[1]}]<extra></extra>",
        "marker": {"color": PALETTE[0]},
    }


def histogram(metric: MetricView, ctx: Context) -> str:
    mv = metric.raw.metric_values.histogram_metric_values
    data = ctx.data(mv.values_data_id)
    if data is None:
        return missing("its values data is not in the file")
    numbers = exact_doubles(data)
    buckets = [(b.lower, b.upper) for b in mv.buckets]
    counts, outside = bucket_counts(numbers, buckets)
    trace = {
        "type": "bar",
        "name": data.name,
        "x": [(lo + hi) / 2 for lo, hi in buckets],
        "width": [hi - lo for lo, hi in buckets],
        "y": counts,
        "customdata": [[lo, hi] for lo, hi in buckets],
        "hovertemplate": "[%{customdata[0]}, %{customdata[1]}): %{y}<extra></extra>",
        "marker": {"color": PALETTE[0], "line": {"color": "#fff", "width": 1}},
    }
    x_name = mv.x_axis_name if mv.HasField("x_axis_name") else data.name
    layout = {
        "xaxis": {"title": {"text": _with_unit(x_name, data.unit)}},
        "yaxis": {"title": {"text": "count"}},
        "bargap": 0,
    }
    note = f"{len(numbers):,} values in {len(buckets)} buckets"
    if outside:
        note += f"; {outside:,} outside them"
    return ctx.figures.add([trace], layout, metric=metric.name) + f'<p class="note">{note}</p>'


def bucket_counts(
    numbers: Sequence[float], buckets: Sequence[tuple[float, float]]
) -> tuple[list[int], int]:
    """Counts per bucket as written (not re-binned), and how many values fall outside.

    A value counts in the bucket whose lower edge it reaches, the last bucket holding its
    upper bound too, as the platform counts. Buckets are contiguous (the validator's rule),
    so the lower edges are sorted and a bisection finds each value's bucket.
    """
    counts = [0] * len(buckets)
    if not buckets:
        return counts, len(numbers)
    lowers = [lo for lo, _ in buckets]
    top = buckets[-1][1]
    outside = 0
    for v in numbers:
        i = bisect_right(lowers, v) - 1
        if i < 0 or v > top or (v == top and i != len(buckets) - 1) or v != v:
            outside += 1
        elif v < buckets[i][1] or i == len(buckets) - 1:
            counts[i] += 1
        else:  # in a hole between non-contiguous buckets
            outside += 1
    return counts, outside


def batchwise_bar_chart(metric: MetricView, ctx: Context) -> str:
    mv = metric.raw.metric_values.batchwise_bar_chart_metric_values
    traces: list[dict[str, Any]] = []
    unit = ""
    for i, (t_ref, v_ref) in enumerate(zip(mv.times_data_id, mv.values_data_id, strict=False)):
        times, vals = ctx.data(t_ref), ctx.data(v_ref)
        if times is None or vals is None:
            continue
        unit = unit or vals.unit
        category = mv.categories[i] if i < len(mv.categories) else vals.name
        color = mv.colors[i] if i < len(mv.colors) and mv.colors[i] else None
        status_data = ctx.data(mv.statuses_data_id[i]) if i < len(mv.statuses_data_id) else None
        statuses = values(status_data) if status_data is not None else None
        by_name = category_colors([category])
        statuses = telling(statuses, metric)
        marker: Any = color or (by_name[0] if by_name else None)
        if marker is None:
            marker = [status_color(s) for s in statuses] if statuses else PALETTE[i % 7]
        traces.append(
            {
                "type": "bar",
                "name": category,
                "x": list(values(times)),
                "y": list(values(vals)),
                "customdata": list(index_of(ctx.source.view, vals) or []),
                "hovertemplate": "%{x}<br>%{y}<br>batch %{customdata}<extra>"
                + esc(category)
                + "</extra>",
                "marker": {"color": marker},
            }
        )
    stacked = mv.stack_bars if mv.HasField("stack_bars") else True
    layout = {
        "barmode": "stack" if stacked else "group",
        "xaxis": {
            "title": {"text": mv.x_axis_name if mv.HasField("x_axis_name") else "batch time (UTC)"},
            "type": "date",
        },
        "yaxis": {"title": {"text": _with_unit(mv.y_axis_name, unit)}},
        "showlegend": len(traces) > 1,
    }
    return ctx.figures.add(traces, layout, metric=metric.name)


def states_over_time(metric: MetricView, ctx: Context) -> str:
    mv = metric.raw.metric_values.states_over_time_metric_values
    failing = set(mv.failure_states)
    traces: list[dict[str, Any]] = []
    seen: list[str] = list(mv.states_set)
    longest, relative = 0, True
    for i, ref in enumerate(mv.states_over_time_data_id):
        data = ctx.data(ref)
        if data is None:
            continue
        states = values(data)
        longest = max(longest, len(states))
        seen += [s for s in dict.fromkeys(states) if s not in seen]
        status_data = (
            ctx.data(mv.statuses_over_time_data_id[i])
            if i < len(mv.statuses_over_time_data_id)
            else None
        )
        statuses = telling(values(status_data) if status_data is not None else None, metric)
        times, series_relative = time_index(ctx.source.view, data)
        relative = relative and series_relative
        trace = _trace(
            _legend(mv.legend_series_names, i, data.name),
            times,
            states,
            None,
            PALETTE[i % len(PALETTE)],
        )
        trace["line"]["shape"] = "hv"
        trace["mode"] = "lines+markers"
        shown = trace["y"]
        # The statuses of the points drawn: the same positions as the states'. A failure
        # state, or a failing point, stands out; the rest is in the line's colour.
        shown_statuses = list(pick(statuses, thin(states)) or []) if statuses else []
        shown_statuses += [""] * (len(shown) - len(shown_statuses))
        line = PALETTE[i % len(PALETTE)]
        colors = [
            status_color("FAIL_BLOCK")
            if state in failing
            else (status_color(status) if status in _FAILING else line)
            for state, status in zip(shown, shown_statuses, strict=False)
        ]
        trace["marker"] = {"color": colors, "size": 6}
        traces.append(trace)
    layout = {
        "xaxis": _time_axis(relative and bool(traces)),
        "yaxis": {
            "title": {"text": "state"},
            "type": "category",
            "categoryorder": "array",
            "categoryarray": seen,
            "range": [-0.5, len(seen) - 0.5],
        },
        "showlegend": len(traces) > 1,
    }
    note = f"failure states: {', '.join(mv.failure_states)}" if mv.failure_states else ""
    figure = ctx.figures.add(traces, layout, metric=metric.name, thinned=_thinned_note(longest))
    return figure + (f'<p class="note">{esc(note)}</p>' if note else "")


@cache
def _markdown() -> MarkdownIt:
    """CommonMark and tables, raw HTML escaped, never passed on: with ``html`` off,
    markdown-it-py renders any HTML in the text as text, and its link check refuses
    ``javascript:`` and other script URLs, so a metric's text cannot run code in the
    page. ``breaks``: a line break as written stays one, as in the text a run printed
    (a comparison's lines, one per finding), where CommonMark would join the lines."""
    from markdown_it import MarkdownIt

    return MarkdownIt("commonmark", {"html": False, "linkify": False, "breaks": True}).enable(
        "table"
    )


def markdown_html(text: str) -> str:
    rendered: str = _markdown().render(text)
    return rendered


def text(metric: MetricView, ctx: Context) -> str:
    del ctx
    body = metric.raw.metric_values.text_metric_values.text
    return f'<div class="text">{markdown_html(body)}</div>'


def plotly(metric: MetricView, ctx: Context) -> str:
    from google.protobuf.json_format import MessageToDict

    mv = metric.raw.metric_values.plotly_metric_values
    figure = MessageToDict(mv.json) if mv.HasField("json") else {}
    if not isinstance(figure.get("data"), list) or not figure["data"]:
        return missing("its plotly figure has no data")
    # Struct numbers are doubles; plotly reads them as they are.
    figure = json.loads(json.dumps(figure, allow_nan=False, default=str))
    return ctx.figures.add_plotly(figure, metric=metric.name)


def image(metric: MetricView, ctx: Context) -> str:
    refs = [metric.raw.metric_values.image_metric_values.image_data_id]
    return _images(refs, ctx)


def image_list(metric: MetricView, ctx: Context) -> str:
    return _images(list(metric.raw.metric_values.image_list_metric_values.image_data_ids), ctx)


def _images(refs: Sequence[pb.MetricsDataId], ctx: Context) -> str:
    parts = []
    for ref in refs:
        data = ctx.data(ref)
        if data is None or data.external_path is None:
            parts.append(missing("an image whose data is not in the file"))
            continue
        parts.append(_image(data, ctx.source.folder))
    return f'<div class="images">{"".join(parts)}</div>'


def _image(data: MetricsDataView, folder: Path | None) -> str:
    path = data.external_path or ""
    caption = f"<figcaption>{esc(data.name)} · <code>{esc(path)}</code></figcaption>"
    reason = _image_unavailable(path, folder)
    if reason is not None:
        return f'<figure><div class="placeholder">{esc(reason)}</div>{caption}</figure>'
    assert folder is not None
    file = (folder / path).resolve()
    payload = base64.b64encode(file.read_bytes()).decode("ascii")
    mime = _IMAGE_TYPES[file.suffix.lower()]
    return (
        f'<figure><img src="data:{mime};base64,{payload}" alt="{esc(data.name)}">{caption}</figure>'
    )


def _image_unavailable(path: str, folder: Path | None) -> str | None:
    if folder is None:
        return "image not shown: the preview was made from a message, not a file"
    root = folder.resolve()
    file = (root / path).resolve()
    if not file.is_relative_to(root):
        return "image not shown: its path leads out of the file's folder"
    if not file.is_file():
        return f"image {path!r} is not beside the file"
    if file.suffix.lower() not in _IMAGE_TYPES:
        return f"{path!r} is not an image type a browser shows"
    size = file.stat().st_size
    if size > MAX_IMAGE_BYTES:
        return f"{path!r} is {human_size(size)}: too large to embed"
    return None


def _chip(status: str) -> str:
    return f'<span class="chip" style="background:{status_color(status)}">{esc(status)}</span>'


def status_chip(value: int | None) -> str:
    return _chip(status_name(int(value or 0)))


RENDERERS: dict[MetricType, Callable[[MetricView, Context], str]] = {
    MetricType.SCALAR: scalar,
    MetricType.DOUBLE_SUMMARY: double_summary,
    MetricType.DOUBLE_OVER_TIME: double_over_time,
    MetricType.LINE_PLOT: line_plot,
    MetricType.BAR_CHART: bar_chart,
    MetricType.HISTOGRAM: histogram,
    MetricType.BATCHWISE_BAR_CHART: batchwise_bar_chart,
    MetricType.STATES_OVER_TIME: states_over_time,
    MetricType.TEXT: text,
    MetricType.PLOTLY: plotly,
    MetricType.IMAGE: image,
    MetricType.IMAGE_LIST: image_list,
}

CHART_TYPES = frozenset(
    {
        MetricType.DOUBLE_OVER_TIME,
        MetricType.LINE_PLOT,
        MetricType.BAR_CHART,
        MetricType.HISTOGRAM,
        MetricType.BATCHWISE_BAR_CHART,
        MetricType.STATES_OVER_TIME,
        MetricType.PLOTLY,
    }
)
"""The types drawn as exactly one figure each."""


def body(metric: MetricView, ctx: Context) -> str:
    if not isinstance(metric.type, MetricType):
        return missing(f"metric type {metric.type} is not one this preview knows")
    try:
        return RENDERERS[metric.type](metric, ctx)
    except Exception as exc:  # one broken metric must not hide the rest of the file
        return missing(f"could not draw this metric: {exc.__class__.__name__}: {exc}")


def kind_text(data: MetricsDataView) -> str:
    if data.kind is None:
        return f"data type {data.raw.data_type}"
    if data.kind is SeriesKind.EXTERNAL_FILE:
        return "external file"
    return str(data.kind.value) + (" per category" if data.per_category else "")
