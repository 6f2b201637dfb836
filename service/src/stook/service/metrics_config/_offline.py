"""What `stook metrics-config` needs beyond the engine: the static check of a config,
and emissions given as files and folders on this machine."""

from __future__ import annotations

import json
import uuid
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from stook.service.metrics_config._emissions import EmissionsSet
from stook.service.metrics_config._errors import EmissionsError
from stook.service.metrics_config._jobs import JobMeta
from stook.service.metrics_config._liquid import template_problem
from stook.service.metrics_config._model import MetricsConfig
from stook.service.metrics_config._query_engine import QueryEngine

EMISSIONS_NAME = "emissions.resim.jsonl"
JOB_META_NAME = "job.json"

# Generated IDs are derived from names, not drawn at random: the same inputs give the
# same output, byte for byte.
_NAMESPACE = uuid.UUID("6f1c3c38-5a0e-4e4b-9a1d-3b8e2f6d7c10")


def stable_id(kind: str, name: str) -> str:
    return str(uuid.uuid5(_NAMESPACE, f"{kind}:{name}"))


def check_config(config: MetricsConfig) -> list[str]:
    """Every metric query (and status query) that does not bind against the topics'
    schemas and every custom template that does not parse, one line each; load_config
    has checked the rest."""
    problems = []
    for metric in config.metrics.values():
        if metric.template_file is not None and metric.template_file in config.templates:
            why = template_problem(metric.template_file, config.templates[metric.template_file])
            if why:
                problems.append(f"{metric.source}: metrics {metric.name!r}: {why}")
    with QueryEngine(EmissionsSet(config).tables()) as engine:
        for metric in config.metrics.values():
            where = f"{metric.source}: metrics {metric.name!r}"
            why = engine.bind(metric.query)
            if why:
                problems.append(f"{where}: query_string does not run: {why}")
            if metric.status is not None:
                why = engine.bind(metric.status.query)
                if why:
                    problems.append(f"{where}: the status query_string does not run: {why}")
    return problems


@dataclass(frozen=True, slots=True)
class OfflineJob:
    meta: JobMeta
    emissions: Path
    folder: Path  # where the job's attached files are


def find_jobs(paths: Sequence[Path]) -> list[OfflineJob]:
    """Each PATH is one emissions file (one job) or a folder of per-job sub-folders,
    each with emissions.resim.jsonl and optionally job.json."""
    jobs: list[OfflineJob] = []
    for path in paths:
        if path.is_file():
            jobs.append(_job(path, path.parent, path.parent.name or "job"))
        elif path.is_dir():
            found = sorted(p for p in path.iterdir() if (p / EMISSIONS_NAME).is_file())
            if not found:
                raise EmissionsError(
                    f"{path}: no job folder in it holds {EMISSIONS_NAME} (give a file, or a "
                    "folder of per-job folders)"
                )
            jobs.extend(_job(p / EMISSIONS_NAME, p, p.name, batch=path.name) for p in found)
        else:
            raise EmissionsError(f"{path}: no such file or folder")
    return jobs


def _job(emissions: Path, folder: Path, name: str, *, batch: str | None = None) -> OfflineJob:
    values: dict[str, object] = {}
    meta_file = folder / JOB_META_NAME
    if batch is not None and meta_file.is_file():
        try:
            loaded = json.loads(meta_file.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise EmissionsError(f"{meta_file}: not JSON ({exc})") from None
        if not isinstance(loaded, dict):
            raise EmissionsError(f"{meta_file}: must be a JSON object of metadata keys")
        values = loaded
    values.setdefault("job_id", stable_id("job", name))
    values.setdefault("batch_id", stable_id("batch", batch or name))
    return OfflineJob(JobMeta.from_mapping(values, source=str(meta_file)), emissions, folder)
