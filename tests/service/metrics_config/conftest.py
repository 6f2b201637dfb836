from __future__ import annotations

from pathlib import Path

import pytest

from stook.testing.metrics_config_fixture import write_fixture
from tests.service.metrics_config.emitted import JobData, emit_job, make_job


@pytest.fixture
def config(tmp_path: Path) -> Path:
    return write_fixture(tmp_path / "repo")


@pytest.fixture
def one_job(tmp_path: Path, config: Path) -> tuple[Path, JobData]:
    job = make_job(0)
    return emit_job(tmp_path / "test-job", config, job), job


BATCH_META = [
    {"experience_name": "exp-a", "job_conflated_status": "PASSED", "build_version": "1.0"},
    {"experience_name": "exp-b", "job_conflated_status": "BLOCKER", "build_version": "1.0"},
    {"experience_name": "exp-c", "job_conflated_status": "PASSED", "build_version": "1.1"},
]


@pytest.fixture
def batch(tmp_path: Path, config: Path) -> tuple[Path, list[JobData]]:
    folder = tmp_path / "batch"
    jobs = []
    for k, meta in enumerate(BATCH_META):
        job = make_job(k)
        job.name = meta["experience_name"]
        ids = {"job_id": f"job-{k}", "batch_id": "nightly-42"}  # names, not UUIDs
        emit_job(folder / f"job-{k}", config, job, meta={**meta, **ids})
        jobs.append(job)
    return folder, jobs
