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

# Eager: each module imports its heavy libraries (polars, DuckDB, sqlglot, PyYAML,
# python-liquid) inside the functions that use them, so importing the package is cheap.
from stook.service.metrics_config._emissions import EmissionsSet, Tables
from stook.service.metrics_config._errors import (
    EmissionsError,
    MetricsConfigError,
    QueryError,
    TemplateError,
)
from stook.service.metrics_config._evaluate import Evaluation, evaluate
from stook.service.metrics_config._jobs import JobMeta
from stook.service.metrics_config._load import load_config, read_config
from stook.service.metrics_config._model import LEVELS, Level, Metric, MetricsConfig, Topic
from stook.service.metrics_config._offline import OfflineJob, check_config, find_jobs, stable_id

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
    "OfflineJob",
    "QueryError",
    "Tables",
    "TemplateError",
    "Topic",
    "check_config",
    "evaluate",
    "find_jobs",
    "load_config",
    "read_config",
    "stable_id",
]
