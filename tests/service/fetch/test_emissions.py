"""Each job's emissions log, fetched from the emulator: the listing's model, the download
on the storage client (retried, relisted on expiry, never with the token), and jobs
without a log."""

from __future__ import annotations

import re
import uuid

import pytest

from stook.emulator import EMISSIONS_FILE, Emulator, EmulatorConfig
from stook.service.api import ApiClient, JobLog, LogType, RetriesExhaustedError, RetryPolicy
from stook.service.fetch import fetch_emissions, fetch_emissions_log

_SMALL = EmulatorConfig(jobs_per_batch=12, report_batches=2, report_jobs_per_batch=4)


def _policy(max_attempts: int = 4) -> RetryPolicy:
    return RetryPolicy(initial_backoff=0, request_timeout=5.0, max_attempts=max_attempts)


async def test_the_listing_reads_into_job_logs() -> None:
    async with Emulator(_SMALL) as emu, ApiClient(emu.api_url, emu.token) as api:
        job = next(j for j in emu.dataset.jobs(emu.batch_id) if j.has_metrics)
        logs = [log async for log in api.list_job_logs(emu.project_id, emu.batch_id, job.id)]
        assert [log.log_type for log in logs] == [LogType.CONTAINER_LOG, LogType.EMISSIONS_LOG]
        emissions = logs[1]
        assert isinstance(emissions, JobLog)
        assert emissions.file_name == EMISSIONS_FILE
        assert emissions.job_id == job.id
        expected = emu.dataset.job_emissions(emu.batch_id, job.id)
        assert expected is not None
        assert emissions.file_size == len(expected)
        only = [
            log
            async for log in api.list_job_logs(
                emu.project_id, emu.batch_id, job.id, log_type=LogType.EMISSIONS_LOG
            )
        ]
        assert [log.log_id for log in only] == [emissions.log_id]


async def test_every_jobs_emissions_as_the_emulator_stored_them() -> None:
    async with Emulator(_SMALL) as emu, ApiClient(emu.api_url, emu.token) as api:
        jobs = list(emu.dataset.jobs(emu.batch_id))
        got: dict[uuid.UUID, bytes | None] = {}
        with_log = await fetch_emissions(
            api,
            emu.project_id,
            jobs,
            ids_of=lambda j: (j.batch_id, j.id),
            on_job=lambda j, body: got.__setitem__(j.id, body),
            workers=3,
        )
        expected = {j.id: emu.dataset.job_emissions(emu.batch_id, j.id) for j in jobs}
        assert got == expected
        assert None in got.values()  # a job without an emissions log counts as no rows
        assert with_log == sum(body is not None for body in expected.values())
        assert emu.stats.leaked_tokens == 0


async def test_a_failing_storage_download_is_retried() -> None:
    # Every storage request fails twice (503/502/500) before it is answered.
    config = _SMALL.replace(fault_5xx=1.0, fault_origins=("storage",), max_consecutive_faults=2)
    async with (
        Emulator(config) as emu,
        ApiClient(emu.api_url, emu.token, retry=_policy()) as api,
    ):
        job = next(j for j in emu.dataset.jobs(emu.batch_id) if j.has_metrics)
        body = await fetch_emissions_log(api, emu.project_id, emu.batch_id, job.id)
        assert body == emu.dataset.job_emissions(emu.batch_id, job.id)
        assert emu.stats.faults["storage:5xx"] == 2
        assert api.storage.stats.retries == 2
        assert emu.stats.leaked_tokens == 0


async def test_a_download_that_keeps_failing_fails_the_fetch() -> None:
    config = _SMALL.replace(fault_5xx=1.0, fault_origins=("storage",), max_consecutive_faults=5)
    async with (
        Emulator(config) as emu,
        ApiClient(emu.api_url, emu.token, retry=_policy(max_attempts=3)) as api,
    ):
        jobs = [j for j in emu.dataset.jobs(emu.batch_id) if j.has_metrics]
        with pytest.raises(RetriesExhaustedError) as failed:
            await fetch_emissions(
                api,
                emu.project_id,
                jobs,
                ids_of=lambda j: (j.batch_id, j.id),
                on_job=lambda j, body: None,
                workers=2,
            )
        message = str(failed.value)
        assert "logs/" in message  # names the download that failed
        assert re.search(r"Signature=[0-9a-f]{8}", message) is None
        assert emu.token not in message
        assert emu.stats.leaked_tokens == 0
