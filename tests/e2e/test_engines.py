"""`[engine] kind = "processes"` end to end: the same bytes as a local run, its settings
checked before the first request, and a failed shard ending the run with its own error.

Real worker processes (spawned) against the emulator, a real HTTP server. Ray has its own
module (test_engines_ray.py), which starts one local Ray instance.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import os
import pickle
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from stook.emulator import Emulator
from stook.sdk import read_job_metrics
from stook.sdk.aggregations import default_batch_aggregations
from stook.service.api import AuthError, Job
from stook.service.fetch import FetchOutcome
from stook.service.modes import ApiAccess, FetchSettings, open_api
from stook.service.modes._pipeline import needs_of
from stook.service.modes._shards import BatchShard, ShardDone, ShardFailed, run_shard
from tests.e2e.engines import (
    ENGINE_BATCH_TOML,
    assert_progress_moved_inside_the_shards,
    run_engine,
    run_with_live_progress,
)
from tests.e2e.processes import StookProcess
from tests.e2e.support import (
    OUTPUT_NAME,
    EmulatorThread,
    by_name,
    config,
    text_of,
    write_batch_inputs,
)
from tests.failures import failure_lines

pytestmark = pytest.mark.slow

PROCESSES = '[engine]\nkind = "processes"\nworkers = 2\nshards = 3\n'
JOBS = 23  # shards of 8, 8 and 7 jobs


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    emulator_config = config(
        jobs_per_batch=JOBS,
        seed=11,
        report_batches=7,
        report_jobs_per_batch=6,
        batch_summaries="exact",
        report_batches_without_summary=(1, 4),
    )
    with EmulatorThread(emulator_config) as emulator:
        yield emulator


def api_requests(emu: Emulator) -> int:
    return emu.stats.requests["api"]


def test_processes_write_the_bytes_of_a_local_run(emu: Emulator, tmp_path: Path) -> None:
    local = run_engine(emu, tmp_path / "local")
    sharded = run_engine(emu, tmp_path / "processes", toml=ENGINE_BATCH_TOML + PROCESSES)
    assert sharded.output == local.output


def test_a_report_on_processes_writes_the_bytes_of_a_local_run(
    emu: Emulator, tmp_path: Path
) -> None:
    # Batches with and without summaries, split into shards of 3, 2 and 2 batches.
    local = run_engine(emu, tmp_path / "local", toml="", report=True)
    sharded = run_engine(emu, tmp_path / "processes", toml=PROCESSES, report=True)
    assert sharded.output == local.output


def test_the_engine_flag_replaces_the_configured_kind(emu: Emulator, tmp_path: Path) -> None:
    toml = ENGINE_BATCH_TOML + '[engine]\nkind = "local"\nworkers = 2\n'
    run = run_engine(emu, tmp_path, "--engine", "processes", "--log-level", "info", toml=toml)
    shards = [e for e in _events(run.err) if e.get("event") == "shard finished"]
    assert sorted(e["shard"] for e in shards) == [0, 1]  # workers = 2: two shards
    assert sum(e["size"] for e in shards) == JOBS
    assert all(e["state_bytes"] > 0 for e in shards)
    assert run.output  # and written


BASELINE_TOML = """\
[batch]
defaults = false

[batch.baseline]
previous = true
better = { "Max speed" = "higher" }
"""


def test_a_baseline_comparison_on_processes_writes_the_bytes_of_a_local_run(
    tmp_path: Path,
) -> None:
    # The candidate's jobs in shards, the baseline's on the driver beside them, the
    # directions of the other metrics from their failure definitions once both are in.
    pair = config(
        seed=7,
        jobs_per_batch=30,
        baseline_pair=True,
        baseline_regressed_experiences=(3, 11),
        baseline_shift_metric="Localization error",
        baseline_shift=0.25,
    )
    with EmulatorThread(pair) as emulator:
        local = run_engine(emulator, tmp_path / "local", toml=BASELINE_TOML)
        sharded = run_engine(emulator, tmp_path / "processes", toml=BASELINE_TOML + PROCESSES)
    assert sharded.output == local.output
    text = text_of(by_name(read_job_metrics(local.output))["Compared with baseline"])
    assert "REGRESSED" in text


@pytest.mark.parametrize(
    ("table", "named"),
    [
        ('kind = "threads"', "[engine] kind"),
        ('kind = "processes"\nworkers = 0', "[engine] workers"),
        ('kind = "processes"\nshards = -2', "[engine] shards"),
        ('kind = "processes"\nworkers = "many"', "[engine] workers"),
        ('kind = "processes"\naddress = "auto"', "[engine] address"),
        ('kind = "ray"\naddress = ""', "[engine] address"),
        ("cores = 4", "'cores'"),
    ],
)
def test_bad_engine_settings_exit_2_before_any_request(
    emu: Emulator, tmp_path: Path, table: str, named: str
) -> None:
    before = api_requests(emu)
    run = run_engine(emu, tmp_path, toml=ENGINE_BATCH_TOML + "[engine]\n" + table + "\n")
    assert run.code == 2, run.err
    (line,) = failure_lines(run.err)
    assert named in line
    assert api_requests(emu) == before
    assert not (run.outputs / OUTPUT_NAME).exists()


# A Python that cannot import Ray, whatever is installed: `import ray` fails as if absent.
WITHOUT_RAY = """\
import sys
sys.modules["ray"] = None
from stook.service.cli import main
main()
"""


def run_without_ray(
    tmp: Path, emu: Emulator, *args: str, toml: str
) -> subprocess.CompletedProcess[str]:
    write_batch_inputs(tmp / "inputs", emu)
    (tmp / "stook.toml").write_text(toml)
    argv = [sys.executable, "-c", WITHOUT_RAY, "run", "--inputs", str(tmp / "inputs")]
    argv += ["--outputs", str(tmp / "outputs"), "--config", str(tmp / "stook.toml"), *args]
    env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
    return subprocess.run(
        argv, cwd=tmp, env=env, capture_output=True, text=True, timeout=120, check=False
    )


def test_ray_without_ray_installed_exits_2_naming_the_extra(emu: Emulator, tmp_path: Path) -> None:
    before = api_requests(emu)
    done = run_without_ray(tmp_path, emu, toml=ENGINE_BATCH_TOML + '[engine]\nkind = "ray"\n')
    assert done.returncode == 2, done.stderr
    (line,) = failure_lines(done.stderr)
    assert 'pip install "stook[ray]"' in line
    assert "[engine] kind" in line
    assert api_requests(emu) == before
    assert not (tmp_path / "outputs" / OUTPUT_NAME).exists()


def test_the_engine_flag_needs_no_ray_for_a_local_run(emu: Emulator, tmp_path: Path) -> None:
    done = run_without_ray(
        tmp_path, emu, "--engine", "local", toml=ENGINE_BATCH_TOML + '[engine]\nkind = "ray"\n'
    )
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "outputs" / OUTPUT_NAME).exists()


def test_a_shard_refused_by_the_api_exits_3_saying_it_once(tmp_path: Path) -> None:
    # The token expires after the driver's listing (a few pages) and a few of the shards'
    # requests: a shard's AuthError is the run's, said once, and nothing is written.
    with EmulatorThread(config(jobs_per_batch=40, seed=3, revoke_token_after_requests=12)) as emu:
        write_batch_inputs(tmp_path / "inputs", emu)
        (tmp_path / "stook.toml").write_text(ENGINE_BATCH_TOML + PROCESSES)
        script = Path(sys.executable).parent / "stook"
        argv = [str(script), "run", "--inputs", str(tmp_path / "inputs")]
        argv += ["--outputs", str(tmp_path / "outputs"), "--config", str(tmp_path / "stook.toml")]
        env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
        done = subprocess.run(
            argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120, check=False
        )
        token = emu.token
    assert done.returncode == 3, done.stderr
    (line,) = failure_lines(done.stderr)
    assert "refused the token" in line
    assert "401" in line
    assert token not in done.stderr
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "outputs" / OUTPUT_NAME).exists()
    assert list((tmp_path / "outputs").glob("*")) == []


def test_the_deadline_covers_the_whole_sharded_run(tmp_path: Path) -> None:
    with EmulatorThread(config(jobs_per_batch=30, seed=3, latency_ms=400)) as emu:
        toml = ENGINE_BATCH_TOML + PROCESSES + "[fetch]\ndeadline = 1.5\n"
        run = run_engine(emu, tmp_path, toml=toml)
    assert run.code == 3, run.err
    (line,) = failure_lines(run.err)
    assert "deadline of 1.5 s" in line
    assert not (run.outputs / OUTPUT_NAME).exists()


def test_missing_jobs_are_listed_in_job_order_by_every_engine(tmp_path: Path) -> None:
    # Two jobs whose listings always fail, in different shards: "Missing jobs" names them
    # in job-ID order, whichever failed first and wherever, with reasons that leave out
    # what timing decides (how many attempts fitted in retry_for): the same bytes.
    broken = (2, 20)
    with EmulatorThread(config(jobs_per_batch=JOBS, seed=5, broken_jobs=broken)) as emu:
        toml = ENGINE_BATCH_TOML + "[fetch]\nretry_for = 2\n"
        args = ("--allow-missing-jobs", "0.5")
        local = run_engine(emu, tmp_path / "local", *args, toml=toml)
        sharded = run_engine(emu, tmp_path / "processes", *args, toml=toml + PROCESSES)
        ids = sorted(str(emu.dataset.jobs(emu.batch_id)[i].id) for i in broken)
    for run in (local, sharded):
        text = text_of(by_name(read_job_metrics(run.output))["Missing jobs"])
        listed = [line.split()[1] for line in text.splitlines() if line.startswith("- ")]
        assert listed == ids
        assert "failed on every attempt" in text
        assert "attempts;" not in text
    assert local.output == sharded.output


def test_progress_moves_while_the_shards_run(tmp_path: Path) -> None:
    run = run_with_live_progress(tmp_path, '[engine]\nkind = "processes"\nworkers = 2\n')
    assert_progress_moved_inside_the_shards(run)
    assert not [t for t in threading.enumerate() if t.name == "stook-shard-progress"]


def _events(err: str) -> list[dict[str, Any]]:
    events = []
    for line in err.splitlines():
        if line.startswith("{"):
            events.append(json.loads(line))
    return events


def test_a_shard_runs_the_fetch_core_on_its_own_jobs(emu: Emulator) -> None:
    # What a worker does, here in the test's process: five of the batch's jobs, folded into
    # fresh states; and a refused token coming back as a failure, not an exception.
    access = ApiAccess(emu.api_url, emu.token, emu.project_id)

    async def listed() -> list[Job]:
        async with open_api(access, FetchSettings()) as api:
            return [job async for job in api.list_jobs(emu.project_id, emu.batch_id)]

    jobs = asyncio.run(listed())
    states = default_batch_aggregations()
    shard = BatchShard(
        0, access, FetchSettings(), None, needs_of(states), states, emu.batch_id, jobs[3:8]
    )
    done = pickle.loads(run_shard([], None, pickle.dumps(shard)))
    assert isinstance(done, ShardDone)
    assert isinstance(done.outcome, FetchOutcome)
    assert (done.size, done.outcome.jobs_done, done.outcome.jobs_listed) == (5, 5, 5)
    assert len(done.states) == len(states)
    assert done.requests > 0

    refused = dataclasses.replace(
        shard, access=ApiAccess(emu.api_url, "not-the-token", emu.project_id)
    )
    failed = pickle.loads(run_shard([], None, pickle.dumps(refused)))
    assert isinstance(failed, ShardFailed)
    assert type(failed.error.rebuild()) is AuthError
    assert "not-the-token" not in failed.error.message


# A custom aggregation in a module beside stook.toml, which only the config's folder holds.
TALLY_MODULE = """\
from dataclasses import dataclass, field

from stook.sdk.aggregations import BatchAggregation


@dataclass
class JobTally(BatchAggregation):
    name: str = "Jobs tallied"
    count: int = field(default=0, init=False)

    def update(self, record):
        self.count += 1

    def merge(self, other):
        self.count += other.count

    def finish(self, writer):
        writer.scalar(self.name, float(self.count))
"""


def test_user_aggregations_are_imported_in_the_workers(emu: Emulator, tmp_path: Path) -> None:
    folder = tmp_path / "config"
    folder.mkdir()
    (folder / "tally_metrics_for_engines.py").write_text(TALLY_MODULE)
    emu.write_batch_config(tmp_path / "inputs")
    toml = '[[batch.custom]]\nclass = "tally_metrics_for_engines:JobTally"\n' + PROCESSES
    run = StookProcess(tmp_path, "--config", str(folder / "stook.toml"))
    (folder / "stook.toml").write_text(toml)
    assert run.finish(60) == 0, run.err
    view = read_job_metrics((run.outputs / OUTPUT_NAME).read_bytes())
    assert by_name(view)["Jobs tallied"].value == JOBS


def child_pids(pid: int) -> set[int]:
    children: set[int] = set()
    for task in Path(f"/proc/{pid}/task").iterdir():
        text = (task / "children").read_text().split()
        children.update(int(child) for child in text)
    return children


def gone(pid: int) -> bool:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return True
    return "\nState:\tZ" in status


def test_a_signal_stops_the_workers_too(tmp_path: Path) -> None:
    # Shards of ~4 s each; the listing, 100 jobs a page, takes 1.5 s.
    slow = config(
        jobs_per_batch=1500, latency_ms=100.0, seed=61, default_page_size=100, max_page_size=100
    )
    with EmulatorThread(slow) as emu:
        emu.write_batch_config(tmp_path / "inputs")
        run = StookProcess(tmp_path, "--log-format", "json", toml=PROCESSES)
        run.wait_for_line("batch fetch starting")
        run.wait_until(lambda: len(child_pids(run.proc.pid)) >= 2, "two workers started")
        workers = child_pids(run.proc.pid)
        time.sleep(0.5)  # the workers are fetching
        sent = time.monotonic()
        run.proc.send_signal(signal.SIGINT)
        code = run.finish(30)
        seconds = time.monotonic() - sent
    assert code == 130, run.err
    lines = failure_lines(run.err)
    assert len(lines) == 1, run.err
    assert lines[0].startswith("stook: interrupted by SIGINT")
    assert "Traceback" not in run.err
    assert seconds < 2.0
    assert not (run.outputs / OUTPUT_NAME).exists()
    deadline = time.monotonic() + 1.0  # not left to finish their shards
    while not all(gone(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert all(gone(pid) for pid in workers), workers


DIES_MODULE = """\
import os
from dataclasses import dataclass

from stook.sdk.aggregations import BatchAggregation


@dataclass
class DiesInWorker(BatchAggregation):
    name: str = "Dies"

    def update(self, record):
        os._exit(9)  # as the kernel's OOM killer would end it: no exception, no result

    def merge(self, other):
        pass

    def finish(self, writer):
        pass
"""


def test_a_worker_that_dies_ends_the_run_with_a_shard_error(emu: Emulator, tmp_path: Path) -> None:
    (tmp_path / "dies_for_engines.py").write_text(DIES_MODULE)
    toml = '[[batch.custom]]\nclass = "dies_for_engines:DiesInWorker"\n' + PROCESSES
    run = run_engine(emu, tmp_path, toml=toml)
    assert run.code == 1, run.err
    (line,) = failure_lines(run.err)
    assert "its worker ended without a result" in line
    assert not (run.outputs / OUTPUT_NAME).exists()
