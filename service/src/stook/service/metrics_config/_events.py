"""Event topics' rows into the writer's events (test level only: the others have none).

An event row carries `name, description, status, tags, metrics` (what it lacks gets a
default); its `$metadata.timestamp` places it. Timestamps from 2001 on (>= 1e18 ns) are
taken as absolute, smaller ones as relative to the test's start; one output's events
share one kind, so any small one makes them all relative.
"""

from __future__ import annotations

import json
from typing import Any

from stook.sdk import MetricHandle, MetricStatus, MetricsWriter
from stook.service.metrics_config._emissions import Tables
from stook.service.metrics_config._model import MetricsConfig
from stook.service.metrics_config._values import label, number

_ABSOLUTE_FROM_NS = 10**18


def write_events(config: MetricsConfig, tables: Tables, writer: MetricsWriter) -> int:
    rows: list[dict[str, Any]] = []
    for topic in config.topics.values():
        if topic.event and topic.name in tables:
            rows.extend(tables[topic.name].to_dicts())
    if not rows:
        return 0
    relative = any((r["timestamp"] or 0) < _ABSOLUTE_FROM_NS for r in rows)
    seen: dict[str, int] = {}
    for row in rows:
        base = label(row.get("name") or "event")
        seen[base] = seen.get(base, 0) + 1
        name = base if seen[base] == 1 else f"{base} ({seen[base]})"
        metrics = [_event_metric(writer, entry) for entry in row.get("metrics") or ()]
        writer.event(
            name,
            timestamp=row["timestamp"] or 0,
            relative=relative,
            metrics=[m for m in metrics if m is not None],
            status=_status(row.get("status")),
            description=str(row.get("description") or ""),
            tags=[str(t) for t in row.get("tags") or ()],
        )
    return len(rows)


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
    name, value = str(item["name"]), item.get("value")
    as_number = number(value)
    if as_number is not None:
        unit = item.get("unit")
        return writer.scalar(name, as_number, unit=str(unit) if unit else None, event=True)
    if value is None or value == "":
        return None
    return writer.text(name, label(value), event=True)
