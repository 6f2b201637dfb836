"""The fetch library against the emulator: what each plan costs in requests, what its
records hold against the emulator's own data, early exits, errors, and the examples of
the README and the library page run as written."""

from __future__ import annotations

import asyncio
import contextlib
import subprocess
import sys
import uuid
from collections import Counter
from collections.abc import AsyncIterator
from pathlib import Path

import polars as pl
import pytest

from stook.emulator import Emulator
from stook.emulator._store import MetricsOutput
from stook.sdk import MetricType
from stook.sdk.aggregations import JobRecord, Needs, default_batch_aggregations
from stook.service import (
    AuthError,
    fetch_batch,
    fetch_batch_frame,
    fetch_report,
)
from stook.service.fetch import DeadlineReachedError
from stook.service.modes import ApiAccess, ConfigError, InputsError, MissingJobsError
from stook.testing import emulated_batch
from tests.docs_examples import block

ROOT = Path(__file__).resolve().parents[2]
JOBS = 24
HISTOGRAM = "Acceleration distribution"


async def _collect(needs: Needs, emu: Emulator, **settings: object) -> list[JobRecord]:
    access = ApiAccess(api_url=emu.api_url, token=emu.token, project_id=emu.project_id)
    return [
        job
        async for job in fetch_batch(access, batch_id=emu.batch_id, needs=needs, **settings)  # type: ignore[arg-type]
    ]


def _storage(emu: Emulator) -> Counter[str]:
    return Counter({k: v for k, v in emu.stats.endpoints.items() if k.startswith("storage:")})


def _outputs(emu: Emulator) -> dict[uuid.UUID, MetricsOutput | None]:
    return {
        job.id: emu.dataset.job_output(emu.batch_id, job.id)
        for job in emu.dataset.jobs(emu.batch_id)
    }


async def test_what_each_plan_downloads(tmp_path: Path) -> None:
    # Pages large enough that each listing is one request, so requests count listings.
    async with emulated_batch(
        tmp_path / "inputs", jobs_per_batch=JOBS, seed=3, default_page_size=100, max_page_size=100
    ) as emu:
        outputs = {
            j.id: emu.dataset.job_output(emu.batch_id, j.id) for j in emu.dataset.jobs(emu.batch_id)
        }
        # The default batch metrics' plan: listings only, no blob at all.
        defaults = Needs()
        for aggregation in default_batch_aggregations():
            defaults = defaults | aggregation.needs()
        records = await _collect(defaults, emu)
        assert len(records) == JOBS
        assert _storage(emu) == Counter()
        assert emu.stats.endpoints["api:list_job_metrics"] == JOBS
        for name in ("list_job_metrics_data", "list_events", "list_experience_tags"):
            assert emu.stats.endpoints[f"api:{name}"] == 0
        emu.stats.reset()

        # One histogram metric: its blob and the blobs of the data it references, per job.
        records = await _collect(Needs(metrics=frozenset({HISTOGRAM})), emu)
        expected_metrics = expected_data = 0
        for output in outputs.values():
            assert output is not None
            for stored in output.metrics:
                if stored.name == HISTOGRAM:
                    expected_metrics += 1
                    expected_data += len(stored.data_ids)
        assert expected_metrics > 0
        assert _storage(emu) == Counter(
            {"storage:job_metric": expected_metrics, "storage:job_metrics_data": expected_data}
        )
        for record in records:
            view = record.job_metrics
            assert view is not None
            truth = emu.dataset.truth(emu.batch_id, record.job_id)
            if not view.metrics:
                assert "accelerations" not in truth.series
                continue
            (metric,) = view.metrics
            assert metric.type is MetricType.HISTOGRAM
            values = view.data_by_id[metric.data_ids[0]].series().to_list()
            assert values == list(truth.series["accelerations"])
        emu.stats.reset()

        # Every metric of every job: every blob the jobs have (what ReSim's fetcher loads).
        records = await _collect(Needs(every_metric=True), emu)
        every_metric = sum(len(o.metrics) for o in outputs.values() if o is not None)
        every_data = sum(
            sum(d.storage_type == "STANDARD" for d in o.data)
            for o in outputs.values()
            if o is not None
        )
        assert _storage(emu) == Counter(
            {"storage:job_metric": every_metric, "storage:job_metrics_data": every_data}
        )
        by_id = {r.job_id: r for r in records}
        for job_id, output in outputs.items():
            assert output is not None
            view = by_id[job_id].job_metrics
            assert view is not None
            assert sorted(m.name for m in view.metrics) == sorted(m.name for m in output.metrics)
        emu.stats.reset()

        # Events: one listing per job. Tags: one listing per experience.
        records = await _collect(Needs(events=True, experience_tags=True), emu)
        assert _storage(emu) == Counter()
        assert emu.stats.endpoints["api:list_events"] == JOBS
        experiences = {j.experience.id for j in emu.dataset.jobs(emu.batch_id)}
        tag_paths = emu.stats.path_requests("/experienceTags")
        assert len(tag_paths) == len(experiences)
        assert set(tag_paths.values()) == {1}
        for record in records:
            job = emu.dataset.job(emu.batch_id, record.job_id)
            assert job is not None
            assert record.experience_tags == tuple(sorted(t.name for t in job.experience.tags))
            assert dict(record.parameters) == job.parameter_map
            output = outputs[record.job_id]
            assert output is not None
            assert [e.name for e in record.events] == [e.name for e in output.events]


async def test_a_frame_of_the_batch(tmp_path: Path) -> None:
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=12, seed=4) as emu:
        inputs = tmp_path / "inputs"
        frame = await asyncio.to_thread(fetch_batch_frame, inputs, series=["speeds"])
        jobs = sorted(emu.dataset.jobs(emu.batch_id), key=lambda j: str(j.id))
    assert frame.height == len(jobs)
    assert frame["job_id"].to_list() == [str(j.id) for j in jobs]  # sorted by job ID
    assert frame.schema["speeds"] == pl.List(pl.Float64)
    assert frame.schema["Max speed"] == pl.Float64
    for row, job in zip(frame.iter_rows(named=True), jobs, strict=True):
        truth = emu.dataset.truth(emu.batch_id, job.id)
        assert row["conflated_status"] == job.conflated_status
        assert row["Max speed"] == truth.scalars.get("Max speed")
        assert row["speeds"] == (list(truth.series["speeds"]) if "speeds" in truth.series else None)
        for key, value in job.parameter_map.items():
            assert row[f"parameters.{key}"] == value


async def test_leaving_early_stops_the_fetch_and_closes_the_client(tmp_path: Path) -> None:
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=60, seed=5) as emu:
        before = set(asyncio.all_tasks())
        stream = fetch_batch(tmp_path / "inputs", concurrency=2)
        async with contextlib.aclosing(stream) as jobs:
            async for _ in jobs:
                break
        assert set(asyncio.all_tasks()) == before  # nothing left running
        requests = emu.stats.requests["api"]
        await asyncio.sleep(0.2)
        assert emu.stats.requests["api"] == requests  # and nothing asks any more
        assert requests < 60

        # A plain break, without aclosing: the iterator is closed when collected.
        async for _ in fetch_batch(tmp_path / "inputs", concurrency=2):
            break
        for _ in range(20):
            await asyncio.sleep(0.01)
            if set(asyncio.all_tasks()) == before:
                break
        assert set(asyncio.all_tasks()) == before


async def test_errors_are_stooks_own_and_never_show_the_token(tmp_path: Path) -> None:
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=4, seed=6) as emu:
        stream = fetch_batch(
            api_url=emu.api_url,
            token="wrong-secret-token",
            project_id=emu.project_id,
            batch_id=emu.batch_id,
        )
        with pytest.raises(AuthError) as refused:
            await _drain(stream)
        assert "wrong-secret-token" not in str(refused.value)
        emu.stats.reset()
        # Settings and inputs are checked before any request.
        with pytest.raises(ConfigError, match="concurrency"):
            fetch_batch(tmp_path / "inputs", concurrency=0)
        with pytest.raises(InputsError, match="token"):
            fetch_batch(api_url=emu.api_url, project_id=emu.project_id, batch_id=emu.batch_id)
        with pytest.raises(InputsError, match="fetch_report"):
            fetch_batch(_report_inputs(emu, tmp_path))
        assert sum(emu.stats.requests.values()) == 0
        # The platform's config file itself is a source too.
        config_file = tmp_path / "inputs" / "batch_metrics_config.json"
        assert len([j async for j in fetch_batch(config_file)]) == 4


async def test_unavailable_jobs_raise_at_the_end_unless_allowed(tmp_path: Path) -> None:
    async with emulated_batch(
        tmp_path / "inputs", jobs_per_batch=8, seed=9, broken_jobs=(2, 5)
    ) as emu:
        seen: list[JobRecord] = []

        async def consume() -> None:
            async for job in fetch_batch(tmp_path / "inputs", retry_for=0.5):
                seen.append(job)

        with pytest.raises(MissingJobsError, match="2 of 8 jobs missing"):
            await consume()
        assert len(seen) == 6  # every other job was handed over first
        allowed = [
            j async for j in fetch_batch(tmp_path / "inputs", retry_for=0.5, allow_missing=2)
        ]
        assert len(allowed) == 6
        assert emu.stats.broken_job_answers > 0


async def test_the_deadline_bounds_the_whole_fetch(tmp_path: Path) -> None:
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=30, seed=10, latency_ms=200):
        stream = fetch_batch(tmp_path / "inputs", deadline=0.3, concurrency=2)
        with pytest.raises(DeadlineReachedError, match=r"deadline of 0\.3 s"):
            await _drain(stream)


async def test_a_source_and_access_keywords_do_not_mix(tmp_path: Path) -> None:
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=2, seed=11) as emu:
        with pytest.raises(InputsError, match="not both"):
            fetch_batch(tmp_path / "inputs", token=emu.token)
        with pytest.raises(InputsError, match="fetch_batch"):
            fetch_report(tmp_path / "inputs")
        with pytest.raises(InputsError, match="neither"):
            fetch_batch(tmp_path / "nowhere")


async def _drain(stream: AsyncIterator[object]) -> None:
    async for _ in stream:
        pass


def _report_inputs(emu: Emulator, tmp_path: Path) -> Path:
    inputs = tmp_path / "report-inputs"
    emu.write_report_config(inputs)
    return inputs


async def test_fetch_report_hands_over_every_batch(tmp_path: Path) -> None:
    async with emulated_batch(
        tmp_path / "inputs", jobs_per_batch=4, seed=7, report_batches=4, report_jobs_per_batch=5
    ) as emu:
        inputs = _report_inputs(emu, tmp_path)
        batches = [b async for b in fetch_report(inputs, needs=Needs(job_metrics=True))]
        expected = emu.dataset.report_batches(emu.report_id)
    assert len(expected) == 4
    assert sorted(b.batch_id for b in batches) == sorted(b.id for b in expected)
    assert any(b.jobs for b in batches)
    assert all(b.job_scalars for b in batches if b.jobs)


# -- the README's and the library page's examples, run as written against the emulator --

EXAMPLES = {
    "fetch_batch": block("docs/library.md", "# fetch_batch: "),
    "fetch_batch_frame": block("docs/library.md", "# fetch_batch_frame: "),
    "fetch_report": block("docs/library.md", "# fetch_report: "),
    "readme": block("README.md", "# readme: the mean of each job's speeds"),
}


@pytest.mark.slow
@pytest.mark.parametrize("example", sorted(EXAMPLES))
async def test_docs_example_runs(tmp_path: Path, example: str) -> None:
    # The README's top five must hold up where some jobs wrote no speeds (one in ten of
    # the emulator's jobs): 40 jobs, so that such jobs are there to sort past.
    jobs = 40 if example == "readme" else 6
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=jobs, seed=8) as emu:
        report_inputs = _report_inputs(emu, tmp_path)
        code = (
            EXAMPLES[example]
            .replace("/tmp/resim/report-inputs", str(report_inputs))
            .replace("/tmp/resim/inputs", str(tmp_path / "inputs"))
        )
        done = await asyncio.create_subprocess_exec(
            sys.executable,
            "-c",
            code,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        out, err = await asyncio.wait_for(done.communicate(), timeout=120)
        if example == "readme":
            frame = await asyncio.to_thread(
                fetch_batch_frame, tmp_path / "inputs", series=["speeds"]
            )
            assert frame["speeds"].null_count() > 0  # jobs without speeds, to sort past
    assert done.returncode == 0, err.decode()
    lines = out.decode().splitlines()
    assert lines, err.decode()
    # Without a structlog set-up of its own, the program's output is its own: no log lines.
    assert "http response" not in out.decode() + err.decode()
    if example == "fetch_batch":
        assert any(HISTOGRAM in line for line in lines)
    if example == "fetch_batch_frame":
        assert "parameters.max_speed" in out.decode()
    if example == "readme":
        # What a reader expects: the five fastest jobs, each with a mean speed.
        assert "mean speed" in out.decode()
        assert "shape: (5, 2)" in out.decode()
        assert "null" not in out.decode()
