"""A batch without jobs: nothing to aggregate, which is not a failure."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from stook.sdk import MetricStatus, MetricType
from stook.service.cli import run_cli
from tests.e2e.support import (
    BATCH_TOML,
    OUTPUT_NAME,
    EmulatorThread,
    by_name,
    config,
    outputs_left,
    read_output,
    text_of,
)
from tests.failures import failure_lines


@pytest.mark.parametrize("toml", [None, BATCH_TOML], ids=["defaults", "configured"])
def test_a_batch_without_jobs(
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    toml: str | None,
) -> None:
    monkeypatch.chdir(tmp_path)
    for name in list(os.environ):
        if name.startswith("STOOK_"):
            monkeypatch.delenv(name)
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--log-format", "json"]
    if toml is not None:
        # Names that no job has cannot be checked against an empty batch: not an error.
        (tmp_path / "stook.toml").write_text(toml)
        argv += ["--config", str(tmp_path / "stook.toml")]
    with EmulatorThread(config(jobs_per_batch=0)) as emu:
        assert emu.dataset.jobs(emu.batch_id) == ()
        emu.write_batch_config(inputs)
        code = run_cli(argv)
        listed = emu.stats.endpoints["api:list_jobs"]
    err = capsys.readouterr().err
    assert code == 0, err
    assert failure_lines(err) == []
    assert listed == 1
    assert outputs_left(outputs) == [OUTPUT_NAME]
    view = read_output(outputs / OUTPUT_NAME)
    assert view.job_id == emu.batch_id
    assert view.status is MetricStatus.NOT_APPLICABLE
    metrics = by_name(view)
    summary = metrics["Batch summary"]
    assert summary.type is MetricType.TEXT
    assert "no jobs" in text_of(summary)
    assert summary.status is MetricStatus.NOT_APPLICABLE
    # No per-job numbers are made up for an empty batch.
    assert "Pass rate" not in metrics
    assert not any(name.endswith("(mean)") for name in metrics)
