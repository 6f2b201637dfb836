"""Decode and reduce throughput: doubles per second from MetricsData bytes to a reduction.

Two paths from protobuf bytes to a reduction:

* the public one, ``read_metrics_data(...).series()`` (polars) -> the aggregation;
* the one batch mode takes for every downloaded series (the ``fetched-`` rows): each
  job's views handed over as a `SeriesByName`, whose values the merged histogram takes
  as numpy (`SeriesByName.values_of`) without a polars Series. These rows end as a run
  does: with the waiting values binned (counts mode) or sorted into the column `finish`
  writes (exact mode, `MergedHistogram.values`).

Three shapes: job-sized series (100 payloads of 300 doubles, as the emulator's jobs
have), long-job series (100 x 3,000) and one large series (300,000 doubles), where
per-call costs vanish. Timed only with `--benchmark-enable` (`make bench`); the normal
test run executes each once, as a smoke test, and asserts no speed.

Doubles per second = `doubles` (in extra_info) x the benchmark's operations per second.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from typing import Any

import pytest

from stook.bench._decode import job_payloads
from stook.sdk._reader import read_metrics_data
from stook.sdk.aggregations import JobRecord, MergedHistogram, Scalar, SeriesByName, WeightedMean

# job-sized: the emulator's jobs; long-job: five minutes of a 10 Hz signal per job.
SHAPES = {"job-sized": (100, 300), "long-job": (100, 3_000), "large": (1, 300_000)}


def payloads(count: int, length: int) -> list[bytes]:
    # The same payloads `stook bench` times (its `decode_reduce` target).
    return job_payloads(count, length)


def histogram(counts_mode: bool) -> MergedHistogram:
    h = MergedHistogram(
        "Speeds", "speeds", 0.0, 40.0, buckets=20, max_values=10 if counts_mode else 10**9
    )
    if counts_mode:
        # One small job first, so that every measured update runs in counts mode.
        h.update(JobRecord(uuid.UUID(int=0), "PASSED", series={"speeds": read(payloads(1, 20)[0])}))
        assert h.binned
    return h


def read(payload: bytes) -> Any:
    return read_metrics_data(payload, source="bench").series()


def reduce_histogram(counts_mode: bool) -> Callable[[list[bytes]], object]:
    def run(batch: list[bytes]) -> object:
        h = histogram(counts_mode)
        for i, payload in enumerate(batch):
            h.update(JobRecord(uuid.UUID(int=i + 1), "PASSED", series={"speeds": read(payload)}))
        return h

    return run


def reduce_fetched_histogram(counts_mode: bool) -> Callable[[list[bytes]], object]:
    def run(batch: list[bytes]) -> object:
        h = histogram(counts_mode)
        for i, payload in enumerate(batch):
            view = read_metrics_data(payload, source="bench")
            series = SeriesByName({"speeds": view})
            h.update(JobRecord(uuid.UUID(int=i + 1), "PASSED", series=series))
        if counts_mode:
            return h.counts  # bins the values still waiting
        return h.values()

    return run


def reduce_weighted_mean(batch: list[bytes]) -> object:
    # Each job's series reduced to its mean, weighted by its length, across the jobs.
    agg = WeightedMean("Mean speed", "mean speed", weight="samples")
    for i, payload in enumerate(batch):
        s = read(payload)
        scalars = {"mean speed": Scalar(float(s.mean())), "samples": Scalar(float(s.len()))}
        agg.update(JobRecord(uuid.UUID(int=i + 1), "PASSED", scalars=scalars))
    return agg


REDUCERS: dict[str, Callable[[list[bytes]], object]] = {
    "histogram-exact": reduce_histogram(counts_mode=False),
    "histogram-counts": reduce_histogram(counts_mode=True),
    "weighted-mean": reduce_weighted_mean,
    "fetched-histogram-exact": reduce_fetched_histogram(counts_mode=False),
    "fetched-histogram-counts": reduce_fetched_histogram(counts_mode=True),
}


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("reducer", REDUCERS)
def test_bench_decode_reduce(benchmark: Any, shape: str, reducer: str) -> None:
    count, length = SHAPES[shape]
    batch = payloads(count, length)
    benchmark.group = f"decode + reduce, {shape}"
    benchmark.extra_info["doubles"] = count * length
    result = benchmark(REDUCERS[reducer], batch)
    assert result is not None


@pytest.mark.parametrize("shape", SHAPES)
def test_bench_decode_only(benchmark: Any, shape: str) -> None:
    count, length = SHAPES[shape]
    batch = payloads(count, length)
    benchmark.group = f"decode + reduce, {shape}"
    benchmark.extra_info["doubles"] = count * length
    total = benchmark(lambda: sum(read(p).len() for p in batch))
    assert total == count * length
