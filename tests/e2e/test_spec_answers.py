"""Every answer the API spec allows, end to end: fields left out, values listed as null,
enum values the spec does not list yet, unnamed metrics data, nanosecond timestamps.

The emulator's `spec_quirks` serves all of them at once without changing what a correct
client computes, so outputs must be byte-identical to a clean run's. Statuses the spec
does not list, or that are left out, do change the counts: those are checked against
expectations computed here from the emulator's ground truth.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pytest

from stook.emulator import Emulator
from stook.emulator._quirks import FUTURE_CONFLATED_STATUS, FUTURE_METRIC_STATUS, LEAP_SECOND
from stook.sdk import MetricStatus
from stook.service.api._client import ApiClient
from stook.service.cli import run_cli
from stook.service.cli._run import RunOptions, run
from stook.testing import emulated_batch, emulated_report
from tests.e2e.support import (
    BATCH_TOML,
    OUTPUT_NAME,
    bar_chart,
    by_name,
    outputs_left,
    read_output,
)


@dataclass(frozen=True)
class BatchRun:
    output: bytes
    downloads: int  # of Metric messages (scalar values)
    nulls: int  # SCALAR job metrics listed without a value


async def _run_batch(tmp: Path, toml: str, **emulator: Any) -> BatchRun:
    config = tmp / "stook.toml"
    config.parent.mkdir(parents=True, exist_ok=True)
    config.write_text(toml)
    async with emulated_batch(tmp / "inputs", jobs_per_batch=40, seed=11, **emulator) as emu:
        written = await run(RunOptions(inputs=tmp / "inputs", outputs=tmp / "out", config=config))
        downloads = emu.stats.endpoints["storage:job_metric"]
        return BatchRun(written.read_bytes(), downloads, await _null_scalars_listed(emu))


async def _null_scalars_listed(emu: Emulator) -> int:
    """How many job metrics the emulator lists as SCALAR without a value, as a client sees;
    and with quirks, the job created in a leap second read as the instant before it."""
    count = 0
    leap_seconds = 0
    async with ApiClient(emu.api_url, emu.token) as api:
        async for job in api.list_jobs(emu.project_id, emu.batch_id):
            leap_seconds += job.creation_timestamp == datetime(
                2016, 12, 31, 23, 59, 59, 999_999, tzinfo=UTC
            )
            for m in await api.list_job_metrics(emu.project_id, emu.batch_id, job.job_id):
                count += m.type == "SCALAR" and m.value is None and not m.event_metric
    assert leap_seconds == (1 if emu.config.spec_quirks else 0), LEAP_SECOND
    return count


async def test_batch_output_is_byte_identical_with_every_spec_quirk(tmp_path: Path) -> None:
    clean = await _run_batch(tmp_path / "clean", BATCH_TOML)
    quirky = await _run_batch(tmp_path / "quirks", BATCH_TOML, spec_quirks=True)
    assert quirky.output == clean.output
    assert outputs_left(tmp_path / "quirks" / "out") == [OUTPUT_NAME]
    # The values listed as null were read from their Metric messages, one download each
    # (the defaults read every scalar); values listed as numbers cost nothing.
    assert (clean.nulls, clean.downloads) == (0, 0)
    assert quirky.nulls > 20
    assert quirky.downloads == quirky.nulls


async def test_null_scalars_nobody_reads_are_not_downloaded(tmp_path: Path) -> None:
    toml = BATCH_TOML.split("[[batch.weighted_mean]]")[0] + (
        "[batch]\ndefaults = false\n\n"
        '[[batch.scalar_stats]]\nmetric = "Max speed"\nstats = ["mean"]\n'
        # The batch summary reads every scalar for later reports; without it, none is.
        "\n[output]\nsummary = false\n"
    )
    clean = await _run_batch(tmp_path / "clean", toml)
    quirky = await _run_batch(tmp_path / "quirks", toml, spec_quirks=True)
    assert quirky.output == clean.output
    # Only "Max speed" is read: at most one download per job, and some were needed.
    assert 0 < quirky.downloads <= 40
    assert quirky.downloads < quirky.nulls


async def test_report_output_is_byte_identical_with_every_spec_quirk(tmp_path: Path) -> None:
    outputs = []
    for quirks in (False, True):
        inputs, out = tmp_path / f"{quirks}" / "inputs", tmp_path / f"{quirks}" / "out"
        async with emulated_report(
            inputs, seed=17, report_batches=6, report_jobs_per_batch=15, spec_quirks=quirks
        ) as emu:
            written = await run(RunOptions(inputs=inputs, outputs=out, config=None))
            outputs.append(written.read_bytes())
            # Batch and job scalars listed as null were read from their messages.
            metric_downloads = emu.stats.endpoints["storage:batch_metric"]
            job_metric_downloads = emu.stats.endpoints["storage:job_metric"]
        assert (metric_downloads > 0, job_metric_downloads > 0) == (quirks, quirks)
    assert outputs[0] == outputs[1]


async def test_statuses_the_spec_does_not_list_are_counted_by_name(tmp_path: Path) -> None:
    """A conflated status or metric status the platform adds later, or none at all, is a
    category of its own; it is not a pass, and it makes nothing fail."""
    future, unreported = (0, 1, 2), (3, 4, 5)
    inputs, outputs = tmp_path / "inputs", tmp_path / "out"
    async with emulated_batch(
        inputs,
        jobs_per_batch=30,
        seed=11,
        future_status_jobs=future,
        unreported_status_jobs=unreported,
    ) as emu:
        written = await run(RunOptions(inputs=inputs, outputs=outputs, config=None))
        jobs = emu.dataset.jobs(emu.batch_id)
        truth = {j.index: emu.dataset.truth(emu.batch_id, j.id) for j in jobs}
    view = read_output(written)
    metrics = by_name(view)

    conflated = Counter[str]()
    metric_statuses = Counter[str]()
    for job in jobs:
        names = truth[job.index].statuses  # metric name -> status, as the job wrote it
        if job.index in future:
            conflated[FUTURE_CONFLATED_STATUS] += 1
            metric_statuses[FUTURE_METRIC_STATUS] += len(names)
        elif job.index in unreported:
            conflated["UNKNOWN"] += 1
            metric_statuses["NO_STATUS_REPORTED"] += len(names)
        else:
            conflated[job.conflated_status] += 1
            metric_statuses.update(names.values())
    assert metric_statuses[FUTURE_METRIC_STATUS] > 0
    assert metric_statuses["NO_STATUS_REPORTED"] > 0

    job_chart = bar_chart(view, metrics["Job statuses"])
    assert {k: v for k, v in job_chart.items() if v} == {k: float(n) for k, n in conflated.items()}
    # Known statuses first, in the app's order; the others after them, by name.
    assert list(job_chart)[-2:] == [FUTURE_CONFLATED_STATUS, "UNKNOWN"]
    metric_chart = bar_chart(view, metrics["Job metric statuses"])
    assert {k: v for k, v in metric_chart.items() if v} == {
        k: float(n) for k, n in metric_statuses.items()
    }
    assert metrics["Pass rate"].value == pytest.approx(100.0 * conflated["PASSED"] / len(jobs))
    # Unknown statuses are not failures: the charts' statuses follow the known ones alone.
    if conflated["BLOCKER"]:
        assert metrics["Job statuses"].status is MetricStatus.FAIL_BLOCK
    elif conflated["WARNING"] or conflated["ERROR"]:
        assert metrics["Job statuses"].status is MetricStatus.FAIL_WARN
    else:
        assert metrics["Job statuses"].status is MetricStatus.PASSED
    if metric_statuses["FAIL_BLOCK"]:
        assert metrics["Job metric statuses"].status is MetricStatus.FAIL_BLOCK
    elif metric_statuses["FAIL_WARN"]:
        assert metrics["Job metric statuses"].status is MetricStatus.FAIL_WARN
    else:
        assert metrics["Job metric statuses"].status is MetricStatus.PASSED


def test_a_page_size_above_the_spec_maximum_is_refused_before_fetching(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    toml = tmp_path / "stook.toml"
    toml.write_text("[fetch]\npage_size = 101\n")
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    # An API URL nothing listens on: any request would fail with exit code 3, not 2.
    (inputs / "batch_metrics_config.json").write_text(
        '{"authToken": "t", "apiURL": "http://127.0.0.1:9/v1", '
        '"batchID": "7579affb-3e5b-4f02-871b-bf275aef67ee", '
        '"projectID": "2f4b8a0e-1c9d-4e7f-8a6b-5c3d2e1f0a9b"}'
    )
    argv = ["run", "--inputs", str(inputs), "--outputs", str(tmp_path / "out")]
    code = run_cli([*argv, "--config", str(toml), "--log-format", "console"])
    _, err = capsys.readouterr()
    assert code == 2, err
    errors = [line for line in err.splitlines() if line.startswith("stook: error:")]
    assert errors == [
        f"stook: error: {toml}: [fetch] page_size must be at most 100 (the API's limit), got 101"
    ]
    assert outputs_left(tmp_path / "out") == []
