"""What a metrics build writes for one job or one batch, and the ground truth it wrote.

Generation is a pure function of (seed, spec): the same job always gives the same
`MetricsWriter` calls, hence the same protobuf bytes. The truth that tests compare
against is recorded alongside each call, never read back from the protobufs.
"""

from __future__ import annotations

import math
import random
import uuid
from dataclasses import dataclass, field

from stook.emulator._config import EmulatorConfig
from stook.emulator._steps import distance_factor
from stook.emulator._world import BatchKind, BatchSpec, JobSpec
from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricStatus, MetricsWriter, data

# Scalar metric names the generator writes (and their units).
SCALARS: dict[str, str | None] = {
    "Localization error": "m",
    "Distance driven": "m",
    "Max speed": "m/s",
    "Collisions": None,
}
DOUBLE_SERIES = ("speeds", "accelerations", "Lateral offset")
STEP_NS = 100_000_000  # 10 Hz samples
# Fixed job slots (per 16 jobs) that make every seed show a missing "Localization error"
# and an image; `_world` has the slot of a job without metrics.
_GAP_SLOT = 9
_IMAGE_SLOT = 4
# The report's stable batch metrics stay within this share of their level; a seeded
# regression multiplies "Mean localization error" by REGRESSION_FACTOR, past its limit.
STABLE_NOISE = 0.01
REGRESSION_FACTOR = 2.0
LOCALIZATION_LIMIT = 0.3


@dataclass(frozen=True, slots=True)
class Truth:
    """What the generator wrote, independent of any protobuf."""

    scalars: dict[str, float]
    series: dict[str, tuple[float, ...]]
    statuses: dict[str, str]  # metric name -> API status
    metric_types: dict[str, str]  # metric name -> proto MetricType name (SCALAR, IMAGE, ...)
    data_names: tuple[str, ...]
    external_data_names: tuple[str, ...]
    overall_status: str
    units: dict[str, str] = field(default_factory=dict)  # scalar name -> unit ("" for none)


class TruthBuilder:
    """Collects a `Truth` while the generator writes; `build` adds what only the writer
    knows (statuses, metric types, data names)."""

    def __init__(self) -> None:
        self.scalars: dict[str, float] = {}
        self.series: dict[str, tuple[float, ...]] = {}
        self.units: dict[str, str] = {}

    def build(self, writer: MetricsWriter) -> Truth:
        metrics = writer.metrics
        return Truth(
            scalars=dict(self.scalars),
            series=dict(self.series),
            statuses={m.name: MetricStatus(m.proto.status).name for m in metrics},
            metric_types={m.name: m.type.name for m in metrics},
            data_names=tuple(d.name for d in writer.data),
            external_data_names=tuple(d.name for d in writer.data if d.external_path is not None),
            overall_status=writer.status.name if metrics else "NO_STATUS_REPORTED",
            units=dict(self.units),
        )


@dataclass(frozen=True, slots=True)
class WrittenMetrics:
    """One job's (or batch's) metrics as its build wrote them, and the truth recorded."""

    writer: MetricsWriter
    recorded: TruthBuilder

    def to_proto(self) -> pb.JobMetrics:
        return self.writer.to_proto()

    def truth(self) -> Truth:
        return self.recorded.build(self.writer)


def no_metrics(owner_id: uuid.UUID) -> WrittenMetrics:
    """What a job or batch that wrote nothing amounts to."""
    return WrittenMetrics(MetricsWriter(owner_id, deterministic=True), TruthBuilder())


def generate_job(seed: int, job: JobSpec) -> WrittenMetrics:
    """A job's metrics as its metrics build would have written them."""
    writer = MetricsWriter(job.id, deterministic=True)
    truth = TruthBuilder()
    if not job.has_metrics:
        return WrittenMetrics(writer, truth)
    rng = random.Random(f"{seed}:job-metrics:{job.id}")
    status = job.conflated_status
    n = rng.randint(50, 500)
    dt = STEP_NS / 1e9
    cruise = rng.uniform(8.0, 28.0)
    phase = rng.uniform(0.0, math.tau)
    # Noise from uniform draws: rng.gauss costs ~20x more and thousands run per job.
    noise = rng.random
    speeds = [
        max(0.0, cruise + 3.0 * math.sin(i / 15.0 + phase) + 0.8 * (noise() - 0.5))
        for i in range(n)
    ]
    accelerations = [
        max(-8.0, min(8.0, (speeds[min(i + 1, n - 1)] - speeds[i]) / dt)) for i in range(n)
    ]
    lateral = [0.3 * math.sin(i / 40.0 + phase) + 0.1 * (noise() - 0.5) for i in range(n)]
    start_ns = int(job.created.timestamp()) * 1_000_000_000
    times = data.timestamps("timestamps", [start_ns + i * STEP_NS for i in range(n)])

    speeds_data = data.doubles("speeds", speeds, unit="m/s")
    accel_data = data.doubles("accelerations", accelerations, unit="m/s^2")
    lateral_data = data.doubles("Lateral offset", lateral, unit="m", index=times)
    writer.add_data(speeds_data)
    truth.series = {
        "speeds": tuple(speeds),
        "accelerations": tuple(accelerations),
        "Lateral offset": tuple(lateral),
    }

    # Metric statuses follow the job's conflated status, so that what the job list says
    # and what its metrics add up to agree.
    warn = status == "WARNING"
    block = status == "BLOCKER"
    # Occasionally missing (always in a fixed slot): gaps are part of real data.
    if rng.random() >= 0.05 and job.index % 16 != _GAP_SLOT:
        if warn or (block and rng.random() < 0.5):
            loc_error, loc_status = rng.uniform(0.4, 0.8), MetricStatus.FAIL_WARN
        else:
            loc_error = abs(rng.gauss(0.12, 0.04))
            na = rng.random() < 0.03
            loc_status = MetricStatus.NOT_APPLICABLE if na else MetricStatus.PASSED
        loc_error *= job.localization_factor
        _scalar(writer, truth, "Localization error", loc_error, loc_status)
    _scalar(writer, truth, "Distance driven", sum(speeds) * dt, MetricStatus.RAW)
    top = max(speeds)
    _scalar(writer, truth, "Max speed", top, MetricStatus.PASSED)
    collisions = float(rng.randint(1, 3)) if block else 0.0
    _scalar(
        writer,
        truth,
        "Collisions",
        collisions,
        MetricStatus.FAIL_BLOCK if block else MetricStatus.PASSED,
        blocking=True,
    )
    writer.double_over_time("Lateral offset over time", lateral_data, y_axis_name="Offset (m)")
    writer.histogram(
        "Acceleration distribution",
        accel_data,
        buckets=16,
        lower=-8.0,
        upper=8.0,
        x_axis_name="Acceleration (m/s^2)",
    )
    writer.text(
        "Run notes",
        f"**{job.experience.name}**: {n} steps at {cruise:.1f} m/s cruise, top {top:.1f} m/s.",
        status=MetricStatus.RAW,
    )
    if rng.random() < 0.2 or job.index % 16 == _IMAGE_SLOT:
        writer.image("Camera snapshot", data.external_file("Camera snapshot", "camera.png"))
    return WrittenMetrics(writer, truth)


def _scalar(
    writer: MetricsWriter,
    truth: TruthBuilder,
    name: str,
    value: float,
    status: MetricStatus,
    *,
    blocking: bool = False,
) -> None:
    writer.scalar(name, value, unit=SCALARS[name], status=status, blocking=blocking)
    truth.scalars[name] = value
    truth.units[name] = SCALARS[name] or ""


@dataclass(frozen=True, slots=True)
class BatchMetricsPlan:
    """How one batch's batch metrics deviate from the usual: none at all, a gap in
    "Mean localization error", or that metric at `REGRESSION_FACTOR` times its level."""

    with_metrics: bool = True
    with_localization: bool = True
    regressed: bool = False
    distance_factor: float = 1.0  # a step change (see _steps.py)


def batch_metrics_plan(config: EmulatorConfig, batch: BatchSpec) -> BatchMetricsPlan:
    """What the config makes of a batch's batch metrics (only report batches vary)."""
    c = config
    if batch.kind is not BatchKind.REPORT:
        return BatchMetricsPlan()
    return BatchMetricsPlan(
        with_metrics=batch.index not in c.report_batches_without_metrics,
        with_localization=batch.index not in c.report_partial_metric_batches,
        regressed=c.report_regression and batch.index == c.report_batches - 1,
        distance_factor=distance_factor(c, batch.index),
    )


def generate_batch(
    seed: int,
    batch: BatchSpec,
    jobs: tuple[JobSpec, ...],
    plan: BatchMetricsPlan,
) -> WrittenMetrics:
    """Batch-level metrics as a batch metrics build would have written them."""
    writer = MetricsWriter(batch.id, deterministic=True)
    truth = TruthBuilder()
    if not plan.with_metrics:
        return WrittenMetrics(writer, truth)
    counted = [j for j in jobs if j.conflated_status != "CANCELLED"]
    failed = sum(j.conflated_status in ("WARNING", "BLOCKER", "ERROR") for j in counted)
    errors = sum(j.conflated_status == "ERROR" for j in counted)
    writer.scalar("Failed tests", failed, status=MetricStatus.RAW)
    writer.scalar("Errored tests", errors, status=MetricStatus.RAW)
    truth.scalars = {"Failed tests": float(failed), "Errored tests": float(errors)}
    truth.units = {"Failed tests": "", "Errored tests": ""}
    # Two stable series: within STABLE_NOISE of a level fixed by the seed, so that the 2%
    # floor of the regression check keeps them unflagged; one of them can jump.
    levels = random.Random(f"{seed}:batch-metric-levels")
    loc_level = levels.uniform(0.18, 0.22)
    distance_level = levels.uniform(1200.0, 1800.0)
    rng = random.Random(f"{seed}:batch-metrics:{batch.id}")
    loc = loc_level * (1.0 + rng.uniform(-STABLE_NOISE, STABLE_NOISE))
    distance = distance_level * (1.0 + rng.uniform(-STABLE_NOISE, STABLE_NOISE))
    if plan.regressed:
        loc *= REGRESSION_FACTOR
    distance *= plan.distance_factor
    if plan.with_localization:
        writer.scalar("Mean localization error", loc, unit="m", fails_above=LOCALIZATION_LIMIT)
        truth.scalars["Mean localization error"] = loc
        truth.units["Mean localization error"] = "m"
    writer.scalar("Mean distance driven", distance, unit="m", status=MetricStatus.RAW)
    truth.scalars["Mean distance driven"] = distance
    truth.units["Mean distance driven"] = "m"
    if counted:
        pass_rate = 100.0 * sum(j.conflated_status == "PASSED" for j in counted) / len(counted)
        writer.scalar("Pass rate", pass_rate, unit="%", fails_below=80.0)
        truth.scalars["Pass rate"] = pass_rate
        truth.units["Pass rate"] = "%"
        per_experience: dict[str, list[bool]] = {}
        for j in counted:
            per_experience.setdefault(j.experience.name, []).append(j.conflated_status == "PASSED")
        names = sorted(per_experience)
        rates = [100.0 * sum(per_experience[n]) / len(per_experience[n]) for n in names]
        labels = data.strings("Experience names", names)
        writer.bar_chart(
            "Pass rate by experience",
            data.doubles("Pass rate by experience", rates, unit="%", index=labels),
            y_axis_name="Pass rate (%)",
        )
        truth.series = {"Pass rate by experience": tuple(rates)}
    writer.text("Batch summary", f"{len(jobs)} tests, {failed} failed, {errors} errored.")
    return WrittenMetrics(writer, truth)
