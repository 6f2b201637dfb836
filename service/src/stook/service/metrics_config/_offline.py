"""What `stook metrics-config` needs beyond the engine: the static check of a config,
and emissions given as files and folders on this machine."""

from __future__ import annotations

import re
import stat
import uuid
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stook.service.metrics_config._emissions import EmissionsSet, decode_strict
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
    emissions: Path | None  # None: a job folder with job.json and no emissions
    folder: Path  # where the job's attached files are
    source: Path  # what named the job: its job.json, else its emissions file


def find_jobs(paths: Sequence[Path]) -> list[OfflineJob]:
    """Each PATH is one emissions file (one job) or a folder of jobs: per-job
    sub-folders, each with emissions.resim.jsonl and optionally job.json, and the SDK's
    own `emissions_<job_id>.resim.jsonl` files. What cannot be read is an error naming
    it, never a job left out."""
    jobs: list[OfflineJob] = []
    for path in paths:
        if _kind(path) == "file":
            jobs.append(_single(path))
        else:
            found = _folder_jobs(path)
            if not found:
                raise EmissionsError(
                    f"{path}: no job folder in it holds {EMISSIONS_NAME}, and no "
                    f"emissions_<job_id>.resim.jsonl is in it (give a file, or a folder of "
                    "jobs)"
                )
            jobs.extend(found)
    named: dict[str, Path] = {}
    for job in jobs:
        first = named.setdefault(job.meta.job_id, job.source)
        if first is not job.source:
            raise EmissionsError(
                f"job_id {job.meta.job_id!r} is given twice: by {first} and by {job.source}"
            )
    return jobs


def sdk_job_id(name: str) -> str | None:
    """The job ID in an SDK emissions file's name (`emissions_<job_id>.resim.jsonl`)."""
    found = _SDK_NAME.fullmatch(name)
    return found.group(1) if found else None


_SDK_NAME = re.compile(r"emissions_(.+)\.resim\.jsonl")


def _kind(path: Path, *, optional: bool = False) -> str | None:
    """ "file" (a regular one) or "folder"; None when absent and `optional`; else an
    error naming the path (a symlink loop, a FIFO, no permission)."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        if optional and not path.is_symlink():
            return None
        raise EmissionsError(f"{path}: no such file or folder") from None
    except OSError as exc:
        raise EmissionsError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if stat.S_ISREG(mode):
        return "file"
    if stat.S_ISDIR(mode):
        return "folder"
    raise EmissionsError(f"{path}: neither a file nor a folder")


def _single(emissions: Path) -> OfflineJob:
    job_id = sdk_job_id(emissions.name) or stable_id("job", emissions.parent.name or "job")
    meta = JobMeta(job_id=job_id, batch_id=stable_id("batch", emissions.parent.name or "job"))
    return OfflineJob(meta, emissions, emissions.parent, emissions)


def _folder_jobs(folder: Path) -> list[OfflineJob]:
    try:
        entries = sorted(folder.iterdir())
    except OSError as exc:
        raise EmissionsError(f"{folder}: cannot be read ({exc.strerror or exc})") from None
    batch = stable_id("batch", folder.name)
    jobs = []
    for entry in entries:
        job_id = sdk_job_id(entry.name)
        if job_id is not None:  # the SDK's local layout: the job's ID in the name
            if _kind(entry) != "file":
                raise EmissionsError(f"{entry}: a folder, not an emissions file")
            jobs.append(OfflineJob(JobMeta(job_id=job_id, batch_id=batch), entry, folder, entry))
        elif _kind(entry) == "folder":
            job = _folder_job(entry, folder.name)
            if job is not None:
                jobs.append(job)
    return jobs


def _folder_job(folder: Path, batch: str) -> OfflineJob | None:
    """A job folder's job (None: the folder holds neither file, so is no job's)."""
    emissions = folder / EMISSIONS_NAME
    meta_file = folder / JOB_META_NAME
    has_emissions, has_meta = _kind(emissions, optional=True), _kind(meta_file, optional=True)
    for path, kind in ((emissions, has_emissions), (meta_file, has_meta)):
        if kind == "folder":
            raise EmissionsError(f"{path}: a folder, not a file")
    if has_emissions is None and has_meta is None:
        return None
    values = read_job_json(meta_file) if has_meta else {}
    values.setdefault("job_id", stable_id("job", folder.name))
    values.setdefault("batch_id", stable_id("batch", batch))
    meta = JobMeta.from_mapping(values, source=str(meta_file))
    source = meta_file if has_meta else emissions
    return OfflineJob(meta, emissions if has_emissions else None, folder, source)


MAX_JOB_JSON_BYTES = 1 << 20
"""A job.json is a few hundred bytes; more than this is not one."""


def read_job_json(path: Path) -> dict[str, Any]:
    """A job.json's object, decoded strictly (as emission rows are); EmissionsError
    names the file, and the line where there is one."""
    try:
        with path.open("rb") as file:
            data = file.read(MAX_JOB_JSON_BYTES + 1)
    except OSError as exc:
        raise EmissionsError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if len(data) > MAX_JOB_JSON_BYTES:
        raise EmissionsError(f"{path}: larger than {MAX_JOB_JSON_BYTES:,} bytes")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise EmissionsError(f"{path} line {line}: not UTF-8") from None
    try:
        loaded = decode_strict(text)
    except ValueError as exc:
        raise EmissionsError(f"{path}: {exc}") from None
    if not isinstance(loaded, dict):
        raise EmissionsError(f"{path}: must be a JSON object of metadata keys")
    return loaded
