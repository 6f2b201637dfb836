"""What a merged config holds, once checked: topics, metrics, metrics sets, dashboards."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

Level = Literal["test", "batch", "dashboard"]
LEVELS: tuple[Level, ...] = ("test", "batch", "dashboard")
# Older configs name the dashboard level `report` (isaacsim-demo's report.resim.yml).
LEVEL_ALIASES = {"report": "dashboard"}

# The column types a topic's schema may name (the platform's list).
COLUMN_TYPES = ("boolean", "int", "float", "string", "status", "image", "video")
LIST_TYPES = ("string[]", "metric[]")

# The system templates the platform reports, plus `video` which it accepts too.
SYSTEM_TEMPLATES = (
    "line",
    "bar",
    "table",
    "scalar",
    "image",
    "state_timeline",
    "histogram",
    "pie",
    "artifact",
    "video",
)

# Columns every topic table has besides its schema's, and the metadata table's.
TOPIC_EXTRA_COLUMNS = ("timestamp", "job_id", "batch_id", "experience_name", "build_version")
METADATA_TABLE = "metadata"


@dataclass(frozen=True, slots=True)
class Topic:
    name: str
    schema: Mapping[str, str]
    event: bool = False


@dataclass(frozen=True, slots=True)
class StatusCheck:
    query: str  # Trino SQL with exactly one `?`, the threshold
    block: Any = None
    warn: Any = None


@dataclass(frozen=True, slots=True)
class Metric:
    name: str
    level: Level
    query: str  # Trino SQL, as written
    template: str  # a system template's name, or "custom"
    template_file: str | None = None
    description: str = ""
    units: str | None = None
    skip_if_no_data: bool = False
    settings: Mapping[str, Any] = field(default_factory=dict)
    status: StatusCheck | None = None
    source: Path | None = None  # the config file it came from

    @property
    def custom(self) -> bool:
        return self.template == "custom"


Refresh = Literal["auto", "manual"]
REFRESH_MODES: tuple[Refresh, ...] = ("auto", "manual")


@dataclass(frozen=True, slots=True)
class Dashboard:
    """A dashboard the config defines: the metrics set it shows, how it refreshes and how
    many days of batches it covers (None: the platform's default)."""

    name: str
    metrics_set: str | None = None
    description: str = ""
    refresh: Refresh | None = None
    day_range: int | None = None


@dataclass(frozen=True, slots=True)
class MetricsConfig:
    """A merged, checked config (see `load_config`)."""

    version: Any
    topics: Mapping[str, Topic]
    metrics: Mapping[str, Metric]
    metrics_sets: Mapping[str, tuple[str, ...]]
    dashboards: Mapping[str, Dashboard]
    templates: Mapping[str, str]  # custom template file name -> Liquid text
    files: tuple[Path, ...] = ()
    # What `check` says but does not refuse: unknown keys (refused with --strict) and
    # notices such as `type: report` read as `dashboard`. One line each, naming the file.
    warnings: tuple[str, ...] = ()

    def metrics_for(self, level: Level, metrics_set: str | None = None) -> list[Metric]:
        """The metrics of `level` that run, in the config's order: those of `metrics_set`
        when one is given, else all of them."""
        from stook.service.metrics_config._errors import MetricsConfigError

        if metrics_set is None:
            return [m for m in self.metrics.values() if m.level == level]
        if metrics_set not in self.metrics_sets:
            known = ", ".join(sorted(self.metrics_sets)) or "none"
            raise MetricsConfigError([f"unknown metrics set {metrics_set!r} (known: {known})"])
        chosen = set(self.metrics_sets[metrics_set])
        return [m for m in self.metrics.values() if m.level == level and m.name in chosen]
