"""Running `stook run` with an `[engine]` on the emulator, for tests/e2e/test_engines*.py."""

from __future__ import annotations

import contextlib
import io
import json
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest

from stook.emulator import Emulator
from stook.service.cli import run_cli
from tests.e2e.support import BATCH_TOML, OUTPUT_NAME, EmulatorThread, config, write_batch_inputs

# The batch metrics under comparison: a histogram over a series ("speeds"), scalar stats,
# a weighted mean, the default aggregations and the batch summary (on by default).
ENGINE_BATCH_TOML = BATCH_TOML


@dataclass(frozen=True)
class EngineRun:
    code: int
    err: str
    outputs: Path

    @property
    def output(self) -> bytes:
        assert self.code == 0, self.err
        return (self.outputs / OUTPUT_NAME).read_bytes()


@contextlib.contextmanager
def no_stook_environment() -> Iterator[None]:
    with pytest.MonkeyPatch.context() as mp:
        for name in list(os.environ):
            if name.startswith("STOOK_"):
                mp.delenv(name)
        yield


def run_engine(
    emu: Emulator,
    tmp: Path,
    *args: str,
    toml: str = ENGINE_BATCH_TOML,
    report: bool = False,
    env: Mapping[str, str] | None = None,
) -> EngineRun:
    """`stook run` in this process (its shards in workers) on the emulator's batch, or its
    report; `args` are extra flags, e.g. ``--engine processes``; `env`: STOOK_* settings."""
    inputs, outputs = tmp / "inputs", tmp / "outputs"
    if report:
        emu.write_report_config(inputs)
    else:
        write_batch_inputs(inputs, emu)
    config = tmp / "stook.toml"
    config.write_text(toml)
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--config", str(config)]
    argv += ["--log-format", "json", "--log-level", "warning", *args]
    err = io.StringIO()
    with no_stook_environment(), pytest.MonkeyPatch.context() as mp:
        for name, value in (env or {}).items():
            mp.setenv(name, value)
        with contextlib.redirect_stderr(err):
            code = run_cli(argv)
    return EngineRun(code, err.getvalue(), outputs)


def run_with_live_progress(tmp_path: Path, engine: str) -> EngineRun:
    """Two shards of 12 jobs, two jobs at a time, 50 ms a request: each shard runs for
    about a second, with progress events every 0.1 s."""
    with EmulatorThread(config(jobs_per_batch=24, seed=13, latency_ms=50)) as emu:
        toml = ENGINE_BATCH_TOML + engine + "shards = 2\n[fetch]\nconcurrency = 2\n"
        env = {"STOOK_PROGRESS": "log", "STOOK_PROGRESS_INTERVAL": "0.1"}
        return run_engine(emu, tmp_path, "--log-level", "info", toml=toml, env=env)


def assert_progress_moved_inside_the_shards(run: EngineRun) -> None:
    """Jobs done inside the shards, not only 0, 12 and 24 (what whole shards give), and
    requests and bytes before any shard is done."""
    assert run.code == 0, run.err
    events = [json.loads(line) for line in run.err.splitlines() if line.startswith("{")]
    progress = [e for e in events if e.get("event") == "fetch progress"]
    done = [e["jobs_done"] for e in progress]
    assert [d for d in done if d not in (0, 12, 24)], done
    assert done == sorted(done)  # never back: a shard's result supersedes its reports
    first_shard = next(i for i, e in enumerate(events) if e.get("event") == "shard finished")
    before = [e for e in events[:first_shard] if e.get("event") == "fetch progress"]
    assert any(e["requests_per_s"] > 0 and e["received"] != "0 B" for e in before), before
