"""`stook demo`'s "run it yourself" commands work after the demo's emulator has gone: run
as printed, in the demo's working directory, they write valid batch and report outputs."""

from __future__ import annotations

import shlex
import subprocess
import time
from pathlib import Path

import pytest

from stook.sdk import find_problems, read_job_metrics
from tests.e2e.processes import stook_command


def _command(line: str) -> list[str]:
    words = shlex.split(line)
    assert words[0] == "stook", line
    return [*stook_command(), *words[1:]]


@pytest.mark.slow
def test_the_demos_run_it_yourself_commands_work(tmp_path: Path) -> None:
    demo = subprocess.run(
        [*stook_command(), "demo", "--jobs", "6", "--output", "out"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=180,
        check=False,
    )
    assert demo.returncode == 0, demo.stderr
    hint = demo.stdout[demo.stdout.index("Run it yourself") :].splitlines()
    commands = [line.strip() for line in hint if line.startswith("  stook ")]
    assert [c.split()[1] for c in commands] == ["emulate", "run", "run"], hint

    emulator = subprocess.Popen(
        _command(commands[0]),
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert emulator.stdout is not None
        deadline = time.monotonic() + 30
        while "Press Ctrl-C" not in (line := emulator.stdout.readline()):
            assert line, "the emulator exited early"
            assert time.monotonic() < deadline
        for command, folder in zip(commands[1:], ("batch", "report"), strict=True):
            run = subprocess.run(
                _command(command),
                cwd=tmp_path,
                capture_output=True,
                text=True,
                timeout=120,
                check=False,
            )
            assert run.returncode == 0, run.stderr
            output = tmp_path / "out" / "yours" / folder / "metrics.binproto"
            view = read_job_metrics(output.read_bytes())
            assert not find_problems(view.raw)
            assert view.metrics
    finally:
        emulator.terminate()
        emulator.wait(timeout=15)
        if emulator.stdout is not None:
            emulator.stdout.close()
