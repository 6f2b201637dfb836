"""What a metrics build writes for one job or one batch, and the ground truth it wrote.

Generation is a pure function of (seed, spec): the same job always gives the same
`MetricsWriter` calls, hence the same protobuf bytes. The truth that tests compare
against is recorded alongside each call, never read back from the protobufs.
"""

from __future__ import annotations

import itertools
import math
import random
import uuid
from dataclasses import dataclass, field

from stook.emulator._config import EmulatorConfig
from stook.emulator._steps import distance_factor
from stook.emulator._world import BatchKind, BatchSpec, JobSpec
from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricHandle, MetricStatus, MetricsWriter, SeriesKind, data

# Scalar metric names the generator writes (and their units).
SCALARS: dict[str, str | None] = {
    "Localization error": "m",
    "Distance driven": "m",
    "Max speed": "m/s",
    "Collisions": None,
    "Braking distance": "m",  # rises with the job's max_speed parameter
}
# Histogram metrics every job with metrics writes, on buckets shared by all jobs (but
# those of EmulatorConfig.histogram_bucket_mismatch_jobs): name -> (values data, buckets,
# lower, upper).
HISTOGRAMS: dict[str, tuple[str, int, float, float]] = {
    "Acceleration distribution": ("accelerations", 16, -8.0, 8.0),
    "Speed histogram": ("speeds", 20, 0.0, 40.0),
}
ODD_BUCKETS = (20, -10.0, 10.0)  # "Acceleration distribution" of a mismatch job
# The per-class detections: a BAR_CHART over doubles indexed by class labels, and the same
# counts split over the run's quarters as per-category data. A class a job never saw is
# left out of its labels (only "bus" can be), so label sets differ between jobs.
OBJECT_CLASSES = ("car", "pedestrian", "cyclist", "truck", "bus")
DETECTIONS_METRIC = "Detections per class"
DETECTIONS_DATA = "detections per class"
DETECTIONS_LABELS = "object classes"
DETECTIONS_BY_CATEGORY = "detections per class (by category)"
DETECTION_WINDOWS = 4
# Events a job can write (each at most once), their tags, and the event metric each
# references (None: the event references no metric).
EVENTS: dict[str, tuple[tuple[str, ...], str | None]] = {
    "Hard brake": (("braking", "longitudinal"), "Hard brake deceleration"),
    "Lane departure": (("lateral",), None),
    "Near miss": (("longitudinal", "safety"), "Near miss distance"),
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
class HistogramTruth:
    """A HISTOGRAM metric as written: the data it bins and its buckets."""

    values_data: str
    buckets: tuple[tuple[float, float], ...]
    values: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class EventTruth:
    """One event as written: absolute timestamp in ns, API status, and the name and
    value of each event metric it references (all SCALAR)."""

    name: str
    description: str
    timestamp_ns: int
    status: str
    tags: tuple[str, ...]
    metrics: dict[str, float]


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
    # Scalars above exclude event metrics (see `events`); statuses and metric_types do not.
    parameters: dict[str, str] = field(default_factory=dict)  # the job's batch parameters
    histograms: dict[str, HistogramTruth] = field(default_factory=dict)  # by metric name
    # Doubles indexed by string labels, by data name: label -> value, in label order.
    labelled: dict[str, dict[str, float]] = field(default_factory=dict)
    # Per-category data, by data name: category -> its series.
    per_category: dict[str, dict[str, tuple[float, ...]]] = field(default_factory=dict)
    events: tuple[EventTruth, ...] = ()

    @property
    def event_scalars(self) -> dict[str, float]:
        """The event metrics' values, by metric name."""
        return {k: v for e in self.events for k, v in e.metrics.items()}


class TruthBuilder:
    """Collects a `Truth` while the generator writes; `build` adds what only the writer
    knows (statuses, metric types, data names)."""

    def __init__(self) -> None:
        self.scalars: dict[str, float] = {}
        self.series: dict[str, tuple[float, ...]] = {}
        self.units: dict[str, str] = {}
        self.parameters: dict[str, str] = {}
        self.histograms: dict[str, HistogramTruth] = {}
        self.labelled: dict[str, dict[str, float]] = {}
        self.per_category: dict[str, dict[str, tuple[float, ...]]] = {}
        self.events: list[EventTruth] = []

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
            parameters=dict(self.parameters),
            histograms=dict(self.histograms),
            labelled={k: dict(v) for k, v in self.labelled.items()},
            per_category={k: dict(v) for k, v in self.per_category.items()},
            events=tuple(self.events),
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
    truth.parameters = job.parameter_map
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
    _histogram(writer, truth, job, "Acceleration distribution", accel_data, "Acceleration (m/s^2)")
    writer.text(
        "Run notes",
        f"**{job.experience.name}**: {n} steps at {cruise:.1f} m/s cruise, top {top:.1f} m/s.",
        status=MetricStatus.RAW,
    )
    if rng.random() < 0.2 or job.index % 16 == _IMAGE_SLOT:
        writer.image("Camera snapshot", data.external_file("Camera snapshot", "camera.png"))
    # What came later draws from its own generator, so that the values above stay put.
    extra = random.Random(f"{seed}:job-extras:{job.id}")
    _histogram(writer, truth, job, "Speed histogram", speeds_data, "Speed (m/s)")
    max_speed = job.parameter_map.get("max_speed")
    # Stopping from the speed cap at about 7 m/s^2: a sweep over max_speed shows it rise.
    cap = float(max_speed) if max_speed is not None else cruise
    braking = cap * cap / 14.0 * extra.uniform(0.9, 1.1)
    _scalar(writer, truth, "Braking distance", braking, MetricStatus.RAW)
    _detections(writer, truth, extra)
    _events(writer, truth, job, extra, start_ns, accelerations, lateral)
    return WrittenMetrics(writer, truth)


def _histogram(
    writer: MetricsWriter,
    truth: TruthBuilder,
    job: JobSpec,
    name: str,
    values: data.MetricsData,
    x_axis_name: str,
) -> None:
    values_name, count, lower, upper = HISTOGRAMS[name]
    if job.odd_histogram_buckets and name == "Acceleration distribution":
        count, lower, upper = ODD_BUCKETS
    handle = writer.histogram(
        name, values, buckets=count, lower=lower, upper=upper, x_axis_name=x_axis_name
    )
    buckets = handle.proto.metric_values.histogram_metric_values.buckets
    truth.histograms[name] = HistogramTruth(
        values_name,
        tuple((b.lower, b.upper) for b in buckets),
        truth.series[values_name],
    )


def _detections(writer: MetricsWriter, truth: TruthBuilder, rng: random.Random) -> None:
    """The per-class detection counts, as a bar chart and as per-category data."""
    counts = {
        "car": rng.randint(5, 40),
        "pedestrian": rng.randint(0, 15),
        "cyclist": rng.randint(0, 8),
        "truck": rng.randint(1, 10),
        "bus": rng.randint(0, 3),
    }
    if counts["bus"] == 0:
        del counts["bus"]  # a class never seen is not a bar
    labels = list(counts)
    values = [float(counts[c]) for c in labels]
    writer.bar_chart(
        DETECTIONS_METRIC,
        data.doubles(DETECTIONS_DATA, values, index=data.strings(DETECTIONS_LABELS, labels)),
        x_axis_name="Class",
        y_axis_name="Detections",
        status=MetricStatus.RAW,
    )
    truth.labelled[DETECTIONS_DATA] = dict(zip(labels, values, strict=True))
    windows: dict[str, tuple[float, ...]] = {}
    for label, count in counts.items():
        cuts = sorted(rng.randint(0, count) for _ in range(DETECTION_WINDOWS - 1))
        edges = [0, *cuts, count]
        windows[label] = tuple(float(b - a) for a, b in itertools.pairwise(edges))
    writer.add_data(data.per_category(DETECTIONS_BY_CATEGORY, SeriesKind.DOUBLE, windows))
    truth.per_category[DETECTIONS_BY_CATEGORY] = windows


def _events(
    writer: MetricsWriter,
    truth: TruthBuilder,
    job: JobSpec,
    rng: random.Random,
    start_ns: int,
    accelerations: list[float],
    lateral: list[float],
) -> None:
    """A few events at absolute times in the run; a near miss in every failing job."""
    n = len(accelerations)
    status = job.conflated_status
    written: list[tuple[str, int, MetricStatus, str, float | None]] = []
    if rng.random() < 0.7 or job.index % 4 == 0:
        step = min(range(n), key=accelerations.__getitem__)
        decel = accelerations[step]
        # Nearly every run brakes at the clip (-8); how hard is not what a verdict judges.
        verdict = MetricStatus.FAIL_WARN if rng.random() < 0.35 else MetricStatus.PASSED
        written.append(("Hard brake", step, verdict, f"Braked at {decel:.2f} m/s^2", decel))
    if rng.random() < 0.4 or job.index % 4 == 1:
        step = max(range(n), key=lambda i: abs(lateral[i]))
        verdict = MetricStatus.FAIL_WARN if rng.random() < 0.3 else MetricStatus.PASSED
        text = f"Lateral offset reached {lateral[step]:.2f} m"
        written.append(("Lane departure", step, verdict, text, None))
    if status in ("WARNING", "BLOCKER") or rng.random() < 0.1:
        step = rng.randrange(n)
        gap = rng.uniform(0.3, 2.0)
        verdict = {"BLOCKER": MetricStatus.FAIL_BLOCK, "WARNING": MetricStatus.FAIL_WARN}.get(
            status, MetricStatus.PASSED
        )
        written.append(("Near miss", step, verdict, f"Closest gap {gap:.2f} m", gap))
    for name, step, verdict, description, value in written:
        tags, metric_name = EVENTS[name]
        metrics: list[MetricHandle] = []
        metric_values: dict[str, float] = {}
        if metric_name is not None and value is not None:
            unit = "m" if name == "Near miss" else "m/s^2"
            # RAW, so that the job's metric statuses still follow its conflated status.
            metrics.append(
                writer.scalar(metric_name, value, unit=unit, status=MetricStatus.RAW, event=True)
            )
            metric_values[metric_name] = value
        at = start_ns + step * STEP_NS
        writer.event(
            name,
            timestamp=at,
            metrics=metrics,
            status=verdict,
            description=description,
            tags=tags,
        )
        truth.events.append(EventTruth(name, description, at, verdict.name, tags, metric_values))


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
