"""Shared pieces of the end-to-end tests: an emulator on its own thread, the batch config
the tests use, reading and validating an output, and the expected metrics computed
independently from the emulator's ground truth."""

from __future__ import annotations

import asyncio
import itertools
import json
import math
import statistics
import threading
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

import pytest
import resim.metrics.proto.metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics

from stook.emulator import Emulator, EmulatorConfig
from stook.sdk import (
    BarChartMetric,
    HistogramMetric,
    JobMetricsView,
    MetricStatus,
    MetricView,
    read_job_metrics,
)
from stook.testing import TEST_DEFAULTS

OUTPUT_NAME = "metrics.binproto"

WEIGHTED_NAME = "Distance-weighted localization error"
HISTOGRAM_NAME = "Speeds (all jobs)"
HISTOGRAM_LOWER, HISTOGRAM_UPPER, HISTOGRAM_BUCKETS = 0.0, 40.0, 20
STATS_METRIC = "Max speed"
STATS = ("mean", "min", "max", "std", "count", "p50", "p95")

BATCH_TOML = f"""\
[[batch.weighted_mean]]
name = "{WEIGHTED_NAME}"
metric = "Localization error"
weight = "Distance driven"

[[batch.histogram]]
name = "{HISTOGRAM_NAME}"
data = "speeds"
lower = {HISTOGRAM_LOWER}
upper = {HISTOGRAM_UPPER}
buckets = {HISTOGRAM_BUCKETS}

[[batch.scalar_stats]]
metric = "{STATS_METRIC}"
stats = {json.dumps(list(STATS))}
"""

# The units the emulator's jobs write, stated here rather than read from the emulator.
UNITS = {
    "Localization error": "m",
    "Distance driven": "m",
    "Max speed": "m/s",
    "Collisions": "",
    "Braking distance": "m",
}

STATUS_RANK = {"PASSED": 0, "NOT_APPLICABLE": 0, "RAW": 0, "FAIL_WARN": 1, "FAIL_BLOCK": 2}


def config(**overrides: object) -> EmulatorConfig:
    """The testing helper's small pages, plus overrides."""
    return EmulatorConfig(**{**TEST_DEFAULTS, **overrides})


class EmulatorThread:
    """An `Emulator` served from its own event loop on a daemon thread, for synchronous
    tests that call `run_cli` (which runs `asyncio.run` itself).

    Read `emu.dataset` and `emu.stats` only while no client is running against it.
    """

    def __init__(self, emulator_config: EmulatorConfig) -> None:
        self.emulator = Emulator(emulator_config)
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(
            target=self._loop.run_forever, name="e2e-emulator", daemon=True
        )

    def __enter__(self) -> Emulator:
        self._thread.start()
        asyncio.run_coroutine_threadsafe(self.emulator.start(), self._loop).result(10)
        return self.emulator

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            asyncio.run_coroutine_threadsafe(self.emulator.close(), self._loop).result(10)
        finally:
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(10)
            self._loop.close()


def write_batch_inputs(
    inputs: Path,
    emu: Emulator,
    *,
    token: str | None = None,
    api_url: str | None = None,
    batch_id: str | None = None,
) -> Path:
    """The platform's batch_metrics_config.json, optionally with one value replaced."""
    inputs.mkdir(parents=True, exist_ok=True)
    body = {
        "authToken": token if token is not None else emu.token,
        "apiURL": api_url if api_url is not None else emu.api_url,
        "batchID": batch_id if batch_id is not None else str(emu.batch_id),
        "projectID": str(emu.project_id),
    }
    path = inputs / "batch_metrics_config.json"
    path.write_text(json.dumps(body, indent=2))
    return path


def read_output(path: Path) -> JobMetricsView:
    """Read an output, after checking it with ReSim's own validator (the oracle)."""
    payload = path.read_bytes()
    msg = rp.JobMetrics()
    msg.ParseFromString(payload)
    validate_job_metrics(msg)
    return read_job_metrics(payload, source=str(path))


def outputs_left(outputs: Path) -> list[str]:
    """Every file in the outputs folder (hidden temporary files included)."""
    if not outputs.exists():
        return []
    return sorted(p.name for p in outputs.rglob("*") if p.is_file())


# ---- reading metrics back ----


def by_name(view: JobMetricsView) -> dict[str, MetricView]:
    out: dict[str, MetricView] = {}
    for metric in view.metrics:
        assert metric.name not in out, f"two metrics named {metric.name!r}"
        out[metric.name] = metric
    return out


def histogram_values(view: JobMetricsView, metric: MetricView) -> list[float]:
    values = view.metric(metric.name, HistogramMetric).values_data
    assert values is not None
    return list(values.series().to_list())


def histogram_bounds(
    view: JobMetricsView, metric: MetricView
) -> tuple[float | None, float | None, list[tuple[float, float]]]:
    hist = view.metric(metric.name, HistogramMetric)
    return hist.lower_bound, hist.upper_bound, list(hist.buckets)


def bar_chart(view: JobMetricsView, metric: MetricView) -> dict[str, float]:
    """A one-series bar chart as {label: value}."""
    (values,) = view.metric(metric.name, BarChartMetric).values_data
    return values.by_label()


def text_of(metric: MetricView) -> str:
    return metric.raw.metric_values.text_metric_values.text


# ---- independent statistics ----


def quantile(values: Sequence[float], q: float) -> float:
    """Linear interpolation between closest ranks (NumPy's default, R's type 7)."""
    ordered = sorted(values)
    position = q * (len(ordered) - 1)
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)


def worst(statuses: Iterable[str]) -> str:
    top = max((STATUS_RANK.get(s, 0) for s in statuses), default=0)
    return {0: "PASSED", 1: "FAIL_WARN", 2: "FAIL_BLOCK"}[top]


@dataclass(frozen=True)
class Expected:
    """What a batch run must write, from the emulator's ground truth alone."""

    jobs: int
    scalars: dict[str, list[float]]  # metric -> one value per (fetched) job that has it
    weighted: dict[str, tuple[float, float]]  # job -> (x, w)
    speeds: list[float]
    job_statuses: Counter[str]
    metric_statuses: Counter[str]


def expected_from_truth(emu: Emulator, *, skip_jobs: Iterable[int] = ()) -> Expected:
    ds = emu.dataset
    batch = emu.batch_id
    skipped = {job.id for job in ds.jobs(batch) if job.index in set(skip_jobs)}
    jobs = [job for job in ds.jobs(batch) if job.id not in skipped]
    scalar_truth = ds.scalar_values(batch)
    scalars = {
        name: [v for job_id, v in per_job.items() if job_id not in skipped]
        for name, per_job in scalar_truth.items()
    }
    scalars = {name: values for name, values in scalars.items() if values}
    loc = scalar_truth.get("Localization error", {})
    dist = scalar_truth.get("Distance driven", {})
    weighted = {
        str(job_id): (loc[job_id], dist[job_id])
        for job_id in loc
        if job_id in dist and job_id not in skipped
    }
    speeds = [
        v
        for job_id, values in ds.series_values(batch, "speeds").items()
        if job_id not in skipped
        for v in values
    ]
    metric_statuses: Counter[str] = Counter()
    for per_job in ds.metric_statuses(batch).values():
        metric_statuses.update(s for job_id, s in per_job.items() if job_id not in skipped)
    return Expected(
        jobs=len(jobs),
        scalars=scalars,
        weighted=weighted,
        speeds=speeds,
        job_statuses=Counter(job.conflated_status for job in jobs),
        metric_statuses=metric_statuses,
    )


def assert_matches_truth(view: JobMetricsView, expected: Expected) -> None:
    """Every metric of a batch output (run with BATCH_TOML) against the ground truth."""
    metrics = by_name(view)
    wanted_names = {"Job statuses", "Job metric statuses", "Pass rate", WEIGHTED_NAME}
    wanted_names.add(HISTOGRAM_NAME)
    for name in expected.scalars:
        wanted_names |= {f"{name} (mean)", f"{name} (distribution)"}
    wanted_names |= {f"{STATS_METRIC} ({s})" for s in STATS if s != "mean"}
    extra = set(metrics) - wanted_names
    assert extra <= {"Missing jobs"}, f"unexpected metrics {sorted(extra)}"
    assert wanted_names <= set(metrics), f"missing metrics {sorted(wanted_names - set(metrics))}"

    # Defaults: "N (mean)" and "N (distribution)" for every scalar any job reported.
    for name, values in expected.scalars.items():
        mean = metrics[f"{name} (mean)"]
        assert mean.value == pytest.approx(math.fsum(values) / len(values), rel=1e-12), name
        assert mean.unit == UNITS[name], name
        dist = metrics[f"{name} (distribution)"]
        assert histogram_values(view, dist) == sorted(values), name
        lower, upper, buckets = histogram_bounds(view, dist)
        assert lower is not None, name
        assert upper is not None, name
        assert lower <= min(values), name
        assert upper >= max(values), name
        assert buckets, name
        assert buckets[0][0] == lower, name
        assert buckets[-1][1] == upper, name
        for (_, hi), (lo, _) in itertools.pairwise(buckets):
            assert hi == lo, f"{name}: buckets are not contiguous"

    # Weighted mean of "Localization error" by "Distance driven".
    xw = list(expected.weighted.values())
    assert len(xw) >= 2
    weighted = math.fsum(x * w for x, w in xw) / math.fsum(w for _, w in xw)
    assert metrics[WEIGHTED_NAME].value == pytest.approx(weighted, rel=1e-12)
    assert metrics[WEIGHTED_NAME].unit == "m"
    plain = math.fsum(x for x, _ in xw) / len(xw)
    assert weighted != pytest.approx(plain, rel=1e-6), "the weights made no difference"

    # Merged histogram: every job's "speeds", appended.
    merged = metrics[HISTOGRAM_NAME]
    assert histogram_values(view, merged) == sorted(expected.speeds)
    lower, upper, buckets = histogram_bounds(view, merged)
    assert (lower, upper, len(buckets)) == (HISTOGRAM_LOWER, HISTOGRAM_UPPER, HISTOGRAM_BUCKETS)

    # Scalar stats of "Max speed".
    tops = expected.scalars[STATS_METRIC]
    stats = {
        "mean": statistics.fmean(tops),
        "min": min(tops),
        "max": max(tops),
        "std": statistics.stdev(tops),
        "count": float(len(tops)),
        "p50": quantile(tops, 0.50),
        "p95": quantile(tops, 0.95),
    }
    assert stats["p50"] == pytest.approx(statistics.median(tops), rel=1e-12)
    for stat, value in stats.items():
        metric = metrics[f"{STATS_METRIC} ({stat})"]
        assert metric.value == pytest.approx(value, rel=1e-9), stat
        assert metric.unit == ("" if stat == "count" else "m/s"), stat

    # Job statuses, per status; the four main ones are shown even at zero.
    counts = bar_chart(view, metrics["Job statuses"])
    wanted_counts = {s: 0.0 for s in ("PASSED", "WARNING", "BLOCKER", "ERROR")}
    wanted_counts.update({s: float(n) for s, n in expected.job_statuses.items()})
    assert counts == wanted_counts
    assert sum(counts.values()) == expected.jobs
    job_status = metrics["Job statuses"].status
    assert isinstance(job_status, MetricStatus)
    if expected.job_statuses["BLOCKER"]:
        assert job_status.name == "FAIL_BLOCK"
    elif expected.job_statuses["WARNING"] or expected.job_statuses["ERROR"]:
        assert job_status.name == "FAIL_WARN"
    else:
        assert job_status.name == "PASSED"

    # Statuses of every metric of every job.
    metric_counts = bar_chart(view, metrics["Job metric statuses"])
    assert {k: v for k, v in metric_counts.items() if v} == {
        s: float(n) for s, n in expected.metric_statuses.items()
    }

    # Pass rate in percent.
    passed = expected.job_statuses["PASSED"]
    assert metrics["Pass rate"].value == pytest.approx(100.0 * passed / expected.jobs, rel=1e-12)
    assert metrics["Pass rate"].unit == "%"

    # The overall status follows the metrics' statuses.
    assert isinstance(view.status, MetricStatus)
    statuses = [m.status.name for m in view.metrics if isinstance(m.status, MetricStatus)]
    assert view.status.name == worst(statuses)
