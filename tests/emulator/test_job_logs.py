"""The emulated job logs: the listing's filters and paging, the files in storage, and the
emissions every job that ran uploaded (deterministic, and valid against the world's
config.resim.yml)."""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator
from pathlib import Path

import aiohttp
import orjson
import pytest
from resim.sdk.metrics.emissions import Emitter, merge_metrics_config_files

from stook.emulator import EMISSIONS_CONFIG_YAML, EMISSIONS_FILE, Emulator, EmulatorConfig
from tests.emulator.support import SMALL, Raw


@pytest.fixture
async def raw() -> AsyncIterator[Raw]:
    async with Emulator(SMALL) as emu, aiohttp.ClientSession() as session:
        yield Raw(emu, session)


def _logs_path(raw: Raw, job_id: uuid.UUID, batch_id: uuid.UUID | None = None) -> str:
    return f"/batches/{batch_id or raw.emu.batch_id}/jobs/{job_id}/logs"


def _jobs(raw: Raw) -> list[tuple[uuid.UUID, bool]]:
    """The main batch's jobs, each with whether it uploaded an emissions log."""
    ds = raw.emu.dataset
    return [
        (j.id, ds.job_emissions(raw.emu.batch_id, j.id) is not None)
        for j in ds.jobs(raw.emu.batch_id)
    ]


async def test_an_emissions_log_is_listed_with_the_specs_fields(raw: Raw) -> None:
    job_id = next(j for j, has in _jobs(raw) if has)
    status, body = await raw.get(_logs_path(raw, job_id), params={"type": "EMISSIONS_LOG"})
    assert status == 200
    assert body["total"] == 1
    assert body["nextPageToken"] == ""
    (entry,) = body["logs"]
    assert entry["fileName"] == EMISSIONS_FILE
    assert entry["logType"] == "EMISSIONS_LOG"
    assert entry["executionStep"] == "EXPERIENCE"
    assert entry["jobID"] == str(job_id)
    assert entry["filePath"] == ""
    assert entry["fullPath"] == EMISSIONS_FILE
    for key in ("logID", "checksum", "creationTimestamp", "location", "userID", "orgID"):
        assert entry[key], key

    expected = raw.emu.dataset.job_emissions(raw.emu.batch_id, job_id)
    assert expected is not None
    assert entry["fileSize"] == len(expected)
    url = entry["logOutputLocation"]
    assert url.startswith(raw.emu.storage_url)
    assert await raw.fetch(url) == (200, expected)
    # The storage origin refuses a request that carries the API token.
    status, _ = await raw.fetch(url, headers=raw.auth)
    assert status == 400
    assert raw.emu.stats.leaked_tokens == 1


async def test_the_type_and_name_filters_and_paging(raw: Raw) -> None:
    job_id = next(j for j, has in _jobs(raw) if has)
    path = _logs_path(raw, job_id)
    status, body = await raw.get(path)
    assert status == 200
    assert [e["logType"] for e in body["logs"]] == ["CONTAINER_LOG", "EMISSIONS_LOG"]
    url = raw.url(path) + "?type=CONTAINER_LOG&type=MCAP_LOG"  # a repeated filter
    async with raw.session.get(url, headers=raw.auth) as answer:
        body = await answer.json()
    assert [e["logType"] for e in body["logs"]] == ["CONTAINER_LOG"]
    status, body = await raw.get(path, params={"name": EMISSIONS_FILE})
    assert [e["fileName"] for e in body["logs"]] == [EMISSIONS_FILE]
    status, body = await raw.get(path, params={"pageSize": 1})
    assert len(body["logs"]) == 1
    assert body["nextPageToken"]
    assert body["total"] == 2
    status, rest = await raw.get(path, params={"pageSize": 1, "pageToken": body["nextPageToken"]})
    assert [e["logType"] for e in rest["logs"]] == ["EMISSIONS_LOG"]
    assert (await raw.get(path, params={"type": "NOT_A_LOG"}))[0] == 400


async def test_jobs_that_died_early_have_no_emissions_log(raw: Raw) -> None:
    without = [j for j, has in _jobs(raw) if not has]
    assert without  # every sizeable batch has a job that died before its metrics
    for job_id in without:
        status, body = await raw.get(_logs_path(raw, job_id), params={"type": "EMISSIONS_LOG"})
        assert status == 200
        assert body["logs"] == []
        assert body["total"] == 0


async def test_unknown_jobs_and_bad_ids(raw: Raw) -> None:
    assert (await raw.get(_logs_path(raw, uuid.uuid4())))[0] == 404
    status, _ = await raw.get(f"/batches/{raw.emu.batch_id}/jobs/not-a-uuid/logs")
    assert status == 400


def test_resims_emitter_accepts_the_config_and_writes_the_same_lines(tmp_path: Path) -> None:
    """ReSim's own Emitter (the oracle) validates every emitted row against the world's
    config.resim.yml and, emitting the same rows, writes the same lines."""
    config = tmp_path / "config.resim.yml"
    config.write_text(EMISSIONS_CONFIG_YAML)
    merged = merge_metrics_config_files([config])
    topics = merged["topics"]
    ds = Emulator(SMALL).dataset
    seen: set[str] = set()
    for batch in ds.batches[:2]:
        for job, rows in ds.emitted_rows(batch.id):
            body = ds.job_emissions(batch.id, job.id)
            if rows is None:
                assert body is None
                continue
            assert body is not None
            out = tmp_path / f"{job.id}.jsonl"
            with Emitter(config_path=config, output_path=out) as emitter:
                for row in rows:
                    if row.event:
                        emitter.emit_event(row.topic, row.data, timestamp=row.timestamp)
                    else:
                        emitter.emit(row.topic, row.data, timestamp=row.timestamp)
                    seen.add(row.topic)
            theirs = [orjson.loads(line) for line in out.read_bytes().splitlines()]
            ours = [orjson.loads(line) for line in body.splitlines()]
            assert ours == theirs
    assert seen == set(topics)
    for metric in merged["metrics"].values():
        assert metric["type"] in ("test", "batch", "dashboard")


def test_emissions_are_deterministic_by_seed() -> None:
    a, b = Emulator(SMALL).dataset, Emulator(SMALL).dataset
    c = Emulator(SMALL.replace(seed=1)).dataset
    job = a.jobs(a.main_batch_id)[0]
    assert a.job_emissions(a.main_batch_id, job.id) == b.job_emissions(b.main_batch_id, job.id)
    other = c.jobs(c.main_batch_id)[0]
    assert a.job_emissions(a.main_batch_id, job.id) != c.job_emissions(c.main_batch_id, other.id)


def test_emission_frames_sets_the_rows_a_job_emits() -> None:
    ds = Emulator(EmulatorConfig(jobs_per_batch=2, emission_frames=500)).dataset
    rows = next(rows for _, rows in ds.emitted_rows(ds.main_batch_id) if rows is not None)
    assert len(rows) >= 1000
    with pytest.raises(ValueError, match="emission_frames"):
        EmulatorConfig(emission_frames=-1)
