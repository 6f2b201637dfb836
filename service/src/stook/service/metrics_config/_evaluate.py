"""`evaluate`: run a level's metrics over the tables into a writer.

Per metric, in its metrics set's order (or the config's): its query; no data -> hidden
(`skip_if_no_data: true`) or NO_DATA, the status query not run; else the status (block
tried first, then warn: rows mean the threshold is crossed) and the template. Each
written metric's `order` is its place in that list. At test level the event topics' rows
become events, and a FAIL_WARN / FAIL_BLOCK event counts toward the output's status.

A metric that fails is written under its name as the platform marks it: ERROR when its
query or status query failed, RENDER_ERROR when its template could not draw the result
(see `render_error`); the others are written as usual. With `strict`, the first failure
raises instead and nothing of the evaluation is kept by the caller.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

from stook.sdk import MetricHandle, MetricStatus, MetricsWriter, StookError, WriterError
from stook.service.metrics_config._emissions import Tables
from stook.service.metrics_config._events import write_events
from stook.service.metrics_config._liquid import render_figure
from stook.service.metrics_config._model import Level, Metric, MetricsConfig
from stook.service.metrics_config._query_engine import QueryEngine, Result
from stook.service.metrics_config._render import (
    RenderError,
    options_for,
    render,
    render_error,
    render_no_data,
    with_settings,
)

Mark = Literal["ERROR", "RENDER_ERROR"]


@dataclass(frozen=True, slots=True)
class MetricFailure:
    """A metric written as an error: which, the platform's mark, and why."""

    metric: str
    mark: Mark
    message: str

    def __str__(self) -> str:
        return f"{self.mark}: {self.message}"


@dataclass(slots=True)
class Evaluation:
    """What `evaluate` wrote."""

    written: list[str] = field(default_factory=list)
    hidden: list[str] = field(default_factory=list)  # no data and skip_if_no_data
    no_data: list[str] = field(default_factory=list)
    failed: list[MetricFailure] = field(default_factory=list)  # written as errors
    files: list[str] = field(default_factory=list)  # attached files referenced, basenames
    events: int = 0


class _MarkedError(Exception):
    """One metric's failure, marked by the step it happened in (internal)."""

    def __init__(self, mark: Mark, error: StookError) -> None:
        self.mark = mark
        self.error = error


def evaluate(
    config: MetricsConfig,
    tables: Tables,
    writer: MetricsWriter,
    *,
    level: Level,
    metrics_set: str | None = None,
    strict: bool = False,
    attached: Callable[[str], bool] | None = None,
) -> Evaluation:
    """Add `level`'s metrics (those of `metrics_set`, if given) into `writer`.

    `attached` says whether a file an image, video or artifact metric names is among the
    jobs' files (None: not checked, as in a metrics build, which downloads none).
    `strict` raises the first metric's failure instead of writing it as an error.
    """
    metrics = config.metrics_for(level, metrics_set)
    if metrics_set is not None:
        place = {name: i for i, name in enumerate(config.metrics_sets[metrics_set])}
        metrics.sort(key=lambda m: place[m.name])
    done = Evaluation()
    with QueryEngine(tables) as engine:
        for order, metric in enumerate(metrics):
            try:
                handle = _one(config, engine, writer, metric, done, attached)
            except _MarkedError as failed:
                if strict:
                    raise failed.error from None
                message = _without_name(str(failed.error), metric.name)
                handle = render_error(writer, metric, failed.mark, message)
                done.failed.append(MetricFailure(metric.name, failed.mark, str(failed.error)))
            if handle is not None:
                handle.order(float(order))
                done.written.append(metric.name)
    if level == "test":
        worst = write_events(config, tables, writer)
        done.events = worst.count
        # The platform counts an event's FAIL_WARN / FAIL_BLOCK toward the test's result;
        # the writer's own status counts metrics only.
        if _severity(worst.status) > _severity(writer.status):
            writer.override_status(worst.status)
    return done


def _one(
    config: MetricsConfig,
    engine: QueryEngine,
    writer: MetricsWriter,
    metric: Metric,
    done: Evaluation,
    attached: Callable[[str], bool] | None,
) -> MetricHandle | None:
    """Write `metric`: its handle, None when hidden; _MarkedError marks a failure."""
    try:
        result = engine.run(metric.name, metric.query)
        if result.no_data:
            if metric.skip_if_no_data:
                done.hidden.append(metric.name)
                return None
            done.no_data.append(metric.name)
            return render_no_data(writer, metric)
        status = _status(engine, metric)
    except StookError as exc:  # the query, or its status query, failed
        raise _MarkedError("ERROR", exc) from None
    try:
        if metric.custom:
            assert metric.template_file is not None  # checked by load_config
            figure = render_figure(metric, config.templates[metric.template_file], result)
            return with_settings(
                writer.plotly(metric.name, figure, **options_for(metric, status)), metric
            )
        handle, files = render(
            writer,
            metric,
            result,
            status,
            attached,
            lambda job: _job_media(config, engine, metric, job),
        )
    except WriterError as exc:  # a value the writer refuses (the metric is not written)
        why = _without_name(str(exc), metric.name)
        raise _MarkedError("RENDER_ERROR", RenderError(metric, why)) from None
    except StookError as exc:
        raise _MarkedError("RENDER_ERROR", exc) from None
    done.files.extend(f for f in files if f not in done.files)
    return handle


def _job_media(config: MetricsConfig, engine: QueryEngine, metric: Metric, job: str) -> list[str]:
    """The files of the metric's kind (its `image` or `video` columns) that job `job`
    emitted in the topics the metric's query reads, in the config's order of topics and
    columns, then by time."""
    import sqlglot
    from sqlglot import exp

    tree = sqlglot.parse_one(metric.query, read="trino")
    read = {table.name.lower() for table in tree.find_all(exp.Table)}
    files: list[str] = []
    for topic in config.topics.values():
        if topic.name.lower() not in read:
            continue
        for column, kind in topic.schema.items():
            if kind != metric.template:
                continue
            name, table = _quoted(column), _quoted(topic.name)
            query = f"SELECT {name} FROM {table} WHERE job_id = ? ORDER BY timestamp, {name}"
            rows = engine.run(metric.name, query, [job], what="lookup of the job's files").rows
            files.extend(str(r[0]) for r in rows if r[0] is not None)
    return list(dict.fromkeys(files))


def _quoted(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


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


def _severity(status: MetricStatus) -> int:
    return {MetricStatus.FAIL_BLOCK: 2, MetricStatus.FAIL_WARN: 1}.get(status, 0)


def _without_name(message: str, metric: str) -> str:
    """The error's message for the metric's own text: its name is the metric's already."""
    prefix = f"metric {metric!r}: "
    return message.removeprefix(prefix)
