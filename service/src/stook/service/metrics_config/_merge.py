"""Several config files into one, by the platform's rules.

`topics`, `metrics` and `metrics sets` must be disjoint across files; `version` must be
in every file and equal; any other top-level key: the last file that has it wins.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from stook.service.metrics_config._errors import MetricsConfigError

MERGED_SECTIONS = ("topics", "metrics", "metrics sets")


def read_yaml(path: Path) -> dict[str, Any]:
    """One config file as a mapping; MetricsConfigError naming the file otherwise."""
    import yaml

    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MetricsConfigError([f"{path}: no such config file"]) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise MetricsConfigError([f"{path}: cannot be read ({exc})"]) from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        line = f" line {where.line + 1}" if where is not None else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise MetricsConfigError([f"{path}{line}: not YAML ({problem})"]) from None
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise MetricsConfigError([f"{path}: a config is a YAML mapping, not {type(doc).__name__}"])
    return doc


def merge(docs: Sequence[tuple[Path, dict[str, Any]]]) -> tuple[dict[str, Any], dict[str, Path]]:
    """The merged document, and for each topic, metric and set name the file it is from."""
    problems: list[str] = []
    merged: dict[str, Any] = {section: {} for section in MERGED_SECTIONS}
    origin: dict[str, Path] = {}
    version: Any = None
    for path, doc in docs:
        if "version" not in doc:
            problems.append(f"{path}: 'version' is required")
        elif version is None:
            version = doc["version"]
        elif doc["version"] != version:
            problems.append(
                f"{path}: version {doc['version']!r} conflicts with version {version!r} of "
                f"{docs[0][0]}"
            )
        for section in MERGED_SECTIONS:
            part = doc.get(section)
            if part is None:
                continue
            if not isinstance(part, dict):
                problems.append(f"{path}: '{section}' must be a mapping")
                continue
            for name, value in part.items():
                key = f"{section}:{name}"
                if key in origin:
                    problems.append(
                        f"{path}: {section} name {name!r} is also defined in {origin[key]}"
                    )
                    continue
                origin[key] = path
                merged[section][name] = value
        for key, value in doc.items():
            if key not in MERGED_SECTIONS and key != "version":
                merged[key] = value  # last wins
    if problems:
        raise MetricsConfigError(problems)
    merged["version"] = version
    return merged, origin
