"""`stook run` against ReSim's fetcher, each timed as a whole process, as a user times them.

The in-process comparison (`compare_with_resim`) times the fetch alone; a user runs
`time stook run`, which also pays for start-up (imports, config, the output's write). Here
each client is a fresh process on the same emulator, timed from before it is started until
it has exited: `stook run` with a config that downloads one series per job into a
histogram, and a Python process that calls ReSim's `fetch_job_metrics_by_batch` (its
import included). Runs alternate, stook then ReSim, and the medians decide. stook's
modules are byte-compiled first, as pip compiles an installed wheel's (and ReSim's).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

from stook.bench._measure import resim_available
from stook.bench._startup import byte_compile_stook, stook_command
from stook.bench._sweep import SWEEP_CONFIG, emulator_for
from stook.emulator import EmulatorInfo

__all__ = ["measure_whole_process", "whole_process_target"]

# Issue 13: 400 jobs at 10 ms, median of 5 interleaved pairs, stook >= 15x faster.
JOBS: Final = 400
QUICK_JOBS: Final = 50
LATENCY_MS: Final = 10.0
PAIRS: Final = 5
QUICK_PAIRS: Final = 1
SPEEDUP_TARGET: Final = 15.0
_TIMEOUT_S: Final = 600

# ReSim's fetcher as its docs show it, in a process of its own; argv: token, API URL,
# project, batch. It prints the number of jobs it fetched, so a run that fetched nothing
# cannot pass for a fast one.
_RESIM_SCRIPT: Final = """\
import sys
from resim.metrics.fetch_job_metrics import fetch_job_metrics_by_batch
token, api_url, project_id, batch_id = sys.argv[1:5]
fetched = fetch_job_metrics_by_batch(
    token=token, api_url=api_url, project_id=project_id, batch_id=batch_id
)
print(len(fetched))
"""


def _time_stook_run(info: EmulatorInfo, folder: Path) -> float:
    inputs = folder / "inputs"
    inputs.mkdir(parents=True)
    info.write_batch_config(inputs)
    return time_stook_run(folder, SWEEP_CONFIG)


def time_stook_run(folder: Path, config_toml: str) -> float:
    """`stook run` as a whole process on ``folder/inputs`` (written beforehand), with
    `config_toml` as its config: the seconds from before it starts until it exits."""
    inputs, outputs = folder / "inputs", folder / "outputs"
    config = folder / "stook.toml"
    config.write_text(config_toml, encoding="utf-8")
    argv = [
        *stook_command(),
        "run",
        "--inputs",
        str(inputs),
        "--outputs",
        str(outputs),
        "--config",
        str(config),
        "--log-level",
        "error",
    ]
    byte_compile_stook()  # as an installed wheel is (see _startup); untimed
    started = time.perf_counter()
    subprocess.run(
        argv,
        cwd=folder,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        check=True,
        timeout=_TIMEOUT_S,
    )
    seconds = time.perf_counter() - started
    if not (outputs / "metrics.binproto").is_file():
        raise RuntimeError("stook run exited 0 without writing metrics.binproto")
    return seconds


def _time_resim(info: EmulatorInfo, jobs: int) -> float:
    argv = [
        sys.executable,
        "-c",
        _RESIM_SCRIPT,
        info.token,
        info.api_url,
        str(info.project_id),
        str(info.batch_id),
    ]
    started = time.perf_counter()
    done = subprocess.run(
        argv,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        check=True,
        text=True,
        timeout=_TIMEOUT_S,
    )
    seconds = time.perf_counter() - started
    if done.stdout.strip() != str(jobs):
        raise RuntimeError(f"ReSim's fetcher fetched {done.stdout.strip()!r} jobs, not {jobs}")
    return seconds


def _requests(emulator: Any) -> int:
    return sum(emulator.stats().requests.values())


def measure_whole_process(
    jobs: int = JOBS,
    latency_ms: float = LATENCY_MS,
    pairs: int = PAIRS,
    *,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Every run's seconds and requests for both clients, their medians and the speedup.

    Without resim-open-core installed only stook is timed (no speedup).
    """
    with_resim = resim_available()
    runs: dict[str, list[float]] = {"stook": [], "resim": []}
    requests: dict[str, int] = {}
    with emulator_for(jobs, latency_ms) as emulator, tempfile.TemporaryDirectory() as tmp:
        # The emulator makes each job's data on first request: a first, untimed run.
        _time_stook_run(emulator.info, Path(tmp) / "warm")
        for i in range(pairs):
            before = _requests(emulator)
            runs["stook"].append(_time_stook_run(emulator.info, Path(tmp) / f"run-{i}"))
            middle = _requests(emulator)
            requests["stook"] = middle - before
            if with_resim:
                runs["resim"].append(_time_resim(emulator.info, jobs))
                requests["resim"] = _requests(emulator) - middle
    result: dict[str, Any] = {
        "jobs": jobs,
        "latency_ms": latency_ms,
        "pairs": pairs,
        "stook_runs_s": [round(s, 3) for s in runs["stook"]],
        "stook_median_s": round(statistics.median(runs["stook"]), 3),
        "stook_requests": requests["stook"],
    }
    line = f"  stook run: {result['stook_median_s']:.2f} s"
    if with_resim:
        result["resim_runs_s"] = [round(s, 3) for s in runs["resim"]]
        result["resim_median_s"] = round(statistics.median(runs["resim"]), 3)
        result["resim_requests"] = requests["resim"]
        result["speedup"] = round(result["resim_median_s"] / result["stook_median_s"], 1)
        line += f", ReSim's fetcher: {result['resim_median_s']:.2f} s: {result['speedup']}x"
    say(line + f" (whole processes, median of {pairs})")
    return result


def whole_process_target(result: dict[str, Any] | None) -> dict[str, Any]:
    """The target on the medians; none without a ReSim measurement."""
    if result is None or "speedup" not in result:
        return {}
    return {
        "whole_process_vs_resim": {
            "at": (
                f"{result['jobs']} jobs, {result['latency_ms']:g} ms, whole processes, "
                f"median of {result['pairs']} interleaved pairs"
            ),
            "measured": result["speedup"],
            "target": f">= {SPEEDUP_TARGET:g}",
            "met": result["speedup"] >= SPEEDUP_TARGET,
        }
    }
