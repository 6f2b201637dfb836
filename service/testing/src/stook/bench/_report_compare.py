"""Report mode against ReSim's default report metrics (resim-open-core), same emulator.

`compare_report_with_resim` times both in fresh processes from the call on (imports done);
`compare_report_whole_process` times each as a user does, a whole process from start to
exit: `stook run` on the report's inputs, and a Python process that imports ReSim's
`default_report_metrics` and runs it. Runs alternate, stook then ReSim; medians decide.
"""

from __future__ import annotations

import asyncio
import dataclasses
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Final

from stook.bench._measure import Measurement, in_fresh_process, peak_rss_mb, resim_available
from stook.bench._whole_process import time_stook_run
from stook.emulator import EmulatorConfig, EmulatorInfo, EmulatorProcess


def measure_stook_report(info: EmulatorInfo, concurrency: int) -> Measurement:
    from stook.service.modes import (
        ReportInputs,
        configure_logging,
        detect,
        parse,
        run_on_event_loop,
        run_report,
    )

    configure_logging(json=True, level="error")
    config = parse({"fetch": {"concurrency": concurrency}}, source="bench")
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "inputs"
        info.write_report_config(inputs)
        mode = detect(inputs)
        assert isinstance(mode, ReportInputs)
        started = time.perf_counter()
        result = run_on_event_loop(run_report(mode, config, Path(tmp) / "outputs"))
        seconds = time.perf_counter() - started
    return Measurement(
        client="stook report",
        jobs=result.outcome.jobs,
        seconds=seconds,
        requests=result.requests,
        retries=result.retries,
        bytes_received=result.bytes_received,
        peak_rss_mb=peak_rss_mb(),
    )


def measure_resim_report(info: EmulatorInfo) -> Measurement:
    """ReSim's `default_report_metrics.fetch_and_compute_metrics`, as its metrics build runs it."""
    from resim.metrics import default_report_metrics
    from resim.sdk.client.models.batch_metric import BatchMetric
    from resim.sdk.client.models.job_metric import JobMetric

    # resim-open-core 1.6.0 reads `.type` where its own client models define `.type_`;
    # without this alias its default report crashes on every input, emulated or real.
    for model in (JobMetric, BatchMetric):
        if not hasattr(model, "type"):
            model.type = property(lambda self: self.type_)

    with tempfile.TemporaryDirectory() as tmp:
        started = time.perf_counter()
        asyncio.run(
            default_report_metrics.fetch_and_compute_metrics(
                token=info.token,
                api_url=info.api_url,
                project_id=info.project_id,
                report_id=info.report_id,
                output_path=str(Path(tmp) / "metrics.binproto"),
            )
        )
        seconds = time.perf_counter() - started
    return Measurement(
        client="resim default_report_metrics",
        jobs=0,
        seconds=seconds,
        requests=0,
        retries=0,
        bytes_received=0,
        peak_rss_mb=peak_rss_mb(),
    )


def _report_emulator(batches: int, jobs: int, latency_ms: float) -> EmulatorConfig:
    """The report both comparisons fetch: `batches` of `jobs` jobs, answers `latency_ms` late."""
    return EmulatorConfig(
        seed=5,
        report_batches=batches,
        report_jobs_per_batch=jobs,
        cache_jobs=max(batches * jobs, 1),
        latency_ms=latency_ms,
    )


def compare_report_with_resim(batches: int, jobs: int, latency_ms: float) -> dict[str, Any]:
    config = _report_emulator(batches, jobs, latency_ms)
    with EmulatorProcess(config) as emulator:
        # Warm-up: the emulator generates every job's metrics on first request.
        in_fresh_process(measure_stook_report, emulator.info, 64)
        before = sum(emulator.stats().requests.values())
        stook: Measurement = in_fresh_process(measure_stook_report, emulator.info, 64)
        middle = sum(emulator.stats().requests.values())
        result: dict[str, Any] = {
            "batches": batches,
            "jobs_per_batch": jobs,
            "latency_ms": latency_ms,
            "stook": dataclasses.asdict(stook),
            "stook_server_requests": middle - before,
        }
        try:
            resim: Measurement = in_fresh_process(measure_resim_report, emulator.info)
        except ImportError:
            return result
        after = sum(emulator.stats().requests.values())
        result["resim"] = dataclasses.asdict(resim)
        result["resim_server_requests"] = after - middle
        result["speedup"] = resim.seconds / stook.seconds
    return result


_TIMEOUT_S: Final = 900

# ReSim's default report as `measure_resim_report` runs it, in a process of its own (its
# imports included); argv: token, API URL, project, report, output path.
_RESIM_REPORT_SCRIPT: Final = """\
import asyncio, sys
from resim.metrics import default_report_metrics
from resim.sdk.client.models.batch_metric import BatchMetric
from resim.sdk.client.models.job_metric import JobMetric
for model in (JobMetric, BatchMetric):
    if not hasattr(model, "type"):
        model.type = property(lambda self: self.type_)
token, api_url, project_id, report_id, output_path = sys.argv[1:6]
asyncio.run(
    default_report_metrics.fetch_and_compute_metrics(
        token=token, api_url=api_url, project_id=project_id, report_id=report_id,
        output_path=output_path,
    )
)
"""


def _time_stook_report_run(info: EmulatorInfo, folder: Path, concurrency: int) -> float:
    info.write_report_config(folder / "inputs")
    return time_stook_run(folder, f"[fetch]\nconcurrency = {concurrency}\n")


def _time_resim_report(info: EmulatorInfo, folder: Path) -> float:
    output = folder / "resim-metrics.binproto"
    argv = [
        sys.executable,
        "-c",
        _RESIM_REPORT_SCRIPT,
        info.token,
        info.api_url,
        str(info.project_id),
        str(info.report_id),
        str(output),
    ]
    started = time.perf_counter()
    subprocess.run(
        argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True, timeout=_TIMEOUT_S
    )
    seconds = time.perf_counter() - started
    if not output.is_file():
        raise RuntimeError("ReSim's default report exited 0 without writing its metrics")
    return seconds


def compare_report_whole_process(
    batches: int, jobs: int, latency_ms: float, pairs: int = 3, concurrency: int = 64
) -> dict[str, Any]:
    """Every run's seconds for both, their medians and the speedup (stook alone without
    resim-open-core installed)."""
    config = _report_emulator(batches, jobs, latency_ms)
    with_resim = resim_available()
    runs: dict[str, list[float]] = {"stook": [], "resim": []}
    with EmulatorProcess(config) as emulator, tempfile.TemporaryDirectory() as tmp:
        # The emulator makes each job's data on first request: a first, untimed run.
        _time_stook_report_run(emulator.info, Path(tmp) / "warm", concurrency)
        for i in range(pairs):
            folder = Path(tmp) / f"run-{i}"
            runs["stook"].append(_time_stook_report_run(emulator.info, folder, concurrency))
            if with_resim:
                runs["resim"].append(_time_resim_report(emulator.info, folder))
    result: dict[str, Any] = {
        "batches": batches,
        "jobs_per_batch": jobs,
        "latency_ms": latency_ms,
        "pairs": pairs,
        "stook_runs_s": [round(s, 3) for s in runs["stook"]],
        "stook_median_s": round(statistics.median(runs["stook"]), 3),
    }
    if with_resim:
        result["resim_runs_s"] = [round(s, 3) for s in runs["resim"]]
        result["resim_median_s"] = round(statistics.median(runs["resim"]), 3)
        result["speedup"] = round(result["resim_median_s"] / result["stook_median_s"], 1)
    return result


REPORT_SPEEDUP_TARGET: Final = 10.0  # issue 13: report mode against ReSim's default report


def report_target(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """The report-mode target from `compare_report_with_resim` runs: their median speedup
    (no target where ReSim's report could not be run)."""
    speedups = sorted(r["speedup"] for r in runs if "speedup" in r)
    if not speedups:
        return {}
    first = runs[0]
    median = statistics.median(speedups)
    return {
        "report_vs_resim": {
            "at": f"{first['batches']} batches x {first['jobs_per_batch']} jobs, "
            f"{first['latency_ms']:g} ms, median of {len(speedups)}",
            "measured": round(median, 1),
            "by_run": [round(s, 1) for s in speedups],
            "target": f">= {REPORT_SPEEDUP_TARGET:g}",
            "met": median >= REPORT_SPEEDUP_TARGET,
        }
    }
