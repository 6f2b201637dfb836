"""How a run that wrote its output ends: one line for a person in console logs, saying
what was written and that the status is the metrics' verdict, not the run's; the run's
summary event in JSON logs (the platform's log view). And the console log lines before
it, as short as their values allow."""

from __future__ import annotations

import dataclasses
import json
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import Emulator
from stook.sdk import MetricStatus
from stook.service.cli import run_cli
from stook.service.cli._run import Written
from stook.service.modes import RunResult, Traffic
from tests.e2e.support import EmulatorThread, config, write_batch_inputs

JOBS = 12

# No ./stook.toml and no STOOK_* settings from the environment (tests/e2e/conftest.py).
pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=JOBS, seed=73)) as emulator:
        yield emulator


def _run(tmp_path: Path, emu: Emulator, *flags: str) -> int:
    write_batch_inputs(tmp_path / "inputs", emu)
    argv = ["run", "--inputs", str(tmp_path / "inputs"), "--outputs", str(tmp_path / "out")]
    return run_cli([*argv, *flags])


def test_in_console_logs_a_run_ends_with_one_line_for_a_person(
    tmp_path: Path, emu: Emulator, capsys: pytest.CaptureFixture[str]
) -> None:
    code = _run(tmp_path, emu, "--log-format", "console")
    lines = capsys.readouterr().err.splitlines()
    assert code == 0, lines
    output = tmp_path / "out" / "metrics.binproto"
    last = re.fullmatch(
        rf"wrote {re.escape(str(output))}: (\d+) metrics from {JOBS} jobs in [\d.]+ s, "
        r"metrics status (\w+)( \(the run itself succeeded\))?",
        lines[-1],
    )
    assert last, lines[-1]
    count, status, note = last.groups()
    assert int(count) >= 10
    assert status != "PASSED"  # the emulator's batch has failing jobs
    assert note
    assert not [line for line in lines if "metrics written" in line or "status=" in line]
    # The log lines above it: the time of day, the level and the event unpadded, so that
    # a line is as short as its values allow.
    assert re.fullmatch(r"\d\d:\d\d:\d\d \[info\] batch mode batch_id=\S+ config=.+", lines[0])


def test_in_json_logs_a_run_ends_with_its_summary_event(
    tmp_path: Path, emu: Emulator, capsys: pytest.CaptureFixture[str]
) -> None:
    code = _run(tmp_path, emu, "--log-format", "json")
    events = [json.loads(line) for line in capsys.readouterr().err.splitlines()]
    assert code == 0, events
    summary = events[-1]
    assert summary["event"] == "batch metrics written"
    assert summary["output"] == str(tmp_path / "out" / "metrics.binproto")
    assert summary["status"] in {s.name for s in MetricStatus}
    assert (summary["jobs"], summary["jobs_missing"]) == (JOBS, 0)
    assert summary["metrics"] >= 10
    assert summary["requests"] > JOBS
    assert not [e for e in events if e["event"].startswith("wrote")]


def test_the_line_names_the_preview_and_goes_under_a_quieter_log_level(
    tmp_path: Path, emu: Emulator, capsys: pytest.CaptureFixture[str]
) -> None:
    code = _run(tmp_path, emu, "--log-format", "console", "--preview")
    lines = capsys.readouterr().err.splitlines()
    assert code == 0, lines
    out = tmp_path / "out"
    assert lines[-1].startswith(f"wrote {out / 'metrics.binproto'} and {out / 'metrics.html'}: ")
    assert not [line for line in lines if "preview written" in line]
    code = _run(tmp_path, emu, "--log-format", "console", "--log-level", "warning")
    assert code == 0
    assert "wrote " not in capsys.readouterr().err


def _result(**counts: int) -> RunResult[None]:
    return RunResult(
        kind="report" if "batches" in counts else "batch" if counts else "test",
        output=Path("/tmp/resim/outputs/metrics.binproto"),
        outcome=None,
        metrics_written=[f"metric {i}" for i in range(18)],
        status=MetricStatus.FAIL_BLOCK,
        traffic=Traffic(requests=40, retries=1, bytes_received=20_000),
        counts=counts,
        seconds=12.345,
    )


def test_the_line_of_each_mode() -> None:
    assert Written(_result(jobs=1_204, jobs_missing=0)).line() == (
        "wrote /tmp/resim/outputs/metrics.binproto: 18 metrics from 1,204 jobs in 12.3 s, "
        "metrics status FAIL_BLOCK (the run itself succeeded)"
    )
    assert Written(_result(jobs=560, jobs_missing=3, batches=14, batches_summarised=2)).line() == (
        "wrote /tmp/resim/outputs/metrics.binproto: 18 metrics from 560 jobs of 14 batches "
        "(3 missing) in 12.3 s, metrics status FAIL_BLOCK (the run itself succeeded)"
    )
    passed = dataclasses.replace(_result(), status=MetricStatus.PASSED)
    assert Written(passed).line() == (
        "wrote /tmp/resim/outputs/metrics.binproto: 18 metrics, metrics status PASSED"
    )
