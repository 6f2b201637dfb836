"""One measured run, each in a fresh spawned process so that its peak RSS is its own.

The emulator runs in yet another process (EmulatorProcess), so the client measured
never shares an event loop or a core's time slice with the server's Python code.
"""

from __future__ import annotations

import importlib
import os
import resource
import sys
import tempfile
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final, ParamSpec, TypeVar

from stook.emulator import EmulatorInfo

if TYPE_CHECKING:
    from stook.service.modes import Traffic

_P = ParamSpec("_P")
_T = TypeVar("_T")


# The clients as rows, CSV and tables name them.
STOOK: Final = "stook"
BARE_LOOP: Final = "bare aiohttp loop"
LATENCY_BOUND: Final = "latency bound"
RESIM: Final = "resim fetch_job_metrics_by_batch"


# The exact-mode histogram keeps every value up to its cap (2 million by default), so its
# memory grows with the batch by design; measured apart from the streaming sweep.
BENCH_CONFIG = """\
[[batch.weighted_mean]]
name = "Distance-weighted localization error"
metric = "Localization error"
weight = "Distance driven"

[[batch.histogram]]
name = "Speed distribution"
data = "speeds"
lower = 0.0
upper = 40.0
buckets = 20
"""


@dataclass(frozen=True, slots=True)
class Measurement:
    """What one client run cost. `requests` and `retries` are as the client counted them."""

    client: str
    jobs: int
    seconds: float
    requests: int
    retries: int
    bytes_received: int
    peak_rss_mb: float
    # The client process's own CPU time (user + system) over the measured run.
    cpu_seconds: float = 0.0

    @property
    def requests_per_second(self) -> float:
        return self.requests / self.seconds if self.seconds else 0.0


def peak_rss_mb() -> float:
    # On Linux ru_maxrss survives exec: a spawned child would report the RSS of the parent
    # it was forked from, if that was larger. VmHWM belongs to the current image only.
    try:
        status = Path("/proc/self/status").read_text()
    except OSError:
        # ru_maxrss is in KiB on Linux and bytes on macOS.
        scale = 1 if sys.platform == "darwin" else 1024
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale / 2**20
    for line in status.splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024  # kB
    return 0.0


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def process_cpu_seconds(pid: int) -> float | None:
    """User + system CPU of another process (the emulator's), or None off Linux."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    # utime and stime are the 12th and 13th fields after the command name, in clock ticks.
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def in_fresh_process(fn: Any, *args: Any) -> Any:
    """Run fn(*args) in a new spawned interpreter and return its result."""
    with ProcessPoolExecutor(max_workers=1, mp_context=get_context("spawn")) as pool:
        return pool.submit(fn, *args).result()


def measure_stook(
    info: EmulatorInfo, config_toml: str, concurrency: int, adaptive: bool = False
) -> Measurement:
    """Batch mode as `stook run` does it, minus the process start-up."""
    return run_stook(info, config_toml, concurrency, adaptive)[0]


def run_stook(
    info: EmulatorInfo, config_toml: str, concurrency: int, adaptive: bool = False
) -> tuple[Measurement, Traffic]:
    """`measure_stook`, with the run's traffic: its limiters' stats among it."""
    from stook.service.modes import (
        BatchInputs,
        configure_logging,
        detect,
        event_loop_factory,
        parse,
        run_batch,
        run_on_event_loop,
    )

    configure_logging(json=True, level="error")
    # A run imports polars and numpy with its first series (so that its first request goes
    # out sooner); that is start-up, which the start-up section measures. Imported here,
    # before the clock starts, so this number stays the fetch alone, as before.
    importlib.import_module("polars")
    importlib.import_module("numpy")
    # And numpy.ma, which polars imports lazily with its first Series from an array.
    importlib.import_module("numpy.ma")
    event_loop_factory()  # and uvloop, which `stook run` imports before its loop starts
    doc = tomllib.loads(config_toml)
    doc.setdefault("fetch", {})["concurrency"] = concurrency
    if adaptive:
        doc["fetch"]["adaptive"] = True
    config = parse(doc, source="bench")
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "inputs"
        info.write_batch_config(inputs)
        batch = detect(inputs)
        assert isinstance(batch, BatchInputs)
        started = time.perf_counter()
        cpu_before = cpu_seconds()
        # On the loop `stook run` runs on (uvloop where installed).
        result = run_on_event_loop(run_batch(batch, config, Path(tmp) / "outputs"))
        seconds = time.perf_counter() - started
        cpu = cpu_seconds() - cpu_before
    measurement = Measurement(
        client=STOOK,
        jobs=result.outcome.jobs_listed,
        seconds=seconds,
        requests=result.requests,
        retries=result.retries,
        bytes_received=result.bytes_received,
        peak_rss_mb=peak_rss_mb(),
        cpu_seconds=cpu,
    )
    return measurement, result.traffic


def measure_resim(info: EmulatorInfo) -> Measurement:
    """ReSim's own `fetch_job_metrics_by_batch` (resim-open-core), as its docs show it."""
    from resim.metrics.fetch_job_metrics import fetch_job_metrics_by_batch

    started = time.perf_counter()
    cpu_before = cpu_seconds()
    fetched = fetch_job_metrics_by_batch(
        token=info.token,
        api_url=info.api_url,
        project_id=info.project_id,
        batch_id=info.batch_id,
    )
    seconds = time.perf_counter() - started
    # ReSim's fetcher keeps no counters; the emulator's stats give its requests.
    return Measurement(
        client=RESIM,
        jobs=len(fetched),
        seconds=seconds,
        requests=0,
        retries=0,
        bytes_received=0,
        peak_rss_mb=peak_rss_mb(),
        cpu_seconds=cpu_seconds() - cpu_before,
    )


def resim_available() -> bool:
    try:
        import resim.metrics.fetch_job_metrics  # noqa: F401
    except ImportError:
        return False
    return True
