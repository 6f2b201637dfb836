"""Report mode against ReSim's default report metrics (resim-open-core), same emulator."""

from __future__ import annotations

import asyncio
import dataclasses
import tempfile
import time
from pathlib import Path
from typing import Any

from stook.bench._measure import Measurement, in_fresh_process, peak_rss_mb
from stook.emulator import EmulatorConfig, EmulatorInfo, EmulatorProcess


def measure_stook_report(info: EmulatorInfo, concurrency: int) -> Measurement:
    from stook.service.api import configure_logging
    from stook.service.modes import ReportInputs, detect, parse, run_report

    configure_logging(json=True, level="error")
    config = parse({"fetch": {"concurrency": concurrency}}, source="bench")
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "inputs"
        info.write_report_config(inputs)
        mode = detect(inputs)
        assert isinstance(mode, ReportInputs)
        started = time.perf_counter()
        result = asyncio.run(run_report(mode, config, Path(tmp) / "outputs"))
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


def compare_report_with_resim(batches: int, jobs: int, latency_ms: float) -> dict[str, Any]:
    config = EmulatorConfig(
        seed=5,
        report_batches=batches,
        report_jobs_per_batch=jobs,
        cache_jobs=max(batches * jobs, 1),
        latency_ms=latency_ms,
    )
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
