"""Config files read within bounds, and merged into one by the platform's rules.

Reading is bounded before anything is built: a file larger than MAX_CONFIG_BYTES, YAML
nested deeper than MAX_DEPTH, or aliases that would expand the document past
MAX_EXPANDED (a "billion laughs") are refused with the file and line, checked on the
parser's events -- which need no recursion and build nothing -- so no input can hang
the loader or exhaust memory. A key given twice in one mapping is refused too (PyYAML
would keep the last silently; ReSim's CLI refuses it).

Merging follows ReSim's CLI (`resim metrics sync`): `topics`, `metrics`, `metrics sets`
and `dashboards` must be disjoint across files; `version` must be equal; `global:`
settings apply to the metrics of their own file only; any other top-level key: the last
file that has it wins. A single file may leave out `version`, as ReSim's SDK allows.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from stook.service.metrics_config._errors import MetricsConfigError

MERGED_SECTIONS = ("topics", "metrics", "metrics sets", "dashboards")
TOP_LEVEL_KEYS = ("version", "global", *MERGED_SECTIONS)
# `global:` keys, spelt as ReSim's CLI reads them (it ignores any other).
GLOBAL_SKIP = "skip-if-no-data"
GLOBAL_KEYS = (GLOBAL_SKIP,)
# A metric's own setting, in the two spellings the platform takes: the notes' and the
# CLI's (which writes the `global:` default into each metric under its own spelling).
SKIP_KEYS = ("skip_if_no_data", "skip-if-no-data")

# Real configs are tens of kB; these bounds are far above any of them.
MAX_CONFIG_BYTES = 16 * 1024 * 1024  # all the files of one config together
MAX_DEPTH = 64  # nested mappings and lists
MAX_EXPANDED = 64 * 1024 * 1024  # characters and nodes once every alias is expanded


@dataclass
class Findings:
    """What reading a config found: problems (the config is refused), unknown keys
    (warnings; errors with --strict) and notices (said, never refused)."""

    problems: list[str] = field(default_factory=list)
    unknown_keys: list[str] = field(default_factory=list)
    notices: list[str] = field(default_factory=list)

    def unknown(self, where: str, keys: Iterable[Any], known: Sequence[str]) -> None:
        """One line per key of `keys` that is not in `known`, with the closest one."""
        for key in keys:
            if key in known:
                continue
            close = difflib.get_close_matches(str(key), known, n=1, cutoff=0.6)
            hint = f" (did you mean {close[0]!r}?)" if close else f" (known: {', '.join(known)})"
            self.unknown_keys.append(f"{where}: unknown key {key!r}{hint}")


def resolve(path: Path) -> Path:
    """`path`, or its `.yaml`/`.yml` twin when only that exists (as ReSim's CLI does)."""
    if path.exists():
        return path
    twins = {".yml": ".yaml", ".yaml": ".yml"}
    if path.suffix in twins and path.with_suffix(twins[path.suffix]).is_file():
        return path.with_suffix(twins[path.suffix])
    return path


def read_yaml(path: Path, *, budget: int = MAX_CONFIG_BYTES) -> dict[str, Any]:
    """One config file as a mapping, read within the bounds above (`budget`: the bytes
    left of MAX_CONFIG_BYTES); MetricsConfigError naming the file (and line) otherwise."""
    import yaml

    try:
        with path.open("rb") as stream:
            data = stream.read(budget + 1)
    except FileNotFoundError:
        raise MetricsConfigError([f"{path}: no such config file"]) from None
    except OSError as exc:
        raise MetricsConfigError([f"{path}: cannot be read ({exc.strerror or exc})"]) from None
    if len(data) > budget:
        limit = MAX_CONFIG_BYTES // (1024 * 1024)
        raise MetricsConfigError([f"{path}: the config files are larger than {limit} MiB"])
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        number = data[: exc.start].count(b"\n") + 1
        raise MetricsConfigError([f"{path} line {number}: not UTF-8"]) from None
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml when PyYAML has it
    try:
        _check_events(path, yaml.parse(text, Loader=loader))
        doc = yaml.load(text, Loader=loader)  # a safe loader (no tags that build objects)
    except yaml.YAMLError as exc:
        raise MetricsConfigError([f"{path}{_yaml_problem(exc, text)}"]) from None
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise MetricsConfigError([f"{path}: a config is a YAML mapping, not {type(doc).__name__}"])
    return doc


def _yaml_problem(exc: Exception, text: str) -> str:
    """`line N: not YAML (why)`, on one line, from PyYAML's error."""
    import yaml

    mark = getattr(exc, "problem_mark", None)
    if mark is not None:
        line = mark.line + 1
    elif isinstance(exc, yaml.reader.ReaderError):  # a character YAML forbids
        line = text.count("\n", 0, exc.position) + 1
    else:
        line = None
    why = getattr(exc, "problem", None)
    if isinstance(exc, yaml.reader.ReaderError):
        why = f"{exc.reason}: {chr(exc.character)!r}" if isinstance(exc.character, int) else None
    why = " ".join(str(why or exc).split())
    return f"{f' line {line}' if line else ''}: not YAML ({why})"


@dataclass
class _Open:
    """A mapping or list being parsed."""

    anchor: str | None
    expanded_at_start: int
    keys: set[str] | None  # a mapping's scalar keys so far; None for a list
    at_key: bool = True  # a mapping: the next node is a key


def _check_events(path: Path, events: Iterable[Any]) -> None:
    """Refuse nesting past MAX_DEPTH, aliases expanding past MAX_EXPANDED and a key
    given twice in one mapping, from the parser's events alone."""
    import yaml

    stack: list[_Open] = []
    sizes: dict[str, int] = {}  # an anchor's expanded size
    expanded = 0

    def refuse(event: Any, problem: str) -> MetricsConfigError:
        return MetricsConfigError([f"{path} line {event.start_mark.line + 1}: {problem}"])

    for event in events:
        is_node = isinstance(
            event,
            yaml.ScalarEvent | yaml.AliasEvent | yaml.SequenceStartEvent | yaml.MappingStartEvent,
        )
        keys = stack[-1].keys if is_node and stack else None
        if keys is not None:
            parent = stack[-1]
            if parent.at_key and isinstance(event, yaml.ScalarEvent) and event.value != "<<":
                if event.value in keys:
                    raise refuse(event, f"key {event.value!r} is given twice in one mapping")
                keys.add(event.value)
            parent.at_key = not parent.at_key
        if isinstance(event, yaml.ScalarEvent):
            expanded += 1 + len(event.value)
            if event.anchor is not None:
                sizes[event.anchor] = 1 + len(event.value)
        elif isinstance(event, yaml.AliasEvent):
            if any(o.anchor == event.anchor for o in stack):
                raise refuse(event, f"alias *{event.anchor} refers to itself")
            expanded += sizes.get(event.anchor or "", 0)  # an unknown one: the loader says so
        elif isinstance(event, yaml.SequenceStartEvent | yaml.MappingStartEvent):
            if len(stack) >= MAX_DEPTH:
                raise refuse(event, f"nested deeper than {MAX_DEPTH} levels")
            expanded += 1
            mapping = isinstance(event, yaml.MappingStartEvent)
            stack.append(_Open(event.anchor, expanded, set() if mapping else None))
        elif isinstance(event, yaml.SequenceEndEvent | yaml.MappingEndEvent):
            done = stack.pop()
            if done.anchor is not None:
                sizes[done.anchor] = expanded - done.expanded_at_start + 1
        if expanded > MAX_EXPANDED:
            limit = MAX_EXPANDED // (1024 * 1024)
            raise refuse(event, f"its aliases expand the config past {limit} MiB")


@dataclass(frozen=True, slots=True)
class Merged:
    """The merged document, and for each topic, metric, set and dashboard name the file
    it is from (key `section:name`)."""

    doc: dict[str, Any]
    origin: dict[str, Path]


def merge(docs: Sequence[tuple[Path, dict[str, Any]]], found: Findings) -> Merged:
    """Merge the files' documents; what is wrong goes into `found`."""
    merged: dict[str, Any] = {section: {} for section in MERGED_SECTIONS}
    origin: dict[str, Path] = {}
    version: tuple[Path, Any] | None = None
    for path, doc in docs:
        found.unknown(str(path), doc, TOP_LEVEL_KEYS)
        if "version" not in doc:
            if len(docs) > 1:  # ReSim's SDK takes one file without it, never several
                found.problems.append(f"{path}: 'version' is required when files are merged")
        elif not isinstance(doc["version"], int) or isinstance(doc["version"], bool):
            found.problems.append(f"{path}: 'version' must be an integer, not {doc['version']!r}")
        elif version is None:
            version = (path, doc["version"])
        elif doc["version"] != version[1]:
            found.problems.append(
                f"{path}: version {doc['version']!r} conflicts with version {version[1]!r} "
                f"of {version[0]}"
            )
        skip = _global_skip(path, doc.get("global"), found)
        for section in MERGED_SECTIONS:
            part = doc.get(section)
            if part is None:
                continue
            if not isinstance(part, dict):
                found.problems.append(f"{path}: '{section}' must be a mapping")
                continue
            for name, value in part.items():
                key = f"{section}:{name}"
                if key in origin:
                    found.problems.append(
                        f"{path}: {section} name {name!r} is also defined in {origin[key]}"
                    )
                    continue
                origin[key] = path
                # The file's default, where the metric gives none of its own.
                if section == "metrics" and skip is not None and _lacks_skip(value):
                    value = {**value, SKIP_KEYS[0]: skip}
                merged[section][name] = value
        for key, value in doc.items():
            if key not in TOP_LEVEL_KEYS:
                merged[key] = value  # last wins
    merged["version"] = version[1] if version is not None else None
    return Merged(merged, origin)


def _lacks_skip(metric: Any) -> bool:
    return isinstance(metric, dict) and not any(key in metric for key in SKIP_KEYS)


def _global_skip(path: Path, raw: Any, found: Findings) -> bool | None:
    """The file's `global: skip-if-no-data` (None: not set)."""
    if raw is None:
        return None
    if not isinstance(raw, dict):
        found.problems.append(f"{path}: 'global' must be a mapping")
        return None
    found.unknown(f"{path}: global", raw, GLOBAL_KEYS)
    skip = raw.get(GLOBAL_SKIP)
    if skip is not None and not isinstance(skip, bool):
        found.problems.append(f"{path}: global '{GLOBAL_SKIP}' must be true or false")
        return None
    return skip
