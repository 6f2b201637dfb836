"""Fatal errors and signals end `stook run` promptly, mid-fetch included.

Each case runs the installed `stook` command in its own process against a batch big
enough that the job queue is full when the failure comes: 2,000 jobs at 30 ms, listed 100
a page, while each of the 64 workers needs several requests per job, so the lister runs
ahead of them by more than the queue's 128 places. That is the state in which a fatal
error used to hang the run for ever.
"""

from __future__ import annotations

import json
import re
import signal
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from stook.emulator import Emulator, EmulatorConfig
from stook.service.cli import run_cli
from tests.e2e.processes import StookProcess, catches
from tests.e2e.support import BATCH_TOML, OUTPUT_NAME, EmulatorThread, config, outputs_left
from tests.failures import failure_lines, traceback_text

pytestmark = pytest.mark.slow

JOBS = 2000
BIG: dict[str, Any] = {"jobs_per_batch": JOBS, "latency_ms": 30.0, "seed": 61}
CORRUPT = 300  # a job well past the first 2 x 64 + 64 that fill the queue and the workers
HUNG_S = 30.0  # a run still going after this long has hung (a whole clean run takes ~4 s)
FEW_WORKERS = "[fetch]\nconcurrency = 4\n"
SIGNAL_BOUND_S = 2.0  # what docs/cli.md promises from a signal to the exit
TEMP_FILE = re.compile(r"\.metrics\.binproto\.\w{8}\.tmp")

# Test-only, put on the stook process's PYTHONPATH as sitecustomize (which Python imports
# at start-up): the product's code is unchanged, but the window between the creation of
# the output's temporary file and its rename grows from microseconds to a minute, so that
# a signal sent once the temporary file exists certainly lands during the write.
PAUSE_BEFORE_RENAME = """\
import re, sys, time

def _pause_before_rename(event, args):
    if event == "os.rename" and re.search(r"\\.metrics\\.binproto\\.\\w{8}\\.tmp$", str(args[0])):
        time.sleep(60)

sys.addaudithook(_pause_before_rename)
"""


@pytest.fixture(scope="module")
def big() -> Iterator[Emulator]:
    with EmulatorThread(EmulatorConfig(**BIG, corrupt_data_jobs=(CORRUPT,))) as emulator:
        yield emulator


def assert_one_line(run: StookProcess, *named: str) -> str:
    lines = failure_lines(run.err)
    assert len(lines) == 1, run.err
    for thing in named:
        assert thing in lines[0], f"{thing!r} not named in {lines[0]!r}"
    assert outputs_left(run.outputs) == []
    return lines[0]


# ---- fatal errors mid-fetch ----


def test_a_corrupt_blob_mid_fetch_ends_the_run_with_exit_4(big: Emulator, tmp_path: Path) -> None:
    big.write_batch_config(tmp_path / "inputs")
    run = StookProcess(tmp_path, toml=BATCH_TOML)
    assert run.finish(HUNG_S) == 4, run.err
    job = big.dataset.jobs(big.batch_id)[CORRUPT]
    assert_one_line(run, f"job {job.id}", "'speeds'", "not a valid protobuf message")
    assert "Traceback" not in run.err


def test_a_token_revoked_mid_fetch_ends_the_run_with_exit_3(tmp_path: Path) -> None:
    with EmulatorThread(EmulatorConfig(**BIG, revoke_token_after_requests=150)) as emu:
        emu.write_batch_config(tmp_path / "inputs")
        # With 4 workers, a queue of 8 and 100 jobs a page, the lister waits on the full
        # queue nearly all the time, so the first 401 goes to a worker, not the lister.
        run = StookProcess(tmp_path, toml=FEW_WORKERS)
        code = run.finish(HUNG_S)
        refused = emu.stats.unauthorized
    assert code == 3, run.err
    assert_one_line(run, "refused the token", "401")
    assert "Traceback" not in run.err
    assert refused >= 1


def test_a_users_aggregation_raising_mid_fetch_ends_the_run_with_exit_1(
    big: Emulator, tmp_path: Path
) -> None:
    big.write_batch_config(tmp_path / "inputs")
    toml = '[[batch.custom]]\nclass = "tests.e2e.user_metrics:FailsAfterJobs"\nafter = 300\n'
    run = StookProcess(tmp_path, toml=toml)
    assert run.finish(HUNG_S) == 1, run.err
    assert_one_line(run, "aggregation bug on job")
    # An unexpected error keeps its traceback, inside the one JSON event.
    assert "in update" in traceback_text(run.err)


def test_a_token_revoked_mid_report_ends_the_run_with_exit_3(tmp_path: Path) -> None:
    # 12 batches of 200 jobs, four batches listed at a time into the same bounded queue.
    report: dict[str, Any] = {
        "report_batches": 12,
        "report_jobs_per_batch": 200,
        "latency_ms": 10.0,
    }
    with EmulatorThread(EmulatorConfig(**report, revoke_token_after_requests=400)) as emu:
        emu.write_report_config(tmp_path / "inputs")
        run = StookProcess(tmp_path, toml=FEW_WORKERS)
        code = run.finish(HUNG_S)
    assert code == 3, run.err
    assert_one_line(run, "refused the token", "401")


# ---- signals ----


def wait_for_api_requests(emulator: Emulator, count: int, timeout: float = 60.0) -> None:
    """Until the emulator has answered `count` API requests in all."""
    deadline = time.monotonic() + timeout
    while emulator.stats.requests["api"] < count:
        assert time.monotonic() < deadline, f"{count} API requests not answered in {timeout} s"
        time.sleep(0.01)


def send(run: StookProcess, signum: int) -> tuple[int, float]:
    """Send `signum`; the exit status and the seconds from the signal to the exit."""
    sent = time.monotonic()
    run.proc.send_signal(signum)
    code = run.finish(HUNG_S)
    return code, time.monotonic() - sent


@pytest.mark.parametrize(
    ("signum", "log_format"), [(signal.SIGINT, "console"), (signal.SIGTERM, "json")]
)
def test_a_signal_during_the_start_up_imports(
    big: Emulator, tmp_path: Path, signum: int, log_format: str
) -> None:
    big.write_batch_config(tmp_path / "inputs")
    run = StookProcess(tmp_path, "--log-format", log_format)
    # The entry point takes both signals before its heavy imports, which take a third of
    # a second or more; sent at once, the signal lands in the middle of them.
    run.wait_until(lambda: catches(run.proc.pid, signal.SIGTERM), "stook took SIGTERM")
    code, seconds = send(run, signum)
    assert code == 128 + signum, run.err
    name = signal.Signals(signum).name
    assert failure_lines(run.err) == [f"stook: interrupted by {name}"], run.err
    assert "batch mode" not in run.err  # it never got as far as reading the inputs
    assert "Traceback" not in run.err
    assert outputs_left(run.outputs) == []
    assert seconds < SIGNAL_BOUND_S


@pytest.mark.parametrize(
    ("signum", "log_format"), [(signal.SIGINT, "json"), (signal.SIGTERM, "console")]
)
def test_a_signal_mid_fetch(big: Emulator, tmp_path: Path, signum: int, log_format: str) -> None:
    big.write_batch_config(tmp_path / "inputs")
    run = StookProcess(tmp_path, "--log-format", log_format)
    answered = big.stats.requests["api"]  # the emulator serves every case here
    run.wait_for_line("batch fetch starting")
    # Some jobs in, not all (the whole batch takes seconds). Counted, not slept: on a slow
    # first run the first jobs can take longer than any fixed pause.
    wait_for_api_requests(big, answered + 200)
    time.sleep(0.1)  # the jobs listed are folded by now
    code, seconds = send(run, signum)
    assert code == 128 + signum, run.err
    name = signal.Signals(signum).name
    line = assert_one_line(run, f"stook: interrupted by {name} after ")
    found = re.fullmatch(rf"stook: interrupted by {name} after ([\d,]+) of ([\d,]+) jobs", line)
    assert found is not None, line
    done, listed = (int(n.replace(",", "")) for n in found.groups())
    assert 0 < done < listed <= JOBS
    assert "Traceback" not in run.err
    assert seconds < SIGNAL_BOUND_S


@pytest.mark.parametrize(
    ("signum", "log_format"), [(signal.SIGTERM, "json"), (signal.SIGINT, "console")]
)
def test_a_signal_during_the_write_leaves_no_file(
    big: Emulator, tmp_path: Path, signum: int, log_format: str
) -> None:
    big.write_batch_config(tmp_path / "inputs")
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(PAUSE_BEFORE_RENAME)
    run = StookProcess(tmp_path, "--log-format", log_format, python_path=[hook])

    def writing() -> bool:
        outputs = run.outputs
        return outputs.is_dir() and any(TEMP_FILE.fullmatch(p.name) for p in outputs.iterdir())

    run.wait_until(writing, "the output's temporary file exists")
    code, seconds = send(run, signum)
    assert code == 128 + signum, run.err
    name = signal.Signals(signum).name
    assert_one_line(run, f"stook: interrupted by {name} after {JOBS:,} of {JOBS:,} jobs")
    assert "Traceback" not in run.err
    assert seconds < SIGNAL_BOUND_S


def test_a_signal_ends_the_run_even_when_user_code_swallows_it(
    tmp_path: Path,
) -> None:
    marker = tmp_path / "finishing"
    toml = (
        '[[batch.custom]]\nclass = "tests.e2e.user_metrics:StuckFinish"\n'
        f"marker = {json.dumps(str(marker))}\n"
    )
    with EmulatorThread(config(jobs_per_batch=10, seed=73)) as emu:
        emu.write_batch_config(tmp_path / "inputs")
        run = StookProcess(tmp_path, "--log-format", "console", toml=toml)
        run.wait_until(marker.exists, "the stuck aggregation is finishing")
        code, seconds = send(run, signal.SIGTERM)
    # Unwinding never gets past the user's loop; the watchdog ends the process.
    assert code == 143, run.err
    assert_one_line(run, "stook: interrupted by SIGTERM after 10 of 10 jobs")
    assert seconds < SIGNAL_BOUND_S


# ---- what an earlier, killed run left ----


def test_a_run_removes_the_temporary_files_a_killed_run_left(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    outputs = tmp_path / "outputs"
    outputs.mkdir()
    stale = [".metrics.binproto.k3x9_q2a.tmp", ".metrics.binproto.abcdefgh.tmp"]
    kept = [".metrics.binproto.notes.tmp", "metrics.binproto.abcdefgh.tmp", "keep.tmp"]
    for name in stale + kept:
        (outputs / name).write_bytes(b"")
    with EmulatorThread(config(jobs_per_batch=5, seed=67)) as emu:
        emu.write_batch_config(tmp_path / "inputs")
        argv = ["run", "--inputs", str(tmp_path / "inputs"), "--outputs", str(outputs)]
        code = run_cli([*argv, "--log-format", "json"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert outputs_left(outputs) == sorted([*kept, OUTPUT_NAME])
    assert "removed stale temporary files" in err
