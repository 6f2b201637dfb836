"""`load_config`: read, merge and check config files into a `MetricsConfig`.

Every key is checked against what the platform reads: an unknown one is named with the
closest known key (a warning, an error with `strict`), as `unit:` would otherwise be
dropped without a word. Every problem of every file is found in one pass, one line each.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, cast

from stook.service.metrics_config._errors import MetricsConfigError
from stook.service.metrics_config._merge import (
    MAX_CONFIG_BYTES,
    SKIP_KEYS,
    Findings,
    merge,
    read_yaml,
    resolve,
)
from stook.service.metrics_config._model import (
    COLUMN_TYPES,
    LEVEL_ALIASES,
    LEVELS,
    LIST_TYPES,
    METADATA_TABLE,
    REFRESH_MODES,
    SYSTEM_TEMPLATES,
    TOPIC_EXTRA_COLUMNS,
    Dashboard,
    Level,
    Metric,
    MetricsConfig,
    Refresh,
    StatusCheck,
    Topic,
)
from stook.service.metrics_config._sql import parse_problem

TEMPLATES_FOLDER = "templates"
TEMPLATE_SUFFIX = ".liquid"

# The keys the platform reads, per part of the config.
TOPIC_KEYS = ("schema", "event")
# The media column types, of which one topic holds one kind (ReSim's CLI refuses both).
MEDIA_TYPES = ("image", "video")
METRIC_KEYS = (
    "type",
    "description",
    "query_string",
    "template_type",
    "template",
    "template_file",
    "units",
    *SKIP_KEYS,
    "template_settings",
    "status",
)
STATUS_KEYS = ("query_string", "block", "warn")
SET_KEYS = ("metrics",)
DASHBOARD_KEYS = ("metrics_set", "description", "refresh", "day_range")

# Topics, and metrics, one config may define.
MAX_DEFINED = 2_000
# Checked before a query reaches the SQL parser, whose time and stack grow with both.
MAX_QUERY_CHARS = 1_000_000  # Trino's default `query.max-length`
MAX_QUERY_NESTING = 32  # parentheses; stook's own bound, far above real queries
# What can hold a parenthesis that does not nest: literals, quoted names, comments.
_QUERY_TOKENS = re.compile(r"'[^']*'|\"[^\"]*\"|--[^\n]*|/\*.*?\*/|[()]", re.DOTALL)


def load_config(
    paths: Sequence[Path], templates: Path | None = None, *, strict: bool = False
) -> MetricsConfig:
    """Read config files, merge them by the platform's rules and check the result.

    `templates`: the folder of custom Liquid templates (default: `templates/` beside the
    first config file). `strict`: unknown keys are problems, not warnings. Raises
    MetricsConfigError with one line per problem found; warnings are logged.
    """
    config, problems = read_config(paths, templates, strict=strict)
    if problems:
        raise MetricsConfigError(problems)
    if config.warnings:
        import structlog

        log = structlog.get_logger("stook.metrics_config")
        for line in config.warnings:
            log.warning(line)
    return config


def read_config(
    paths: Sequence[Path], templates: Path | None = None, *, strict: bool = False
) -> tuple[MetricsConfig, list[str]]:
    """What `load_config` reads, without refusing: the config built of every part that is
    usable, and every problem found (one line each, naming the file). `check` shows them
    all, then binds the queries of the usable metrics."""
    if not paths:
        return _empty(), ["no config file given"]
    files = tuple(resolve(Path(p)) for p in paths)
    found = Findings()
    docs = []
    budget = MAX_CONFIG_BYTES
    for path in files:
        try:
            doc = read_yaml(path, budget=budget)
        except MetricsConfigError as exc:
            found.problems.extend(exc.problems)
            continue
        budget = max(budget - _size(path), 0)
        docs.append((path, doc))
    if found.problems:
        # Without a file, the others' references to it would each be one more line.
        return _empty(), found.problems
    merged = merge(docs, found)
    raw, origin = merged.doc, merged.origin
    for section in ("topics", "metrics"):
        if len(raw[section]) > MAX_DEFINED:
            # Each costs a table or a parse and a bind: past this, a check takes minutes.
            where = ", ".join(str(path) for path, _ in docs)
            return _empty(), [
                f"{where}: {len(raw[section]):,} {section}; stook reads at most "
                f"{MAX_DEFINED:,} (its limit, far above real configs)"
            ]
    folder = templates if templates is not None else files[0].parent / TEMPLATES_FOLDER
    topics = _topics(raw["topics"], origin, found)
    metrics = _metrics(raw["metrics"], origin, found)
    # Set membership is checked against every metric named, faulty or not: one problem
    # in a metric is one line, not one more per set it is in.
    sets = _metrics_sets(raw["metrics sets"], set(raw["metrics"]), origin, found)
    dashboards = _dashboards(raw["dashboards"], sets, origin, found)
    texts = _templates(metrics, folder, found)
    problems = found.problems + (found.unknown_keys if strict else [])
    warnings = found.notices + ([] if strict else found.unknown_keys)
    config = MetricsConfig(
        version=raw["version"],
        topics=topics,
        metrics=metrics,
        metrics_sets=sets,
        dashboards=dashboards,
        templates=texts,
        files=files,
        warnings=tuple(warnings),
    )
    return config, problems


def query_bound_problem(query: str) -> str | None:
    """Why `query` is too long or too deeply nested to be parsed (None: it is not), in
    one cheap pass before the parser, whose time and stack grow with both."""
    if len(query) > MAX_QUERY_CHARS:
        return (
            f"is {len(query):,} characters long; Trino takes at most {MAX_QUERY_CHARS:,} "
            "(query.max-length)"
        )
    depth = 0
    for token in _QUERY_TOKENS.finditer(query):
        if token.group() == "(":
            depth += 1
            if depth > MAX_QUERY_NESTING:
                return f"nests parentheses deeper than {MAX_QUERY_NESTING} levels (stook's limit)"
        elif token.group() == ")":
            depth = max(depth - 1, 0)
    return None


def _empty() -> MetricsConfig:
    return MetricsConfig(None, {}, {}, {}, {}, {})


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0


def _where(origin: Mapping[str, Path], section: str, name: str) -> str:
    return f"{origin.get(f'{section}:{name}', '?')}: {section} {name!r}"


def _is_text(value: Any) -> bool:
    """A scalar YAML gives as text, a number or a date: what `description` may hold."""
    return value is None or not isinstance(value, dict | list | set | tuple)


def _topics(
    raw: Mapping[str, Any], origin: Mapping[str, Path], found: Findings
) -> dict[str, Topic]:
    problems = found.problems
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
        found.unknown(where, body, TOPIC_KEYS)
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
        media = {kind: [c for c, k in schema.items() if k == kind] for kind in MEDIA_TYPES}
        if all(media.values()):
            problems.append(
                f"{where}: has image column(s) {', '.join(map(repr, media['image']))} and "
                f"video column(s) {', '.join(map(repr, media['video']))}; the platform takes "
                "one kind of media per topic: emit the images and the videos in two topics"
            )
        event = body.get("event", False)
        if not isinstance(event, bool):
            problems.append(f"{where}: 'event' must be true or false")
        topics[name] = Topic(name, schema, event is True)
    return topics


def _metrics(
    raw: Mapping[str, Any], origin: Mapping[str, Path], found: Findings
) -> dict[str, Metric]:
    problems = found.problems
    metrics: dict[str, Metric] = {}
    for name, body in raw.items():
        where = _where(origin, "metrics", name)
        if not isinstance(body, dict):
            problems.append(f"{where}: must be a mapping")
            continue
        found.unknown(where, body, METRIC_KEYS)
        before = len(problems)
        level = body.get("type")
        if isinstance(level, str) and level in LEVEL_ALIASES:
            found.notices.append(
                f"{where}: type {level!r} is read as {LEVEL_ALIASES[level]!r}, its current name"
            )
            level = LEVEL_ALIASES[level]
        if level not in LEVELS:
            problems.append(f"{where}: 'type' must be one of {', '.join(LEVELS)}, not {level!r}")
        query = body.get("query_string")
        if not isinstance(query, str) or not query.strip():
            problems.append(f"{where}: 'query_string' (Trino SQL) is required")
        else:
            bound = query_bound_problem(query)
            problem = None if bound else parse_problem(query)
            if bound or problem:
                problems.append(f"{where}: query_string {bound or f'does not parse: {problem}'}")
        template = _template(body, where, problems)
        skip = _skip(body, where, problems)
        settings = body.get("template_settings") or {}
        if not isinstance(settings, dict):
            problems.append(f"{where}: 'template_settings' must be a mapping")
        for key in ("description", "units"):
            if not _is_text(body.get(key)):
                problems.append(f"{where}: {key!r} must be text")
        status = _status(body.get("status"), where, found)
        if len(problems) > before:
            continue
        units = body.get("units")
        metrics[name] = Metric(
            name=str(name),
            level=cast(Level, level),
            query=cast(str, query),
            template=template,
            template_file=body.get("template_file") if template == "custom" else None,
            description=str(body.get("description") or ""),
            units=None if units is None else str(units),
            skip_if_no_data=skip,
            settings=settings,
            status=status,
            source=origin.get(f"metrics:{name}"),
        )
    return metrics


def _template(body: Mapping[str, Any], where: str, problems: list[str]) -> str:
    """The metric's system template name, or "custom" (checked: only top-level *.liquid
    files of templates/ exist on the platform, which uploads no others)."""
    kind = body.get("template_type", "system")
    template = body.get("template")
    if kind == "custom":
        template_file = body.get("template_file")
        if not isinstance(template_file, str) or not template_file:
            problems.append(f"{where}: a custom template needs 'template_file'")
        elif "/" in template_file or "\\" in template_file or template_file in (".", ".."):
            problems.append(
                f"{where}: template_file {template_file!r} is not a file name; the platform "
                f"takes only the files at the top of {TEMPLATES_FOLDER}/, no sub-folder"
            )
        elif not template_file.lower().endswith(TEMPLATE_SUFFIX):
            problems.append(
                f"{where}: template_file {template_file!r} must be a {TEMPLATE_SUFFIX} file "
                "(the platform uploads no other)"
            )
        return "custom"
    if kind != "system":
        problems.append(f"{where}: 'template_type' must be system or custom, not {kind!r}")
    elif template is None:
        problems.append(f"{where}: 'template' is required ({', '.join(SYSTEM_TEMPLATES)})")
    elif template not in SYSTEM_TEMPLATES:
        problems.append(
            f"{where}: 'template' must be one of {', '.join(SYSTEM_TEMPLATES)}, not {template!r}"
        )
    return str(template)


def _skip(body: Mapping[str, Any], where: str, problems: list[str]) -> bool:
    given = {key: body[key] for key in SKIP_KEYS if key in body}
    for key, value in given.items():
        if not isinstance(value, bool):
            problems.append(f"{where}: {key!r} must be true or false")
            return False
    if len(set(given.values())) > 1:
        problems.append(f"{where}: {' and '.join(map(repr, given))} disagree")
        return False
    return next(iter(given.values()), False)


def _status(raw: Any, where: str, found: Findings) -> StatusCheck | None:
    problems = found.problems
    if raw is None:
        return None
    if not isinstance(raw, dict):
        problems.append(f"{where}: 'status' must be a mapping")
        return None
    found.unknown(f"{where}: status", raw, STATUS_KEYS)
    query = raw.get("query_string")
    if not isinstance(query, str) or not query.strip():
        problems.append(f"{where}: status needs a 'query_string'")
        return None
    problem = query_bound_problem(query) or parse_problem(query, placeholders=1)
    if problem:
        problems.append(f"{where}: the status query_string {problem}")
    if raw.get("block") is None and raw.get("warn") is None:
        problems.append(f"{where}: status needs a 'block' or a 'warn' threshold")
    for key in ("block", "warn"):
        if not _is_text(raw.get(key)) or isinstance(raw.get(key), bool):
            problems.append(f"{where}: the status {key!r} threshold must be a number or text")
    return StatusCheck(query, raw.get("block"), raw.get("warn"))


def _metrics_sets(
    raw: Mapping[str, Any],
    metrics: set[str],
    origin: Mapping[str, Path],
    found: Findings,
) -> dict[str, tuple[str, ...]]:
    problems = found.problems
    sets: dict[str, tuple[str, ...]] = {}
    for name, body in raw.items():
        where = _where(origin, "metrics sets", name)
        members = body.get("metrics") if isinstance(body, dict) else None
        if not isinstance(members, list) or not all(isinstance(m, str) for m in members):
            problems.append(f"{where}: needs 'metrics', a list of metric names")
            continue
        found.unknown(where, body, SET_KEYS)
        for member in members:
            if member not in metrics:
                problems.append(f"{where}: names metric {member!r}, which the config lacks")
        sets[name] = tuple(members)
    return sets


def _dashboards(
    raw: Mapping[str, Any],
    sets: Mapping[str, tuple[str, ...]],
    origin: Mapping[str, Path],
    found: Findings,
) -> dict[str, Dashboard]:
    problems = found.problems
    dashboards: dict[str, Dashboard] = {}
    for name, body in raw.items():
        where = _where(origin, "dashboards", name)
        if not isinstance(body, dict):
            problems.append(f"{where}: must be a mapping")
            continue
        found.unknown(where, body, DASHBOARD_KEYS)
        before = len(problems)
        chosen = body.get("metrics_set")
        if chosen is not None and (not isinstance(chosen, str) or chosen not in sets):
            problems.append(f"{where}: names unknown metrics set {chosen!r}")
        refresh = body.get("refresh")
        if refresh is not None and refresh not in REFRESH_MODES:
            problems.append(
                f"{where}: 'refresh' must be {' or '.join(REFRESH_MODES)}, not {refresh!r}"
            )
        days = body.get("day_range")
        if days is not None and (not isinstance(days, int) or isinstance(days, bool) or days < 1):
            problems.append(f"{where}: 'day_range' must be a positive whole number, not {days!r}")
        if not _is_text(body.get("description")):
            problems.append(f"{where}: 'description' must be text")
        if len(problems) == before:
            dashboards[str(name)] = Dashboard(
                name=str(name),
                metrics_set=chosen,
                description=str(body.get("description") or ""),
                refresh=cast(Refresh | None, refresh),
                day_range=days,
            )
    return dashboards


def _templates(metrics: Mapping[str, Metric], folder: Path, found: Findings) -> dict[str, str]:
    texts: dict[str, str] = {}
    for metric in metrics.values():
        if not metric.custom or metric.template_file is None or metric.template_file in texts:
            continue
        path = folder / metric.template_file
        try:
            texts[metric.template_file] = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            reason = "no such file" if isinstance(exc, FileNotFoundError) else str(exc)
            found.problems.append(
                f"{metric.source}: metrics {metric.name!r}: template {str(path)!r}: {reason}"
            )
    return texts
