"""Event topics' rows into the writer's events (test level only: the others have none).

An event row carries `name, description, status, tags, metrics` (what it lacks gets a
default); its `$metadata.timestamp` places it. Timestamps from 2001 on (>= 1e18 ns) are
taken as absolute, smaller ones as relative to the test's start; one output's events
share one kind, so any small one makes them all relative.

A `metrics` entry is `{name, type, value, unit?}`: a number is a SCALAR (with its
unit), a text a TEXT; a `table` (rows as objects, columns as arrays, or a list of rows
under a header row) a Markdown TEXT; a chart (a Plotly figure: an object with `data`,
or its JSON text) a PLOTLY; any other value its JSON in a TEXT.
"""

from __future__ import annotations

import contextlib
import json
from dataclasses import dataclass
from typing import Any

from stook.sdk import MetricHandle, MetricStatus, MetricsWriter
from stook.service.metrics_config._emissions import Tables
from stook.service.metrics_config._model import MetricsConfig
from stook.service.metrics_config._render import markdown_rows
from stook.service.metrics_config._values import label, number, plain

_ABSOLUTE_FROM_NS = 10**18
_SEVERITY = {MetricStatus.FAIL_BLOCK: 2, MetricStatus.FAIL_WARN: 1}


@dataclass(frozen=True, slots=True)
class EventsWritten:
    count: int = 0
    status: MetricStatus = MetricStatus.PASSED  # the worst of the events' statuses


def write_events(config: MetricsConfig, tables: Tables, writer: MetricsWriter) -> EventsWritten:
    rows: list[dict[str, Any]] = []
    for topic in config.topics.values():
        if topic.event and topic.name in tables:
            rows.extend(tables[topic.name].to_dicts())
    if not rows:
        return EventsWritten()
    relative = any((r["timestamp"] or 0) < _ABSOLUTE_FROM_NS for r in rows)
    seen: dict[str, int] = {}
    worst = MetricStatus.PASSED
    for row in rows:
        base = label(row.get("name") or "event")
        seen[base] = seen.get(base, 0) + 1
        name = base if seen[base] == 1 else f"{base} ({seen[base]})"
        metrics = [_event_metric(writer, entry) for entry in row.get("metrics") or ()]
        status = _status(row.get("status"))
        if _SEVERITY.get(status, 0) > _SEVERITY.get(worst, 0):
            worst = status
        writer.event(
            name,
            timestamp=row["timestamp"] or 0,
            relative=relative,
            metrics=[m for m in metrics if m is not None],
            status=status,
            description=str(row.get("description") or ""),
            tags=[str(t) for t in row.get("tags") or ()],
        )
    return EventsWritten(len(rows), worst)


def _status(value: Any) -> MetricStatus:
    try:
        return MetricStatus.from_api(str(value))
    except ValueError:
        return MetricStatus.PASSED


def _event_metric(writer: MetricsWriter, entry: str) -> MetricHandle | None:
    """One `metric[]` entry ({name, type, value, unit?}) as an event metric."""
    try:
        item = json.loads(entry)
    except ValueError:
        return None
    if not isinstance(item, dict) or not item.get("name"):
        return None
    name, kind, value = str(item["name"]), str(item.get("type") or ""), item.get("value")
    if value is None or value == "":
        return None
    as_number = None if isinstance(value, str) else number(value)
    if as_number is not None:
        unit = item.get("unit")
        return writer.scalar(name, as_number, unit=str(unit) if unit else None, event=True)
    if isinstance(value, str) and kind != "text":
        # A table or a figure may come as its JSON text.
        with contextlib.suppress(ValueError):
            value = json.loads(value)
    if isinstance(value, str):
        return writer.text(name, value, event=True)
    if isinstance(value, dict) and isinstance(value.get("data"), list):
        return writer.plotly(name, plain(value), event=True)
    table = _table(value)
    if table is not None:
        return writer.text(name, table, event=True)
    return writer.text(name, "```json\n" + json.dumps(plain(value), indent=2) + "\n```", event=True)


def _table(value: Any) -> str | None:
    """A table entry as Markdown: rows as objects, columns as arrays, or rows under a
    header row; None when `value` is none of these."""
    if isinstance(value, list) and value and all(isinstance(r, dict) for r in value):
        columns = list(dict.fromkeys(str(k) for r in value for k in r))
        return markdown_rows(columns, [[r.get(c) for c in columns] for r in value])
    if isinstance(value, dict) and value and all(isinstance(v, list) for v in value.values()):
        columns = [str(k) for k in value]
        height = max(len(v) for v in value.values())
        cells = [[v[i] if i < len(v) else None for v in value.values()] for i in range(height)]
        return markdown_rows(columns, cells)
    if isinstance(value, list) and len(value) > 1 and all(isinstance(r, list) for r in value):
        return markdown_rows([label(c) for c in value[0]], value[1:])
    return None
