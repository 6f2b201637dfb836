"""Start-up as a user times it: each command as a whole process, median of `runs`.

`--help`, `--version`, `show` and `validate` are timed from before the process is started
until it has exited. `stook run` is timed from before its process is started until the
emulator (in a process of its own, a fresh one per run) sees its first request; both
sides read time.monotonic(), one clock for every process on the machine.

stook's modules are byte-compiled first, as pip does when it installs a wheel: a checkout
installed in editable mode, run with PYTHONDONTWRITEBYTECODE set (as in many containers),
would otherwise compile every one of its modules from source at every start-up, about a
third of `stook run`'s instructions before its first request.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

from stook.emulator import EmulatorConfig, EmulatorProcess
from stook.sdk import MetricsWriter, data

# Targets of issue 13, in seconds.
COMMAND_TARGET_S: Final = 0.15
FIRST_REQUEST_TARGET_S: Final = 0.35
COMMANDS: Final = ("--help", "--version", "show", "validate")


def stook_command() -> list[str]:
    """The installed console script, as a user runs it."""
    script = Path(sys.executable).parent / "stook"
    if script.exists():
        return [str(script)]
    return [sys.executable, "-c", "from stook.service.cli import main; main()"]


def byte_compile_stook() -> None:
    """Write the bytecode of the stook packages that the commands import (compileall skips
    a module whose bytecode is up to date)."""
    import compileall
    import importlib

    for name in ("stook.proto", "stook.sdk", "stook.service"):
        for folder in importlib.import_module(name).__path__:
            compileall.compile_dir(folder, quiet=1)


def _clean_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}


def _sample_file(folder: Path) -> Path:
    w = MetricsWriter(uuid.UUID(int=13), deterministic=True)
    w.scalar("Max speed", 31.25, unit="m/s", fails_above=35.0)
    speeds = [float(i % 40) for i in range(1000)]
    w.histogram("Speeds", data.doubles("speeds", speeds), buckets=20, lower=0, upper=40)
    return w.write(folder / "metrics.binproto")


def _time_command(argv: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(
        argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=_clean_env(), check=True
    )
    return time.perf_counter() - started


def _time_to_first_request(folder: Path) -> float:
    inputs, outputs = folder / "inputs", folder / "outputs"
    inputs.mkdir()
    with EmulatorProcess(EmulatorConfig(seed=11, jobs_per_batch=10)) as emulator:
        emulator.write_batch_config(inputs)
        argv = [*stook_command(), "run", "--inputs", str(inputs), "--outputs", str(outputs)]
        started = time.monotonic()
        subprocess.run(
            argv,
            cwd=folder,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=_clean_env(),
            check=True,
            timeout=120,
        )
        first = emulator.stats().first_request_at
    if first is None:
        raise RuntimeError("stook run made no request to the emulator")
    return first - started


def measure_startup(runs: int, say: Callable[[str], None] = print) -> dict[str, Any]:
    """Medians (and every run) in seconds, keyed by command; "run" is time to first request."""
    results: dict[str, Any] = {}
    byte_compile_stook()
    with tempfile.TemporaryDirectory(prefix="stook-startup-") as tmp:
        folder = Path(tmp)
        file = str(_sample_file(folder))
        for command in COMMANDS:
            argv = [*stook_command(), command]
            if not command.startswith("--"):
                argv.append(file)
            _time_command(argv)  # a first run fills the OS's file cache
            seconds = [_time_command(argv) for _ in range(runs)]
            results[command] = _summary(seconds)
            say(f"  stook {command}: {results[command]['median_s']:.3f} s")
        seconds = []
        for i in range(runs):
            run_folder = folder / f"run-{i}"
            run_folder.mkdir()
            seconds.append(_time_to_first_request(run_folder))
        results["run"] = _summary(seconds)
        say(f"  stook run, to its first request: {results['run']['median_s']:.3f} s")
    return results


def _summary(seconds: list[float]) -> dict[str, Any]:
    return {
        "median_s": round(statistics.median(seconds), 4),
        "runs_s": [round(s, 4) for s in seconds],
    }


def startup_targets(startup: dict[str, Any]) -> dict[str, Any]:
    """One target for the commands (the slowest median decides), one for `stook run`."""
    slowest = max(COMMANDS, key=lambda c: startup[c]["median_s"])
    commands_s = startup[slowest]["median_s"]
    run_s = startup["run"]["median_s"]
    return {
        "startup_commands": {
            "at": f"{', '.join(COMMANDS)} as processes, median; slowest: {slowest}",
            "measured": commands_s,
            "by_command": {c: startup[c]["median_s"] for c in COMMANDS},
            "target": f"<= {COMMAND_TARGET_S} s",
            "met": commands_s <= COMMAND_TARGET_S,
        },
        "startup_first_request": {
            "at": "stook run as a process, to the emulator's first request, median",
            "measured": run_s,
            "target": f"<= {FIRST_REQUEST_TARGET_S} s",
            "met": run_s <= FIRST_REQUEST_TARGET_S,
        },
    }


def startup_table(startup: dict[str, Any]) -> str:
    """Markdown: each command's median against its target."""
    rows = [
        (f"`stook {c}`", f"{startup[c]['median_s']:.3f}", f"<= {COMMAND_TARGET_S}")
        for c in COMMANDS
    ]
    rows.append(
        (
            "`stook run`, to its first request",
            f"{startup['run']['median_s']:.3f}",
            f"<= {FIRST_REQUEST_TARGET_S}",
        )
    )
    lines = ["| start-up (whole process) | median s | target s |", "|---|---:|---:|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"
