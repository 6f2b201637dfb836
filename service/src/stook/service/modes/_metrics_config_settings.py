"""stook.toml's [metrics_config]: the platform's config-defined metrics in a mode.

[metrics_config]
paths = [".resim/metrics/config.resim.yml"]   # merged by the platform's rules
metrics_set = "core"          # optional: only this set's metrics (default: all of the level)
templates = ".resim/metrics/templates"        # optional (default: beside the first path)
emissions = "logs/emissions.resim.jsonl"      # test mode, optional (default: the inputs'
                                              # logs/emissions.resim.jsonl)
strict = true                 # optional: a failing metric fails the run (exit 4) instead
                              # of being written as an error (default: false)

Relative paths are read from stook.toml's folder.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

_KEYS = {"paths", "metrics_set", "templates", "emissions", "strict"}


class MetricsConfigSettingsError(ValueError):
    """The table is malformed; the caller names the file."""


@dataclass(frozen=True, slots=True)
class MetricsConfigSettings:
    paths: tuple[str, ...]
    metrics_set: str | None = None
    templates: str | None = None
    emissions: str | None = None
    strict: bool = False

    def config_paths(self, base: Path | None) -> list[Path]:
        return [_resolve(p, base) for p in self.paths]

    def templates_path(self, base: Path | None) -> Path | None:
        return None if self.templates is None else _resolve(self.templates, base)

    def emissions_path(self, base: Path | None) -> Path | None:
        return None if self.emissions is None else _resolve(self.emissions, base)


def _resolve(path: str, base: Path | None) -> Path:
    given = Path(path)
    return given if given.is_absolute() or base is None else base / given


def parse_metrics_config(table: Mapping[str, Any]) -> MetricsConfigSettings:
    extra = set(table) - _KEYS
    if extra:
        known = ", ".join(sorted(_KEYS))
        raise MetricsConfigSettingsError(f"unknown key {sorted(extra)[0]!r} (known: {known})")
    paths = table.get("paths")
    if isinstance(paths, str):
        paths = [paths]
    if not paths or not isinstance(paths, list) or not all(isinstance(p, str) for p in paths):
        raise MetricsConfigSettingsError("'paths' must be a non-empty list of config files")
    for key in ("metrics_set", "templates", "emissions"):
        if key in table and not isinstance(table[key], str):
            raise MetricsConfigSettingsError(f"{key!r} must be a string")
    if not isinstance(table.get("strict", False), bool):
        raise MetricsConfigSettingsError("'strict' must be true or false")
    return MetricsConfigSettings(
        paths=tuple(paths),
        metrics_set=table.get("metrics_set"),
        templates=table.get("templates"),
        emissions=table.get("emissions"),
        strict=table.get("strict", False),
    )
