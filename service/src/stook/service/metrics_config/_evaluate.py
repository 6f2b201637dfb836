"""`evaluate`: run a level's metrics over the tables into a writer.

Per metric: its query; no data -> hidden (`skip_if_no_data: true`) or NO_DATA, the
status query not run; else the status (block tried first, then warn: rows mean the
threshold is crossed) and the template. At test level the event topics' rows become
events.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from stook.sdk import MetricStatus, MetricsWriter
from stook.service.metrics_config._emissions import Tables
from stook.service.metrics_config._events import write_events
from stook.service.metrics_config._liquid import render_figure
from stook.service.metrics_config._model import Level, Metric, MetricsConfig
from stook.service.metrics_config._query_engine import QueryEngine, Result
from stook.service.metrics_config._render import options_for, render, render_no_data


@dataclass(slots=True)
class Evaluation:
    """What `evaluate` wrote."""

    written: list[str] = field(default_factory=list)
    hidden: list[str] = field(default_factory=list)  # no data and skip_if_no_data
    no_data: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)  # attached files referenced, basenames
    events: int = 0


def evaluate(
    config: MetricsConfig,
    tables: Tables,
    writer: MetricsWriter,
    *,
    level: Level,
    metrics_set: str | None = None,
) -> Evaluation:
    """Add `level`'s metrics (those of `metrics_set`, if given) into `writer`."""
    metrics = config.metrics_for(level, metrics_set)
    done = Evaluation()
    with QueryEngine(tables) as engine:
        for metric in metrics:
            _one(config, engine, writer, metric, done)
    if level == "test":
        done.events = write_events(config, tables, writer)
    return done


def _one(
    config: MetricsConfig,
    engine: QueryEngine,
    writer: MetricsWriter,
    metric: Metric,
    done: Evaluation,
) -> None:
    result = engine.run(metric.name, metric.query)
    if result.no_data:
        if metric.skip_if_no_data:
            done.hidden.append(metric.name)
            return
        render_no_data(writer, metric)
        done.no_data.append(metric.name)
        done.written.append(metric.name)
        return
    status = _status(engine, metric)
    if metric.custom:
        assert metric.template_file is not None  # checked by load_config
        figure = render_figure(metric, config.templates[metric.template_file], result)
        writer.plotly(metric.name, figure, **options_for(metric, status))
    else:
        done.files.extend(f for f in render(writer, metric, result, status) if f not in done.files)
    done.written.append(metric.name)


def _status(engine: QueryEngine, metric: Metric) -> MetricStatus:
    check = metric.status
    if check is None:
        return MetricStatus.PASSED
    thresholds: list[tuple[Any, MetricStatus]] = [
        (check.block, MetricStatus.FAIL_BLOCK),
        (check.warn, MetricStatus.FAIL_WARN),
    ]
    for threshold, status in thresholds:
        if threshold is None:
            continue
        crossed: Result = engine.run(metric.name, check.query, [threshold], what="status query")
        if crossed.rows:
            return status
    return MetricStatus.PASSED
