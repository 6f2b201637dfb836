"""`load_config`: read, merge and check config files into a `MetricsConfig`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, cast

from stook.service.metrics_config._errors import MetricsConfigError
from stook.service.metrics_config._merge import merge, read_yaml
from stook.service.metrics_config._model import (
    COLUMN_TYPES,
    LEVELS,
    LIST_TYPES,
    METADATA_TABLE,
    SYSTEM_TEMPLATES,
    TOPIC_EXTRA_COLUMNS,
    Level,
    Metric,
    MetricsConfig,
    StatusCheck,
    Topic,
)
from stook.service.metrics_config._sql import parse_problem

TEMPLATES_FOLDER = "templates"


def load_config(paths: Sequence[Path], templates: Path | None = None) -> MetricsConfig:
    """Read config files, merge them by the platform's rules and check the result.

    `templates`: the folder of custom Liquid templates (default: `templates/` beside the
    first config file). Raises MetricsConfigError with one line per problem found.
    """
    if not paths:
        raise MetricsConfigError(["no config file given"])
    files = tuple(Path(p) for p in paths)
    docs = [(path, read_yaml(path)) for path in files]
    merged, origin = merge(docs)
    folder = templates if templates is not None else files[0].parent / TEMPLATES_FOLDER
    problems: list[str] = []
    topics = _topics(merged["topics"], origin, problems)
    metrics = _metrics(merged["metrics"], origin, problems)
    # Set membership is checked against every metric named, faulty or not: one problem
    # in a metric is one line, not one more per set it is in.
    sets = _metrics_sets(merged["metrics sets"], set(merged["metrics"]), origin, problems)
    dashboards = _dashboards(merged.get("dashboards"), sets, files[-1], problems)
    texts = _templates(metrics, folder, problems)
    if problems:
        raise MetricsConfigError(problems)
    return MetricsConfig(
        version=merged["version"],
        topics=topics,
        metrics=metrics,
        metrics_sets=sets,
        dashboards=dashboards,
        templates=texts,
        files=files,
    )


def _where(origin: Mapping[str, Path], section: str, name: str) -> str:
    return f"{origin.get(f'{section}:{name}', '?')}: {section} {name!r}"


def _topics(
    raw: Mapping[str, Any], origin: Mapping[str, Path], problems: list[str]
) -> dict[str, Topic]:
    topics: dict[str, Topic] = {}
    # SQL names are case-insensitive: `Speed` and `speed` would be one table.
    folded: dict[str, str] = {METADATA_TABLE: "the metadata table"}
    for name, body in raw.items():
        where = _where(origin, "topics", name)
        if not isinstance(name, str) or not name:
            problems.append(f"{where}: a topic name is a non-empty string")
            continue
        if name.lower() in folded:
            taken = folded[name.lower()]
            problems.append(f"{where}: the name is taken by {taken} (SQL ignores case)")
            continue
        folded[name.lower()] = f"topic {name!r}"
        if not isinstance(body, dict) or not isinstance(body.get("schema"), dict):
            problems.append(f"{where}: needs a 'schema' mapping of column: type")
            continue
        schema: dict[str, str] = {}
        seen: set[str] = set()
        for column, kind in body["schema"].items():
            lowered = str(column).lower()
            if lowered in TOPIC_EXTRA_COLUMNS:
                problems.append(f"{where}: column {column!r} is one every topic table adds")
            elif lowered in seen:
                problems.append(f"{where}: column {column!r} is named twice (SQL ignores case)")
            elif kind not in COLUMN_TYPES and kind not in LIST_TYPES:
                known = ", ".join(COLUMN_TYPES + LIST_TYPES)
                problems.append(f"{where}: column {column!r} has unknown type {kind!r} ({known})")
            else:
                schema[str(column)] = kind
            seen.add(lowered)
        event = body.get("event", False)
        if not isinstance(event, bool):
            problems.append(f"{where}: 'event' must be true or false")
        topics[name] = Topic(name, schema, event is True)
    return topics


def _metrics(
    raw: Mapping[str, Any], origin: Mapping[str, Path], problems: list[str]
) -> dict[str, Metric]:
    metrics: dict[str, Metric] = {}
    for name, body in raw.items():
        where = _where(origin, "metrics", name)
        if not isinstance(body, dict):
            problems.append(f"{where}: must be a mapping")
            continue
        found = len(problems)
        level = body.get("type")
        if level not in LEVELS:
            problems.append(f"{where}: 'type' must be one of {', '.join(LEVELS)}, not {level!r}")
        query = body.get("query_string")
        if not isinstance(query, str) or not query.strip():
            problems.append(f"{where}: 'query_string' (Trino SQL) is required")
        else:
            problem = parse_problem(query)
            if problem:
                problems.append(f"{where}: query_string does not parse: {problem}")
        kind = body.get("template_type", "system")
        template = body.get("template")
        template_file = body.get("template_file")
        if kind == "custom":
            if not isinstance(template_file, str) or not template_file:
                problems.append(f"{where}: a custom template needs 'template_file'")
            template = "custom"
        elif kind == "system":
            if template not in SYSTEM_TEMPLATES:
                problems.append(
                    f"{where}: 'template' must be one of {', '.join(SYSTEM_TEMPLATES)}, "
                    f"not {template!r}"
                )
        else:
            problems.append(f"{where}: 'template_type' must be system or custom, not {kind!r}")
        skip = body.get("skip_if_no_data", False)
        if not isinstance(skip, bool):
            problems.append(f"{where}: 'skip_if_no_data' must be true or false")
        settings = body.get("template_settings") or {}
        if not isinstance(settings, dict):
            problems.append(f"{where}: 'template_settings' must be a mapping")
        status = _status(body.get("status"), where, problems)
        if len(problems) > found:
            continue
        units = body.get("units")
        metrics[name] = Metric(
            name=str(name),
            level=cast(Level, level),
            query=cast(str, query),
            template=cast(str, template),
            template_file=template_file,
            description=str(body.get("description") or ""),
            units=None if units is None else str(units),
            skip_if_no_data=skip,
            settings=settings,
            status=status,
            source=origin.get(f"metrics:{name}"),
        )
    return metrics


def _status(raw: Any, where: str, problems: list[str]) -> StatusCheck | None:
    if raw is None:
        return None
    if not isinstance(raw, dict):
        problems.append(f"{where}: 'status' must be a mapping")
        return None
    query = raw.get("query_string")
    if not isinstance(query, str) or not query.strip():
        problems.append(f"{where}: status needs a 'query_string'")
        return None
    problem = parse_problem(query, placeholders=1)
    if problem:
        problems.append(f"{where}: the status query_string {problem}")
    if raw.get("block") is None and raw.get("warn") is None:
        problems.append(f"{where}: status needs a 'block' or a 'warn' threshold")
    return StatusCheck(query, raw.get("block"), raw.get("warn"))


def _metrics_sets(
    raw: Mapping[str, Any],
    metrics: set[str],
    origin: Mapping[str, Path],
    problems: list[str],
) -> dict[str, tuple[str, ...]]:
    sets: dict[str, tuple[str, ...]] = {}
    for name, body in raw.items():
        where = _where(origin, "metrics sets", name)
        members = body.get("metrics") if isinstance(body, dict) else None
        if not isinstance(members, list) or not all(isinstance(m, str) for m in members):
            problems.append(f"{where}: needs 'metrics', a list of metric names")
            continue
        for member in members:
            if member not in metrics:
                problems.append(f"{where}: names metric {member!r}, which the config lacks")
        sets[name] = tuple(members)
    return sets


def _dashboards(
    raw: Any, sets: Mapping[str, tuple[str, ...]], last: Path, problems: list[str]
) -> dict[str, dict[str, Any]]:
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        problems.append(f"{last}: 'dashboards' must be a mapping")
        return {}
    for name, body in raw.items():
        chosen = body.get("metrics_set") if isinstance(body, dict) else None
        if chosen is not None and chosen not in sets:
            problems.append(f"{last}: dashboard {name!r} names unknown metrics set {chosen!r}")
    return {str(k): v for k, v in raw.items() if isinstance(v, dict)}


def _templates(metrics: Mapping[str, Metric], folder: Path, problems: list[str]) -> dict[str, str]:
    texts: dict[str, str] = {}
    for metric in metrics.values():
        if not metric.custom or metric.template_file is None or metric.template_file in texts:
            continue
        path = folder / metric.template_file
        try:
            texts[metric.template_file] = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            reason = "no such file" if isinstance(exc, FileNotFoundError) else str(exc)
            problems.append(
                f"{metric.source}: metrics {metric.name!r}: template {str(path)!r}: {reason}"
            )
    return texts
