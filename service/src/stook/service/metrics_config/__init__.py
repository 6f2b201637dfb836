"""Config-defined metrics: the platform's `config.resim.yml` over emissions, in stook.

    from stook.service.metrics_config import EmissionsSet, JobMeta, evaluate, load_config

    config = load_config([Path(".resim/metrics/config.resim.yml")])
    emissions = EmissionsSet(config)
    emissions.add_job(JobMeta(job_id=str(job_id)), Path("emissions.resim.jsonl"))
    evaluate(config, emissions.tables(), writer, level="test")

Configs are YAML (merged by the platform's rules), emissions are checked and loaded
into one polars frame per topic, queries are Trino SQL transpiled by sqlglot and run by
DuckDB in this process, custom templates are Liquid. The layer imports stook.sdk only;
modes and the CLI import it.
"""

TYPE_CHECKING = False
if TYPE_CHECKING:
    from stook.service.metrics_config._emissions import EmissionsSet, Tables
    from stook.service.metrics_config._errors import (
        EmissionsError,
        MetricsConfigError,
        QueryError,
        TemplateError,
    )
    from stook.service.metrics_config._evaluate import Evaluation, evaluate
    from stook.service.metrics_config._jobs import JobMeta
    from stook.service.metrics_config._load import load_config
    from stook.service.metrics_config._model import LEVELS, Level, Metric, MetricsConfig, Topic
    from stook.service.metrics_config._offline import (
        check_config,
        read_emissions_paths,
        stable_id,
    )
else:
    from stook.service._lazy import lazy_exports

    __getattr__, __dir__ = lazy_exports(
        __name__,
        {
            "EmissionsSet": "stook.service.metrics_config._emissions",
            "Tables": "stook.service.metrics_config._emissions",
            "EmissionsError": "stook.service.metrics_config._errors",
            "MetricsConfigError": "stook.service.metrics_config._errors",
            "QueryError": "stook.service.metrics_config._errors",
            "TemplateError": "stook.service.metrics_config._errors",
            "Evaluation": "stook.service.metrics_config._evaluate",
            "evaluate": "stook.service.metrics_config._evaluate",
            "JobMeta": "stook.service.metrics_config._jobs",
            "load_config": "stook.service.metrics_config._load",
            "LEVELS": "stook.service.metrics_config._model",
            "Level": "stook.service.metrics_config._model",
            "Metric": "stook.service.metrics_config._model",
            "MetricsConfig": "stook.service.metrics_config._model",
            "Topic": "stook.service.metrics_config._model",
            "check_config": "stook.service.metrics_config._offline",
            "read_emissions_paths": "stook.service.metrics_config._offline",
            "stable_id": "stook.service.metrics_config._offline",
        },
    )

__all__ = [
    "LEVELS",
    "EmissionsError",
    "EmissionsSet",
    "Evaluation",
    "JobMeta",
    "Level",
    "Metric",
    "MetricsConfig",
    "MetricsConfigError",
    "QueryError",
    "Tables",
    "TemplateError",
    "Topic",
    "check_config",
    "evaluate",
    "load_config",
    "read_emissions_paths",
    "stable_id",
]
