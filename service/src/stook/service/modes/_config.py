"""stook.toml: how to fetch, and what to compute in each mode; the user's modules it names.

[fetch]
concurrency = 64       # requests in flight, API and storage together
timeout = 30.0         # seconds per request attempt
retry_for = 120.0      # seconds each request may spend retrying transient failures
deadline = 1800.0      # optional: seconds the whole fetch may take (default: no limit)
page_size = 100        # items asked for per list page (the API's maximum is 100)
adaptive = false       # find the server's pace below `concurrency` (AIMD on 429s and latency)
max_body_mb = 256      # largest metrics data or metric download, decompressed
max_api_body_mb = 16   # largest API answer (a JSON page), decompressed

[engine]
kind = "local"         # "local" (one process), "processes" or "ray"
workers = 8            # processes: worker processes (default: CPU count); ray: CPUs of
                       #   the local instance started when no address is given
shards = 8             # pieces the job (or batch) list is split into (default: processes,
                       #   = workers; ray, 2 x workers or the cluster's CPUs)
# address = "auto"     # ray only: the cluster to join ("auto", "ray://head:10001");
                       #   absent: start a local instance

[output]
preview = false        # also write metrics.html (stook preview) beside metrics.binproto
summary = true         # batch mode: also write the batch's summary (docs/batch-summaries.md)

[test]
metrics = "my_metrics.test:compute"   # called as compute(experience_dir, logs_dir, writer)

[batch]
defaults = true        # the default batch metrics (means, distributions, statuses)
[[batch.weighted_mean]]
name = "Distance-weighted localization error"
metric = "Localization error"
weight = "Distance driven"
"""

from __future__ import annotations

import dataclasses
import importlib.util
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import structlog

from stook.sdk.aggregations import (
    AggregationConfigError,
    BatchAggregation,
    ReportAggregation,
    build_all,
)
from stook.service.modes._baseline import BaselineConfigError, parse_baseline
from stook.service.modes._errors import ConfigError, EngineConfigError, check_number

if TYPE_CHECKING:
    # Imported by a config with a [batch.baseline] table, not by every run (~6 M).
    from stook.service.modes._baseline import BaselineSettings
    from stook.service.modes._config_metrics import MetricsConfigSettings

log = structlog.get_logger("stook.config")


# [engine]: where one run's fetch and fold happens (checked before the first request,
# including that Ray is installed for kind = "ray", without importing it).
ENGINE_KINDS: Final = ("local", "processes", "ray")
_KEYS: Final = {"kind", "workers", "shards", "address"}
RAY_INSTALL_HINT: Final = 'pip install "stook[ray]"'


@dataclass(frozen=True, slots=True)
class EngineSettings:
    kind: str = "local"
    workers: int | None = None  # None: the engine's default (see the module docstring)
    shards: int | None = None
    address: str | None = None


def parse_engine(table: Mapping[str, Any]) -> EngineSettings:
    """The `[engine]` table's settings; raises EngineConfigError naming the key at fault."""
    extra = set(table) - _KEYS
    if extra:
        raise EngineConfigError(
            f"unknown key {sorted(extra)[0]!r} in [engine] (known: {', '.join(sorted(_KEYS))})"
        )
    kind = table.get("kind", "local")
    if kind not in ENGINE_KINDS:
        raise EngineConfigError(
            f"[engine] kind must be one of {', '.join(map(repr, ENGINE_KINDS))}, got {kind!r}"
        )
    address = table.get("address")
    if address is not None:
        if not isinstance(address, str) or not address.strip():
            raise EngineConfigError(
                '[engine] address must be a Ray address ("auto", "ray://head:10001")'
            )
        if kind != "ray":
            raise EngineConfigError(f'[engine] address is for kind = "ray", not {kind!r}')
    return EngineSettings(
        kind=kind,
        workers=_count(table, "workers"),
        shards=_count(table, "shards"),
        address=address,
    )


def _count(table: Mapping[str, Any], key: str) -> int | None:
    value = table.get(key)
    if value is None:
        return None
    return int(check_number(value, f"[engine] {key}", whole=True, error=EngineConfigError))


def require_engine(settings: EngineSettings) -> None:
    """Refuse an engine that cannot run here: Ray not installed (checked without importing it)."""
    if settings.kind == "ray" and not _installed("ray"):
        raise EngineConfigError(
            f'[engine] kind = "ray" needs Ray, which is not installed: {RAY_INSTALL_HINT}'
        )


def _installed(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):  # ValueError: a module in sys.modules without a spec
        return False


# The API spec's `pageSize` maximum; the API answers 400 to more.
MAX_PAGE_SIZE = 100


@dataclass(frozen=True, slots=True)
class FetchSettings:
    concurrency: int = 64
    timeout: float = 30.0
    retry_for: float = 120.0
    deadline: float | None = None
    page_size: int = 100
    adaptive: bool = False
    max_body_mb: float = 256.0
    max_api_body_mb: float = 16.0


# Counts of attempts, replaced by the time budget `retry_for`. Still accepted, so that a
# config written for an older stook keeps working, but ignored with a warning: honouring
# them would bring back runs lost to a two-second outage.
_DEPRECATED_FETCH_KEYS = ("max_attempts", "max_throttled_attempts")


@dataclass(frozen=True, slots=True)
class ReportSettings:
    defaults: bool = True
    top_n: int = 10
    regression_window: int = 10
    regression_threshold: float = 3.5
    job_metrics: tuple[str, ...] | None = None  # None: every SCALAR job metric
    change_points: bool = True
    change_penalty: float = 3.0
    unstable_experiences: bool = True
    # Read a batch's stook summary where it has one, instead of listing its jobs.
    use_summaries: bool = True


@dataclass(frozen=True, slots=True)
class StookConfig:
    source: str = "(built-in defaults)"
    fetch: FetchSettings = field(default_factory=FetchSettings)
    test_metrics: str | None = None
    batch_defaults: bool = True
    # Raw [[batch.<kind>]] tables; built into fresh aggregations per run.
    batch_tables: Mapping[str, list[dict[str, Any]]] = field(default_factory=dict)
    report: ReportSettings = field(default_factory=lambda: ReportSettings())
    # Raw [[report.<kind>]] tables: custom report aggregations.
    report_tables: Mapping[str, list[dict[str, Any]]] = field(default_factory=dict)
    # The file read, if any: user code is imported from beside it.
    file: Path | None = None
    # [batch.baseline]: compare the batch with a baseline batch (None: no comparison).
    baseline: BaselineSettings | None = None
    # [output] preview: write metrics.html beside metrics.binproto.
    preview: bool = False
    # [output] summary: batch mode also writes the batch's summary (BatchSummaryWriter).
    summary: bool = True
    # [engine]: where the fetch and fold runs (modes/_engine.py).
    engine: EngineSettings = field(default_factory=EngineSettings)
    # [metrics_config]: the platform's config-defined metrics (None: none).
    metrics_config: MetricsConfigSettings | None = None

    def batch_aggregations(self) -> list[BatchAggregation]:
        try:
            return build_all(self.batch_tables, section="batch")
        except AggregationConfigError as exc:
            raise ConfigError(f"{self.source}: {exc}") from None

    def report_aggregations(self) -> list[ReportAggregation]:
        try:
            return build_all(self.report_tables, section="report")
        except AggregationConfigError as exc:
            raise ConfigError(f"{self.source}: {exc}") from None


_SECTIONS = {"fetch", "test", "batch", "report", "output", "engine", "metrics_config"}


def load(path: Path | None) -> StookConfig:
    """Read a config file; None means no file: the defaults."""
    if path is None:
        return StookConfig()
    import tomllib  # here: a run without a file (the defaults) need not import it

    name = str(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"config file {name!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(
            f"config file {name!r} cannot be read ({exc.__class__.__name__})"
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{name}: not valid TOML ({exc})") from None
    # Before parse builds the custom aggregations: their modules sit beside the file or in
    # the working directory, as [test] metrics' does.
    add_import_folders(path)
    return dataclasses.replace(parse(doc, source=name), file=path)


def parse(doc: Mapping[str, Any], *, source: str = "stook.toml") -> StookConfig:
    unknown = set(doc) - _SECTIONS
    if unknown:
        raise ConfigError(
            f"{source}: unknown section {sorted(unknown)[0]!r} "
            f"(known: {', '.join(sorted(_SECTIONS))})"
        )
    fetch = _fetch(_table(doc, "fetch", source), source)
    test = _table(doc, "test", source)
    _only(test, {"metrics"}, "[test]", source)
    metrics = test.get("metrics")
    if metrics is not None and (not isinstance(metrics, str) or ":" not in metrics):
        raise ConfigError(f"{source}: [test] metrics must be 'package.module:function'")
    batch = dict(_table(doc, "batch", source))
    defaults = batch.pop("defaults", True)
    if not isinstance(defaults, bool):
        raise ConfigError(f"{source}: [batch] defaults must be true or false")
    baseline = _baseline(batch.pop("baseline", None), source)
    report, report_tables = _report(_table(doc, "report", source), source)
    output = _table(doc, "output", source)
    _only(output, {"preview", "summary"}, "[output]", source)
    preview = output.get("preview", False)
    if not isinstance(preview, bool):
        raise ConfigError(f"{source}: [output] preview must be true or false")
    summary = output.get("summary", True)
    if not isinstance(summary, bool):
        raise ConfigError(f"{source}: [output] summary must be true or false")
    config = StookConfig(
        source=source,
        fetch=fetch,
        test_metrics=metrics,
        batch_defaults=defaults,
        batch_tables=batch,
        report=report,
        report_tables=report_tables,
        baseline=baseline,
        preview=preview,
        summary=summary,
        engine=_engine(_table(doc, "engine", source), source),
        metrics_config=_metrics_config(doc.get("metrics_config"), source),
    )
    # Fail now, before any fetching, on a bad table.
    config.batch_aggregations()
    config.report_aggregations()
    return config


def _baseline(table: Any, source: str) -> BaselineSettings | None:
    if table is None:
        return None
    try:
        return parse_baseline(table)
    except BaselineConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None


def _metrics_config(table: Any, source: str) -> MetricsConfigSettings | None:
    if table is None:
        return None
    from stook.service.modes._config_metrics import (
        MetricsConfigSettingsError,
        parse_metrics_config,
    )

    if not isinstance(table, dict):
        raise ConfigError(f"{source}: [metrics_config] must be a table")
    try:
        return parse_metrics_config(table)
    except MetricsConfigSettingsError as exc:
        raise ConfigError(f"{source}: [metrics_config] {exc}") from None


def _engine(table: Mapping[str, Any], source: str) -> EngineSettings:
    try:
        return parse_engine(table)
    except EngineConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None


def _table(doc: Mapping[str, Any], key: str, source: str) -> Mapping[str, Any]:
    value = doc.get(key, {})
    if not isinstance(value, dict):
        raise ConfigError(f"{source}: [{key}] must be a table")
    return value


def _only(table: Mapping[str, Any], allowed: set[str], where: str, source: str) -> None:
    extra = set(table) - allowed
    if extra:
        raise ConfigError(
            f"{source}: unknown key {sorted(extra)[0]!r} in {where} "
            f"(known: {', '.join(sorted(allowed))})"
        )


def _report(
    table: Mapping[str, Any], source: str
) -> tuple[ReportSettings, dict[str, list[dict[str, Any]]]]:
    numbers = {"top_n", "regression_window", "regression_threshold", "change_penalty"}
    known = {"defaults", "change_points", "unstable_experiences", "use_summaries", *numbers}
    # The tables (lists and dicts) are the aggregations', checked by build_all, which names
    # a dict where a list belongs; a number setting is one whatever its type
    # (change_points and unstable_experiences are a switch and a kind of table both).
    is_setting = {k: k in numbers or not isinstance(v, list | dict) for k, v in table.items()}
    settings = {k: v for k, v in table.items() if is_setting[k]}
    tables: dict[str, Any] = {k: v for k, v in table.items() if not is_setting[k]}
    job_metrics = table.get("job_metrics")
    if job_metrics is not None:
        tables.pop("job_metrics", None)
        if not isinstance(job_metrics, list) or not all(isinstance(m, str) for m in job_metrics):
            raise ConfigError(f"{source}: [report] job_metrics must be a list of metric names")
    _only(settings, known, "[report]", source)
    defaults = ReportSettings()
    flag = settings.get("defaults", True)
    if not isinstance(flag, bool):
        raise ConfigError(f"{source}: [report] defaults must be true or false")
    switches = {
        k: settings.get(k, True) for k in ("change_points", "unstable_experiences", "use_summaries")
    }
    for key, value in switches.items():
        if not isinstance(value, bool):
            raise ConfigError(f"{source}: [report] {key} must be true or false")

    def number(key: str, kind: type[int] | type[float], default: float) -> Any:
        value = settings.get(key, default)
        return check_number(value, f"{source}: [report] {key}", whole=kind is int)

    return (
        ReportSettings(
            defaults=flag,
            top_n=number("top_n", int, defaults.top_n),
            regression_window=number("regression_window", int, defaults.regression_window),
            regression_threshold=number(
                "regression_threshold", float, defaults.regression_threshold
            ),
            job_metrics=tuple(job_metrics) if job_metrics is not None else None,
            change_penalty=number("change_penalty", float, defaults.change_penalty),
            **switches,
        ),
        tables,
    )


def _fetch(table: Mapping[str, Any], source: str) -> FetchSettings:
    for key in _DEPRECATED_FETCH_KEYS:
        if key in table:
            log.warning(
                "deprecated setting ignored",
                setting=f"[fetch] {key}",
                config=source,
                hint="retries are bounded by time now: [fetch] retry_for, in seconds",
            )
    table = {k: v for k, v in table.items() if k not in _DEPRECATED_FETCH_KEYS}
    _only(
        table,
        {
            "concurrency",
            "timeout",
            "retry_for",
            "deadline",
            "page_size",
            "adaptive",
            "max_body_mb",
            "max_api_body_mb",
        },
        "[fetch]",
        source,
    )
    defaults = FetchSettings()
    adaptive = table.get("adaptive", defaults.adaptive)
    if not isinstance(adaptive, bool):
        raise ConfigError(f"{source}: [fetch] adaptive must be true or false")

    def positive(key: str, kind: type[int] | type[float], default: float) -> Any:
        value = table.get(key, default)
        return check_number(value, f"{source}: [fetch] {key}", whole=kind is int)

    page_size = check_number(
        table.get("page_size", defaults.page_size),
        f"{source}: [fetch] page_size",
        whole=True,
        at_most=MAX_PAGE_SIZE,
        why=" (the API's limit)",
    )
    return FetchSettings(
        concurrency=positive("concurrency", int, defaults.concurrency),
        timeout=positive("timeout", float, defaults.timeout),
        retry_for=positive("retry_for", float, defaults.retry_for),
        deadline=positive("deadline", float, 0.0) if "deadline" in table else None,
        page_size=int(page_size),
        adaptive=adaptive,
        max_body_mb=positive("max_body_mb", float, defaults.max_body_mb),
        max_api_body_mb=positive("max_api_body_mb", float, defaults.max_api_body_mb),
    )


def engine_for(config: StookConfig, kind: str | None = None) -> EngineSettings:
    """`[engine]`, its kind replaced by `--engine` when given; refuses one that cannot run
    here (Ray not installed) before the first request (ConfigError, exit 2)."""
    engine = config.engine
    if kind is not None and kind != engine.kind:
        # The table's address is Ray's: it says nothing to another kind.
        address = engine.address if kind == "ray" else None
        engine = dataclasses.replace(engine, kind=kind, address=address)
    try:
        require_engine(engine)
    except EngineConfigError as exc:
        source = "--engine" if kind is not None else config.source
        raise ConfigError(f"{source}: {exc}") from None
    return engine


# --- the user's modules: where they are imported from ----------------------------------------

# Where user code named in stook.toml is imported from.
#
# ``[test] metrics = "my_metrics.test:compute"`` and ``[[batch.custom]] class = ...`` name
# modules that usually sit beside stook.toml or in the working directory, as the docs'
# examples have it. The ``stook`` console script puts neither on Python's import path (its
# own folder is what ``sys.path[0]`` holds), so both are put there, first, as ``python -m``
# would: the config file's folder, then the working directory.


def import_folders(config_file: Path | None) -> list[Path]:
    """The folders user code is looked for in before the rest of the Python path."""
    folders = [config_file.resolve().parent] if config_file is not None else []
    cwd = Path.cwd()
    if cwd not in folders:
        folders.append(cwd)
    return folders


def add_import_folders(config_file: Path | None) -> None:
    """Put :func:`import_folders` at the front of ``sys.path``, each once."""
    for folder in reversed(import_folders(config_file)):
        entry = str(folder)
        if entry in sys.path:
            sys.path.remove(entry)
        sys.path.insert(0, entry)


def describe_search(config_file: Path | None) -> str:
    """What was searched, for an import error: the folders by role, then the Python path."""
    folders = import_folders(config_file)
    roles = []
    if config_file is not None:
        roles.append(f"the config file's folder {str(folders[0])!r}")
    if len(folders) > len(roles):
        roles.append(f"the working directory {str(folders[-1])!r}")
    return "searched " + ", ".join(roles) + " and then the Python path (PYTHONPATH, site-packages)"
