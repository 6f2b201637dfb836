"""Following a run: a bar with the API's fixed total and an ETA on a terminal (a real
pseudo-terminal), one progress event per interval off one, and a summary in human units."""

from __future__ import annotations

import itertools
import json
import os
import re
import subprocess
from datetime import datetime
from pathlib import Path

import pytest

from tests.e2e.processes import REPO, stook_command
from tests.e2e.support import EmulatorThread, config, write_batch_inputs
from tests.e2e.terminal import run_on_a_terminal

JOBS = 120
# Small pages and few workers: the listing is still going while jobs complete, so a bar
# against the jobs listed so far would show a growing denominator.
SLOW_TOML = "[fetch]\nconcurrency = 4\npage_size = 10\n"


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
    env["PYTHONPATH"] = str(REPO)
    return {**env, **extra}


def _run_on_a_terminal(tmp_path: Path, inputs: Path) -> tuple[int, str]:
    """`stook run` with stdout and stderr on a pseudo-terminal 120 columns wide."""
    (tmp_path / "stook.toml").write_text(SLOW_TOML)
    run = run_on_a_terminal(
        [*stook_command(), "run", "--inputs", str(inputs), "--outputs", str(tmp_path / "out")],
        cwd=tmp_path,
        env=_env(),
        width=120,
    )
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", run.output)
    return run.code, text.replace("\r", "\n")


@pytest.mark.slow
def test_a_batch_on_a_terminal_shows_a_bar_with_the_apis_total(tmp_path: Path) -> None:
    with EmulatorThread(config(jobs_per_batch=JOBS, seed=31, latency_ms=5.0)) as emu:
        write_batch_inputs(tmp_path / "inputs", emu)
        code, screen = _run_on_a_terminal(tmp_path, tmp_path / "inputs")
    assert code == 0, screen
    drawn = re.findall(r"^\s*jobs .*? (\d+)/(\S+) +(\d+)% .* ETA (\S+)", screen, re.M)
    assert len(drawn) >= 2, screen
    assert {total for _, total, _, _ in drawn} == {str(JOBS)}  # fixed from the first drawing
    assert any(0 < int(done) < JOBS for done, _, _, _ in drawn), screen
    assert drawn[-1][:3] == (str(JOBS), str(JOBS), "100")
    assert all(re.fullmatch(r"\d+:\d\d:\d\d|-:--:--", eta) for *_, eta in drawn)
    assert "req/s" in screen
    assert "retries" in screen
    assert "retrying request" not in screen
    assert re.search(r"wrote \S+metrics.binproto: \d+ metrics from 120 jobs in ", screen), screen


@pytest.mark.slow
def test_a_report_on_a_terminal_shows_batches_and_jobs(tmp_path: Path) -> None:
    settings = config(report_batches=4, report_jobs_per_batch=15, seed=37, latency_ms=5.0)
    with EmulatorThread(settings) as emu:
        emu.write_report_config(tmp_path / "inputs")
        code, screen = _run_on_a_terminal(tmp_path, tmp_path / "inputs")
    assert code == 0, screen
    assert re.search(r"^\s*batches .* 4/4 +100%", screen, re.M), screen
    assert re.search(r"^\s*jobs .* 60/60 +100%", screen, re.M), screen
    totals = set(re.findall(r"^\s*jobs .*? \d+/(\S+) ", screen, re.M))
    assert totals <= {"60", "?"}, screen  # the batches' totalJobs, once they are listed


@pytest.mark.slow
def test_off_a_terminal_one_progress_event_per_interval(tmp_path: Path) -> None:
    (tmp_path / "stook.toml").write_text(SLOW_TOML)
    with EmulatorThread(config(jobs_per_batch=JOBS, seed=41, latency_ms=20.0)) as emu:
        write_batch_inputs(tmp_path / "inputs", emu)
        done = subprocess.run(
            [*stook_command(), "run", "--inputs", "inputs", "--outputs", "out"],
            cwd=tmp_path,
            env=_env(STOOK_PROGRESS_INTERVAL="0.25"),
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
    assert done.returncode == 0, done.stderr
    events = [json.loads(line) for line in done.stderr.splitlines()]
    progress = [e for e in events if e["event"] == "fetch progress"]
    assert len(progress) >= 2, done.stderr
    assert {e["jobs_total"] for e in progress} == {JOBS}
    dones = [e["jobs_done"] for e in progress]
    assert dones == sorted(dones)
    assert dones[0] < JOBS
    for event in progress:
        assert set(event) >= {"progress", "requests_per_s", "retries", "elapsed_s", "received"}
        assert event["progress"] == f"{event['jobs_done']} of {JOBS} jobs"
    stamps = [datetime.fromisoformat(e["timestamp"]) for e in progress]
    gaps = [(b - a).total_seconds() for a, b in itertools.pairwise(stamps)]
    assert all(gap >= 0.2 for gap in gaps), gaps
    (summary,) = [e for e in events if e["event"] == "batch metrics written"]
    assert "bytes" not in summary
    assert re.fullmatch(r"[\d.]+ (kB|MB)", summary["received"])
    assert not [e for e in events if e["event"] == "retrying request"]


_BAR_ROW = re.compile(r"^\s*jobs [━╸╺ ]*\s*[\d,]+/[\d,?]+")


@pytest.mark.slow
def test_at_80_columns_nothing_of_the_bar_wraps(tmp_path: Path) -> None:
    (tmp_path / "stook.toml").write_text(SLOW_TOML)
    with EmulatorThread(config(jobs_per_batch=JOBS, seed=43, latency_ms=5.0)) as emu:
        write_batch_inputs(tmp_path / "inputs", emu)
        run = run_on_a_terminal(
            [*stook_command(), "run", "--inputs", "inputs", "--outputs", "out"],
            cwd=tmp_path,
            env=_env(),
            width=80,
        )
    screen = run.screen(80)
    assert run.code == 0, "\n".join(screen)
    bars = [row for row in screen if _BAR_ROW.match(row)]
    assert len(bars) == 1, screen  # redrawn in place, left once
    assert re.match(rf"jobs ━+ {JOBS}/{JOBS} 100%  [\d.]+ jobs/s  ETA 0:00:00", bars[0])
    # No piece of a bar's line below it ("jobs/s" alone on a row): every row that has
    # the bar's words starts as the bar's line does.
    for row in screen:
        if re.search(r"jobs/s|req/s", row):
            assert _BAR_ROW.match(row), screen
        assert len(row) <= 80


@pytest.mark.slow
def test_ctrl_c_leaves_the_bar_drawn_once(tmp_path: Path) -> None:
    (tmp_path / "stook.toml").write_text(SLOW_TOML)
    with EmulatorThread(config(jobs_per_batch=2_000, seed=47, latency_ms=20.0)) as emu:
        write_batch_inputs(tmp_path / "inputs", emu)
        run = run_on_a_terminal(
            [*stook_command(), "run", "--inputs", "inputs", "--outputs", "out"],
            cwd=tmp_path,
            env=_env(),
            width=80,
            # Typed once the bar shows jobs done and a rate: in the middle of the fetch.
            ctrl_c_when=lambda output: bool(re.search(r"\d+\.\d jobs/s", output)),
        )
    screen = [row for row in run.screen(80) if row]
    assert run.code == 130, "\n".join(screen)
    bars = [row for row in screen if _BAR_ROW.match(row)]
    assert len(bars) == 1, "\n".join(screen)
    assert screen[-2] == bars[0]
    done = re.match(r"jobs [━╸╺ ]*\s*([\d,]+)/2,000", bars[0])
    assert done, bars[0]
    assert screen[-1] == f"stook: interrupted by SIGINT after {done.group(1)} of 2,000 jobs"
    assert not [row for row in screen if row.strip() == "^C"]
