"""The page: one column per file, one row per metric name so the same metric lines up.

Rows follow the dashboard's order: importance (critical first), then the metric's
``order`` where it has one, then the order written. plotly.js is embedded once, and the
figures' JSON once, after the content; nothing is fetched when the page opens.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from functools import cache
from pathlib import Path
from typing import Any

from stook.sdk import EventView, MetricsDataView, MetricView
from stook.service.preview._figures import Figures
from stook.service.preview._metrics import Context, body, esc, kind_text, status_chip
from stook.service.preview._sources import Source, human_size
from stook.service.preview._style import CSS, ERROR_COLOR, status_color
from stook.service.preview._values import status_name, timestamp_text

_SCRIPT = """
(function () {
  var specs = JSON.parse(document.getElementById("stook-figures").textContent);
  var config = {responsive: true, displaylogo: false};
  var drawn = specs.map(function (f) {
    return Plotly.newPlot(f.id, f.data, f.layout, config);
  });
  Promise.all(drawn).then(function () { document.body.dataset.figures = String(specs.length); });
  window.addEventListener("beforeprint", function () {
    specs.forEach(function (f) { Plotly.Plots.resize(f.id); });
  });
})();
"""


@cache
def plotly_js() -> str:
    """plotly.js as the plotly package ships it, read once per process.

    Found without importing the plotly package, whose import pulls in its Python figure
    machinery that a preview does not use.
    """
    import importlib.util

    spec = importlib.util.find_spec("plotly")
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError("the plotly package is not installed", name="plotly")
    folder = Path(next(iter(spec.submodule_search_locations)))
    script = (folder / "package_data" / "plotly.min.js").read_text(encoding="utf-8")
    # Inert insurance: no text in the library may end the script element early.
    return script.replace("</script", "<\\/script")


def _sort_key(position: int, metric: MetricView) -> tuple[float, float, int]:
    importance = metric.importance if isinstance(metric.importance, int) else 0
    order = metric.order if metric.order is not None and math.isfinite(metric.order) else math.inf
    return (-float(importance or 0), order, position)


def _event_metric_ids(source: Source) -> set[Any]:
    return {m for e in source.view.events for m in e.metric_ids}


def _rows(sources: Sequence[Source]) -> list[tuple[str, list[MetricView | None]]]:
    """(key, the metric of that name in each file) in dashboard order."""
    keys: dict[str, list[MetricView | None]] = {}
    for column, source in enumerate(sources):
        in_events = _event_metric_ids(source)
        shown = [
            (i, m)
            for i, m in enumerate(source.view.metrics)
            if not (m.event_metric and m.id in in_events)
        ]
        seen: dict[str, int] = {}
        for _, metric in sorted(shown, key=lambda pair: _sort_key(*pair)):
            seen[metric.name] = seen.get(metric.name, 0) + 1
            key = metric.name if seen[metric.name] == 1 else f"{metric.name} #{seen[metric.name]}"
            keys.setdefault(key, [None] * len(sources))[column] = metric
    return list(keys.items())


def _enum_text(value: Any) -> str:
    return value.name if hasattr(value, "name") else str(value)


# How `stook metrics-config` marks a config-defined metric that failed: the platform's
# ERROR (its query) or RENDER_ERROR (its template), as a tag, JobMetrics having no such
# status (the metric itself is NOT_APPLICABLE, its text the message).
ERROR_TAG = "error"
ERROR_MARKS = ("ERROR", "RENDER_ERROR")
# A tag's value longer than this (a config metric's template_settings, as JSON) is folded.
LONG_TAG = 48


def _tag(key: str, value: str) -> str:
    if len(value) <= LONG_TAG:
        return f'<span class="tag">{esc(key)}: {esc(value)}</span>'
    return f'<details class="tag"><summary>{esc(key)}</summary><code>{esc(value)}</code></details>'


def metric_card(metric: MetricView, ctx: Context) -> str:
    meta = [status_chip(metric.status if isinstance(metric.status, int) else None)]
    error = next((v for k, v in metric.tags if k == ERROR_TAG and v in ERROR_MARKS), None)
    if error is not None:
        meta.insert(0, f'<span class="chip" style="background:{ERROR_COLOR}">{esc(error)}</span>')
    meta.append(f"<span>{esc(_enum_text(metric.type))}</span>")
    if isinstance(metric.importance, int) and metric.importance:
        meta.append(f"<span>{esc(_enum_text(metric.importance).lower())} importance</span>")
    if metric.blocking:
        meta.append('<span class="blocking">blocking</span>')
    if metric.should_display is False:
        meta.append("<span>hidden on the dashboard</span>")
    meta += [_tag(k, v) for k, v in metric.tags if not (k == ERROR_TAG and v == error)]
    description = _description(metric.description) if metric.description else ""
    type_name = _enum_text(metric.type)
    return (
        f'<article class="card metric{" failed" if error else ""}" '
        f'data-metric="{esc(metric.name)}" '
        f'data-type="{esc(type_name)}"><h2>{esc(metric.name)}</h2>'
        f'<div class="meta">{"".join(meta)}</div>{description}{body(metric, ctx)}</article>'
    )


# Longer descriptions fold to their lead: a report's every line plot explains itself in
# a paragraph, and the charts are what a reader scans.
FOLDED_DESCRIPTION = 160
_LEAD = re.compile(r"(.{12,120}?[:.;])\s")


def _description(text: str) -> str:
    if len(text) <= FOLDED_DESCRIPTION:
        return f'<p class="desc">{esc(text)}</p>'
    lead = _LEAD.match(text)
    if lead is not None:
        summary, rest = lead[1], text[lead.end() :]
    else:
        summary = text[:100].rsplit(" ", 1)[0] + " …"
        rest = text
    return f'<details class="desc"><summary>{esc(summary)}</summary><p>{esc(rest)}</p></details>'


def _count(n: int, noun: str) -> str:
    return f"{n:,} {noun}" + ("" if n == 1 else "s")


def _header_card(source: Source) -> str:
    view = source.view
    status = status_name(int(view.status or 0)) if isinstance(view.status, int) else "NO_STATUS"
    counts = (
        f"{_count(len(view.metrics), 'metric')} · {len(view.data)} metrics data · "
        f"{_count(len(view.events), 'event')} · {human_size(source.size)}"
    )
    if source.problems:
        shown = source.problems[:20]
        more = len(source.problems) - len(shown)
        items = "".join(f"<li>{esc(p)}</li>" for p in shown)
        items += f"<li>… and {more} more</li>" if more else ""
        findings = (
            f'<p class="note">The platform would refuse this file: '
            f'{len(source.problems)} problem(s).</p><ul class="problems">{items}</ul>'
        )
    else:
        findings = ""
    verdict = (
        f'<span class="blocking">{_count(len(source.problems), "problem")}</span>'
        if source.problems
        else '<span class="ok">valid: the validator finds no problem</span>'
    )
    job = f"job {view.job_id}" if view.job_id else "no job ID"
    return (
        f'<article class="card file" data-file="{esc(source.label)}">'
        f"<h3>{esc(source.label)}</h3>"
        f'<div class="meta"><span class="chip" style="background:{status_color(status)}">'
        f"{esc(status)}</span><span>{counts}</span><span>{esc(job)}</span>{verdict}</div>"
        f"{findings}</article>"
    )


def _event_time(event: EventView) -> Any:
    if event.timestamp_ns is None:
        return None
    seconds, nanos = divmod(event.timestamp_ns, 1_000_000_000)
    if event.timestamp_type == "relative":
        return event.timestamp_ns / 1e9
    return timestamp_text(seconds, nanos)


def _event_range(timed: Sequence[EventView], relative: bool) -> list[Any]:
    """The events' span, widened so a lone event sits in a readable minute, not a
    millisecond."""
    times = [e.timestamp_ns or 0 for e in timed]
    low, high = min(times), max(times)
    pad = max((high - low) // 10, 30_000_000_000)
    low, high = low - pad, high + pad
    if relative:
        return [low / 1e9, high / 1e9]
    return [timestamp_text(*divmod(t, 1_000_000_000)) for t in (low, high)]


def _events_card(ctx: Context) -> str:
    view = ctx.source.view
    if not view.events:
        return '<article class="card absent">no events</article>'
    timed = [e for e in view.events if e.timestamp_ns is not None]
    parts = []
    if timed:
        relative = all(e.timestamp_type == "relative" for e in timed)
        statuses = [status_name(int(e.status or 0)) for e in timed]
        trace = {
            "type": "scatter",
            "mode": "markers+text",
            "x": [_event_time(e) for e in timed],
            "y": [e.name for e in timed],
            "text": [e.name for e in timed],
            "textposition": "top center",
            "marker": {"color": [status_color(s) for s in statuses], "size": 12},
            "hovertext": statuses,
        }
        layout = {
            "height": 150 + 16 * len({e.name for e in timed}),
            "xaxis": {
                "title": {"text": "time from the start (s)" if relative else "time (UTC)"},
                "range": _event_range(timed, relative),
                **({} if relative else {"type": "date"}),
            },
            "yaxis": {"type": "category", "showticklabels": False},
            "showlegend": False,
        }
        parts.append(ctx.figures.add([trace], layout, metric="Events"))
    for event in view.events:
        meta = [status_chip(event.status if isinstance(event.status, int) else None)]
        when = _event_time(event)
        if when is not None:
            meta.append(f"<span>{esc(when if isinstance(when, str) else f'{when:g} s')}</span>")
        if isinstance(event.importance, int) and event.importance:
            meta.append(f"<span>{esc(_enum_text(event.importance).lower())} importance</span>")
        meta += [f'<span class="tag">{esc(t)}</span>' for t in event.tags]
        metrics = [view.metrics_by_id[m] for m in event.metric_ids if m in view.metrics_by_id]
        description = f'<p class="desc">{esc(event.description)}</p>' if event.description else ""
        parts.append(
            f'<section class="event" data-event="{esc(event.name)}"><h2>{esc(event.name)}</h2>'
            f'<div class="meta">{"".join(meta)}</div>{description}'
            + "".join(metric_card(m, ctx) for m in metrics)
            + "</section>"
        )
    return f'<article class="card events">{"".join(parts)}</article>'


def _referenced(source: Source) -> set[Any]:
    view = source.view
    used = {d for m in view.metrics for d in m.data_ids}
    used |= {d.index_id for d in view.data if d.id in used and d.index_id is not None}
    return used


def _data_card(source: Source) -> str:
    used = _referenced(source)
    alone: list[MetricsDataView] = [d for d in source.view.data if d.id not in used]
    if not alone:
        return '<article class="card absent">every metrics data is drawn by a metric</article>'
    rows = "".join(
        f"<tr><td>{esc(d.name)}</td><td>{esc(kind_text(d))}</td><td>{esc(d.unit)}</td>"
        f"<td>{esc(d.external_path) if d.external_path is not None else _length(d)}</td></tr>"
        for d in alone
    )
    return (
        '<article class="card data"><p class="note">Metrics data no metric draws (kept for '
        "batch and report metrics); external files are named, not fetched.</p>"
        f"<table><tr><th>name</th><th>kind</th><th>unit</th><th>values / file</th></tr>"
        f"{rows}</table></article>"
    )


def _length(data: MetricsDataView) -> str:
    raw = data.raw
    if data.kind is None:
        return ""
    if data.per_category:
        series = list(raw.series_per_category.category_to_series.values())
    else:
        series = [raw.series]
    total = 0
    for s in series:
        which = s.WhichOneof("series")
        total += len(getattr(s, which).series) if which else 0
    return _count(total, "value")


def page(sources: Sequence[Source]) -> str:
    figures = Figures()
    contexts = [Context(source, figures) for source in sources]
    cells: list[str] = [_header_card(s) for s in sources]
    cells.append('<h2 class="section">Metrics</h2>')
    for key, metrics in _rows(sources):
        for ctx, metric in zip(contexts, metrics, strict=True):
            cells.append(
                metric_card(metric, ctx)
                if metric is not None
                else f'<article class="card absent">{esc(key)}: not in this file</article>'
            )
    if any(s.view.events for s in sources):
        cells.append('<h2 class="section">Events</h2>')
        cells += [_events_card(ctx) for ctx in contexts]
    cells.append('<h2 class="section">Metrics data</h2>')
    cells += [_data_card(s) for s in sources]
    names = ", ".join(s.label for s in sources)
    specs = json.dumps(figures.specs, allow_nan=False, separators=(",", ":"))
    # "<" never appears unescaped, so no text in the JSON can end the script element.
    specs = specs.replace("<", "\\u003c")
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>stook preview: {esc(names)}</title><style>{CSS}</style></head>"
        f'<body><header class="page"><h1>stook preview</h1><p>{esc(names)} '
        "· values to six significant digits, exact on hover; charts with many points drawn "
        "thinned</p></header>"
        f'<main class="grid{" single" if len(sources) == 1 else ""}" '
        f'style="--columns:{len(sources)}">{"".join(cells)}</main>'
        f"<script>{plotly_js()}</script>"
        f'<script type="application/json" id="stook-figures">{specs}</script>'
        f"<script>{_SCRIPT}</script></body></html>\n"
    )
