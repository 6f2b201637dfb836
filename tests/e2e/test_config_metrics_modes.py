"""Config-defined metrics in batch and report mode, against the emulator: each job's
EMISSIONS_LOG downloaded, the config's `batch` (or `dashboard`) metrics written beside the
aggregations', every number equal to a plain-Python computation over the rows the
emulator emitted."""

from __future__ import annotations

import statistics
import uuid
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import EmittedRow, Emulator, write_emissions_config
from stook.sdk import (
    BarChartMetric,
    ImageMetric,
    JobMetricsView,
    MetricStatus,
    PlotlyMetric,
    TextMetric,
)
from stook.service.api import RetryPolicy
from stook.service.cli._run import RunOptions, run
from stook.service.modes import BatchInputs, detect, load, run_batch
from stook.testing import emulated_batch, emulated_report
from tests.e2e.support import by_name, read_output

# Jobs without an emissions log are among them (slot 6 errors before its metrics).
_JOBS = 24


def _toml(tmp_path: Path, extra: str = "") -> Path:
    """stook.toml naming the emulated project's config.resim.yml."""
    write_emissions_config(tmp_path / ".resim" / "metrics")
    toml = tmp_path / "stook.toml"
    toml.write_text(
        "[batch]\ndefaults = false\n\n[report]\ndefaults = false\n\n"
        '[metrics_config]\npaths = [".resim/metrics/config.resim.yml"]\n' + extra
    )
    return toml


def _rows(
    emu: Emulator, batch_ids: list[uuid.UUID], topic: str
) -> Iterator[tuple[str, EmittedRow]]:
    """Every row of `topic` the batches' jobs emitted, with the job's experience name."""
    for batch_id in batch_ids:
        for job, rows in emu.dataset.emitted_rows(batch_id):
            for row in rows or ():
                if row.topic == topic:
                    yield job.experience.name, row


def _worst_snapshot(emu: Emulator, batch_ids: list[uuid.UUID]) -> str:
    """The snapshot of the camera row with the largest error (ties: the smallest job ID)."""
    snapshots: list[tuple[float, str, str]] = [
        (-row.data["error"], str(job.id), row.data["snapshot"])
        for batch_id in batch_ids
        for job, rows in emu.dataset.emitted_rows(batch_id)
        for row in rows or ()
        if row.topic == "camera"
    ]
    return min(snapshots)[2]


def _bar_figure(view: JobMetricsView, name: str) -> dict[str, float]:
    """The bars of a custom template's Plotly figure, label -> height."""
    (trace,) = view.metric(name, PlotlyMetric).json["data"]
    assert trace["type"] == "bar"
    return dict(zip(trace["x"], trace["y"], strict=True))


def _image(view: JobMetricsView, name: str) -> str | None:
    image = view.metric(name, ImageMetric)
    assert image.image_data is not None
    return image.image_data.external_path


def _status(value: float, block: float, warn: float) -> MetricStatus:
    if value > block:
        return MetricStatus.FAIL_BLOCK
    return MetricStatus.FAIL_WARN if value > warn else MetricStatus.PASSED


def _bars(metric: BarChartMetric) -> dict[str, float]:
    out: dict[str, float] = {}
    for values in metric.values_data:
        out.update(values.labelled())
    return out


async def test_batch_metrics_equal_a_plain_python_computation(tmp_path: Path) -> None:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = _toml(tmp_path)
    async with emulated_batch(inputs, jobs_per_batch=_JOBS, seed=3) as emu:
        written = await run(RunOptions(inputs=inputs, outputs=outputs, config=toml))
        view = read_output(written)
        jobs = emu.dataset.jobs(emu.batch_id)
        batch = [emu.batch_id]
        errors = [r.data["error"] for _, r in _rows(emu, batch, "localization")]
        summaries = [r.data for _, r in _rows(emu, batch, "run_summary")]
        detections: Counter[str] = Counter()
        for _, row in _rows(emu, batch, "detections"):
            detections[row.data["object_class"]] += row.data["count"]
        without_log = [j for j in jobs if emu.dataset.job_emissions(emu.batch_id, j.id) is None]
        frames = Counter(name for name, _ in _rows(emu, batch, "localization"))
        brakes = Counter(
            name for name, r in _rows(emu, batch, "safety_events") if r.data["name"] == "Hard brake"
        )
        speeds: dict[str, list[float]] = {}
        for name, row in _rows(emu, batch, "vehicle"):
            speeds.setdefault(name, []).append(row.data["speed"])
        worst = _worst_snapshot(emu, batch)
        assert emu.stats.leaked_tokens == 0

    assert without_log  # a job without a log counts as having no rows
    metrics = by_name(view)
    mean = metrics["Mean localization error"]
    assert mean.value == pytest.approx(statistics.fmean(errors), rel=1e-12)
    assert mean.unit == "m"
    assert mean.status == _status(statistics.fmean(errors), 2.0, 0.8)
    assert metrics["Total distance driven"].value == pytest.approx(
        sum(s["distance"] for s in summaries), rel=1e-12
    )
    collided = sum(1 for s in summaries if s["collisions"] > 0)
    assert metrics["Jobs with collisions"].value == collided
    assert metrics["Jobs with collisions"].status == _status(collided, 10, 0)
    assert _bars(view.metric("Detections per class", BarChartMetric)) == {
        k: float(v) for k, v in detections.items()
    }
    table = view.metric("Localization error per experience", TextMetric).text
    for name, count in frames.items():
        assert f"| {name} | {count} |" in table
    hard = view.metric("Hard brakes per job", TextMetric).text
    for name, count in brakes.items():
        assert f"| {name} | {count} |" in hard
    # The custom Liquid template's Plotly figure: a bar per experience, in the query's order.
    bars = _bar_figure(view, "Mean speed per experience")
    assert list(bars) == sorted(speeds)
    assert bars == pytest.approx({n: statistics.fmean(s) for n, s in speeds.items()}, rel=1e-12)
    # The image: the attached file's basename (batch mode cannot download it).
    assert _image(view, "Worst localization frame") == worst
    assert "Teleports" not in metrics  # skip_if_no_data: hidden
    assert "Mean localization error by build" not in metrics  # a dashboard metric
    assert "Max localization error" not in metrics  # a test metric


async def test_a_metrics_set_picks_the_batch_metrics(tmp_path: Path) -> None:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = _toml(tmp_path, 'metrics_set = "nightly"\n')
    async with emulated_batch(inputs, jobs_per_batch=10, seed=4) as emu:
        view = read_output(await run(RunOptions(inputs=inputs, outputs=outputs, config=toml)))
        statuses = Counter(j.conflated_status for j in emu.dataset.jobs(emu.batch_id))
    names = set(by_name(view))
    assert {"Mean localization error", "Job outcomes", "Jobs with collisions"} <= names
    assert "Total distance driven" not in names
    assert sum(statuses.values()) == 10


async def test_report_mode_writes_the_dashboard_metrics_per_build(tmp_path: Path) -> None:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = _toml(tmp_path)
    async with emulated_report(
        inputs, report_batches=3, report_jobs_per_batch=9, decoy_batches=1, seed=5
    ) as emu:
        view = read_output(await run(RunOptions(inputs=inputs, outputs=outputs, config=toml)))
        batches = emu.dataset.report_batches()
        by_build: dict[str, list[float]] = {}
        collisions: Counter[str] = Counter()
        speeds: dict[str, list[float]] = {}
        for batch in batches:
            version = emu.dataset.builds[batch.build_id].version
            for _, row in _rows(emu, [batch.id], "localization"):
                by_build.setdefault(version, []).append(row.data["error"])
            for _, row in _rows(emu, [batch.id], "run_summary"):
                collisions[version] += row.data["collisions"]
            for _, row in _rows(emu, [batch.id], "vehicle"):
                speeds.setdefault(version, []).append(row.data["speed"])
        worst = _worst_snapshot(emu, [batch.id for batch in batches])

    assert len(by_build) == 3  # the decoy's jobs are not the report's
    bars = _bars(view.metric("Mean localization error by build", BarChartMetric))
    assert bars == pytest.approx({v: statistics.fmean(e) for v, e in by_build.items()}, rel=1e-12)
    table = view.metric("Collisions by build", TextMetric).text
    for version, count in collisions.items():
        assert f"| {version} | {count} |" in table
    figure = _bar_figure(view, "Mean speed by build")
    assert list(figure) == sorted(speeds)
    assert figure == pytest.approx({v: statistics.fmean(s) for v, s in speeds.items()}, rel=1e-12)
    assert _image(view, "Worst localization frame of the builds") == worst
    assert "Mean localization error" not in by_name(view)  # a batch metric


async def test_the_same_inputs_give_the_same_bytes(tmp_path: Path) -> None:
    outputs: list[bytes] = []
    for concurrency in (1, 16):
        run_dir = tmp_path / f"c{concurrency}"
        run_dir.mkdir()
        toml = _toml(run_dir, f"\n[fetch]\nconcurrency = {concurrency}\n")
        async with emulated_batch(run_dir / "inputs", jobs_per_batch=16, seed=6):
            written = await run(
                RunOptions(inputs=run_dir / "inputs", outputs=run_dir / "out", config=toml)
            )
        outputs.append(written.read_bytes())
    assert outputs[0] == outputs[1]


async def test_failing_storage_downloads_are_retried(tmp_path: Path) -> None:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = _toml(tmp_path)
    # Every storage request (metrics data and emissions logs) fails once, then succeeds;
    # the retries do not wait.
    policy = RetryPolicy(initial_backoff=0, request_timeout=5.0, max_attempts=4)
    async with emulated_batch(
        inputs,
        jobs_per_batch=8,
        seed=7,
        fault_5xx=1.0,
        fault_origins=("storage",),
        max_consecutive_faults=1,
    ) as emu:
        batch = detect(inputs)
        assert isinstance(batch, BatchInputs)
        result = await run_batch(batch, load(toml), outputs, retry=policy)
        view = read_output(result.output)
        errors = [r.data["error"] for _, r in _rows(emu, [emu.batch_id], "localization")]
        with_log = sum(1 for _, rows in emu.dataset.emitted_rows(emu.batch_id) if rows)
        assert emu.stats.faults["storage:5xx"] >= with_log
        assert emu.stats.leaked_tokens == 0
    assert by_name(view)["Mean localization error"].value == pytest.approx(
        statistics.fmean(errors), rel=1e-12
    )


async def test_the_emissions_logs_are_part_of_the_batch_fetch(tmp_path: Path) -> None:
    # Listed with each job's other listings, on the run's client: each job listed once,
    # every request counted in the run's traffic.
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = _toml(tmp_path)
    async with emulated_batch(inputs, jobs_per_batch=_JOBS, seed=3) as emu:
        batch = detect(inputs)
        assert isinstance(batch, BatchInputs)
        # Without [metrics_config] first: the pages of the batch's listing.
        plain = tmp_path / "plain.toml"
        plain.write_text(toml.read_text().split("[metrics_config]")[0])
        await run_batch(batch, load(plain), outputs)
        pages = emu.stats.endpoints["api:list_jobs"]
        before = emu.stats.requests["api"] + emu.stats.requests["storage"]
        result = await run_batch(batch, load(toml), outputs)
        endpoints = emu.stats.endpoints
        served = emu.stats.requests["api"] + emu.stats.requests["storage"] - before
    assert endpoints["api:list_jobs"] == 2 * pages
    assert endpoints["api:get_batch"] == 1  # for the metadata rows
    assert endpoints["api:list_job_logs"] == _JOBS
    assert result.requests == served


@pytest.mark.slow
async def test_a_sharded_batch_gives_the_local_runs_bytes(tmp_path: Path) -> None:
    from stook.service.modes import EngineSettings

    written: list[bytes] = []
    for engine in (EngineSettings(), EngineSettings("processes", workers=2, shards=3)):
        run_dir = tmp_path / engine.kind
        run_dir.mkdir()
        toml = _toml(run_dir)
        async with emulated_batch(run_dir / "inputs", jobs_per_batch=_JOBS, seed=3) as emu:
            batch = detect(run_dir / "inputs")
            assert isinstance(batch, BatchInputs)
            result = await run_batch(batch, load(toml), run_dir / "out", engine=engine)
            assert emu.stats.endpoints["api:list_jobs"] == 3  # the listing's pages, once
            assert emu.stats.endpoints["api:list_job_logs"] == _JOBS
        written.append(result.output.read_bytes())
    assert written[0] == written[1]


async def test_a_level_without_metrics_downloads_no_log(tmp_path: Path) -> None:
    # "trends" holds dashboard metrics only, "nightly" batch metrics only.
    batch_toml = _toml(tmp_path / "batch", 'metrics_set = "trends"\n')
    async with emulated_batch(tmp_path / "batch" / "inputs", jobs_per_batch=8, seed=3) as emu:
        await run(
            RunOptions(
                inputs=tmp_path / "batch" / "inputs",
                outputs=tmp_path / "batch" / "out",
                config=batch_toml,
            )
        )
        assert emu.stats.endpoints["api:list_job_logs"] == 0
    report_toml = _toml(tmp_path / "report", 'metrics_set = "nightly"\n')
    async with emulated_report(
        tmp_path / "report" / "inputs", report_batches=2, report_jobs_per_batch=4, seed=5
    ) as emu:
        await run(
            RunOptions(
                inputs=tmp_path / "report" / "inputs",
                outputs=tmp_path / "report" / "out",
                config=report_toml,
            )
        )
        assert emu.stats.endpoints["api:list_job_logs"] == 0
