"""Decode + reduce throughput as batch mode reads downloaded series: doubles per second.

Each of 100 jobs' MetricsData payloads of 300 doubles (the emulator's job-sized series) is
read as a view, handed over as a `SeriesByName` and folded into an exact-mode
`MergedHistogram`, whose values are then read (`values()`), as `finish` does. The same
path as the ``fetched-histogram-exact`` row of tests/bench/test_bench_decode_reduce.py,
timed here so that `stook bench` reports the target (issue 13: >= 10 M doubles/s).
"""

from __future__ import annotations

import math
import random
import statistics
import time
import uuid
from typing import Any, Final

from stook.sdk import MetricsWriter, data, read_metrics_data
from stook.sdk.aggregations import JobRecord, MergedHistogram, SeriesByName

DECODE_TARGET: Final = 10e6  # doubles per second
JOBS: Final = 100
LENGTH: Final = 300


def job_payloads(count: int = JOBS, length: int = LENGTH) -> list[bytes]:
    """`count` serialized MetricsData of `length` doubles each (a speed-like signal)."""
    rng = random.Random(7)
    out = []
    for i in range(count):
        writer = MetricsWriter(uuid.UUID(int=i + 1), deterministic=True)
        values = [max(0.0, 18 + 6 * math.sin(k / 15) + rng.random()) for k in range(length)]
        writer.add_data(data.doubles("speeds", values, unit="m/s"))
        out.append(writer.to_proto().metrics_data[0].SerializeToString())
    return out


def decode_and_reduce(payloads: list[bytes], job_ids: list[uuid.UUID]) -> int:
    """Fold every payload into one exact-mode histogram; the values kept."""
    histogram = MergedHistogram("Speeds", "speeds", 0.0, 40.0, buckets=20, max_values=10**9)
    for job_id, payload in zip(job_ids, payloads, strict=True):
        series = SeriesByName({"speeds": read_metrics_data(payload, source="bench")})
        histogram.update(JobRecord(job_id, "PASSED", series=series))
    return len(histogram.values())


def measure_decode(rounds: int = 200) -> dict[str, Any]:
    """Median doubles per second over `rounds` timed passes (after 20 untimed ones)."""
    payloads = job_payloads()
    job_ids = [uuid.UUID(int=i + 1) for i in range(len(payloads))]
    doubles = JOBS * LENGTH
    for _ in range(20):
        decode_and_reduce(payloads, job_ids)
    seconds = []
    for _ in range(rounds):
        started = time.perf_counter()
        kept = decode_and_reduce(payloads, job_ids)
        seconds.append(time.perf_counter() - started)
    if kept != doubles:
        raise RuntimeError(f"the histogram kept {kept} of {doubles} doubles")
    median = statistics.median(seconds)
    return {
        "jobs": JOBS,
        "doubles_per_job": LENGTH,
        "rounds": rounds,
        "median_s": round(median, 6),
        "doubles_per_second": round(doubles / median),
        "best_doubles_per_second": round(doubles / min(seconds)),
    }


def decode_target(decode: dict[str, Any]) -> dict[str, Any]:
    rate = decode["doubles_per_second"]
    return {
        "decode_reduce": {
            "at": f"{JOBS} x {LENGTH} doubles as batch mode reads them, median of "
            f"{decode['rounds']}",
            "measured": round(rate / 1e6, 1),
            "target": f">= {DECODE_TARGET / 1e6:g} M doubles/s",
            "met": rate >= DECODE_TARGET,
        }
    }
