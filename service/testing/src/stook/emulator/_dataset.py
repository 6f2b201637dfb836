"""Seeded synthetic ReSim data: a project, a main batch, a report's batches over time.

Everything derives from (seed, object key), so nothing has to be stored: a job's
metrics are regenerated on demand from (seed, batch, job index) and only the most
recently used outputs are kept. The ground truth that tests compare against is
recorded while generating, never read back from the protobufs.
"""

from __future__ import annotations

import enum
import math
import random
import uuid
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta

from google.protobuf.message import Message

from stook.emulator._config import EmulatorConfig
from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricStatus, MetricsWriter, MetricType, data

_NAMESPACE = uuid.UUID("0b6f0c55-3a5e-4d0e-8c77-6f1d2b9e4a10")
# Data is anchored to a fixed instant so that equal seeds give equal timestamps.
BASE_TIME = datetime(2025, 1, 6, 8, 0, tzinfo=UTC)

_SCENARIOS = (
    "Highway merge",
    "Urban intersection",
    "Roundabout entry",
    "Pedestrian crossing",
    "Night rain",
    "Parking lot",
    "Lane change",
    "Cut-in",
    "Emergency stop",
    "Construction zone",
)
_TAG_NAMES = ("highway", "urban", "night", "rain", "merge", "pedestrian", "regression")

# Scalar metric names the generator writes (and their units).
SCALARS: dict[str, str | None] = {
    "Localization error": "m",
    "Distance driven": "m",
    "Max speed": "m/s",
    "Collisions": None,
}
DOUBLE_SERIES = ("speeds", "accelerations", "Lateral offset")
STEP_NS = 100_000_000  # 10 Hz samples
# Fixed job slots that make every seed show each case: a job without metrics (index 6 of
# batches of 8 or more jobs), a missing "Localization error" and an image (per 16 jobs).
_ERROR_WITHOUT_METRICS = 6
_GAP_SLOT = 9
_IMAGE_SLOT = 4
# The report's stable batch metrics stay within this share of their level; a seeded
# regression multiplies "Mean localization error" by REGRESSION_FACTOR, past its limit.
STABLE_NOISE = 0.01
REGRESSION_FACTOR = 2.0
LOCALIZATION_LIMIT = 0.3


class BatchKind(enum.StrEnum):
    MAIN = "main"  # the batch that batch mode reads
    REPORT = "report"  # one of the report's test-suite batches
    DECOY = "decoy"  # same project, but outside the report's search


@dataclass(frozen=True, slots=True)
class ExperienceTag:
    id: uuid.UUID
    name: str
    created: datetime


@dataclass(frozen=True, slots=True)
class Experience:
    id: uuid.UUID
    index: int
    name: str
    tags: tuple[ExperienceTag, ...]
    failure_rate: float  # chance of WARNING or BLOCKER at the first report batch
    drift: float  # change of that chance across the report's batches


@dataclass(frozen=True, slots=True)
class Build:
    id: uuid.UUID
    name: str
    version: str
    branch_id: uuid.UUID
    created: datetime


@dataclass(frozen=True, slots=True)
class BatchSpec:
    id: uuid.UUID
    kind: BatchKind
    index: int  # position among batches of its kind
    friendly_name: str
    created: datetime
    job_count: int
    test_suite_id: uuid.UUID
    test_suite_revision: int
    branch_id: uuid.UUID
    build_id: uuid.UUID
    status: str  # BatchStatus spelling
    drift_position: float  # 0..1 along the report's timeline


@dataclass(frozen=True, slots=True)
class JobSpec:
    id: uuid.UUID
    batch_id: uuid.UUID
    index: int
    experience: Experience
    conflated_status: str
    job_status: str
    metrics_status: str  # what the job's metrics add up to (NO_STATUS_REPORTED: none)
    has_metrics: bool
    created: datetime
    build_id: uuid.UUID


@dataclass(frozen=True, slots=True)
class ReportSpec:
    id: uuid.UUID
    name: str
    test_suite_id: uuid.UUID
    test_suite_revision: int
    branch_id: uuid.UUID
    start: datetime
    end: datetime
    respect_revision_boundary: bool
    created: datetime


@dataclass(frozen=True, slots=True)
class StoredMetric:
    """One Metric as the API lists it, with its serialized message."""

    id: uuid.UUID
    name: str
    api_type: str  # SCALAR or COMPOSITE
    status: str
    value: float | None
    unit: str | None
    data_ids: tuple[str, ...]
    event: bool
    body: bytes


@dataclass(frozen=True, slots=True)
class StoredData:
    """One MetricsData as the API lists it, with what its presigned URL serves."""

    id: uuid.UUID
    name: str
    storage_type: str  # STANDARD or EXTERNAL_FILE
    filename: str | None
    body: bytes
    content_type: str


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


@dataclass(frozen=True, slots=True)
class MetricsOutput:
    """One job's (or batch's) output split into the per-object API view."""

    owner_id: uuid.UUID
    metrics: tuple[StoredMetric, ...]
    data: tuple[StoredData, ...]
    truth: Truth
    _metric_index: dict[uuid.UUID, StoredMetric] = field(repr=False)
    _data_index: dict[uuid.UUID, StoredData] = field(repr=False)

    def metric(self, metric_id: uuid.UUID) -> StoredMetric | None:
        return self._metric_index.get(metric_id)

    def data_item(self, data_id: uuid.UUID) -> StoredData | None:
        return self._data_index.get(data_id)

    @property
    def size(self) -> int:
        return sum(len(m.body) for m in self.metrics) + sum(len(d.body) for d in self.data)


class Dataset:
    """The emulator's world, derived lazily from a config."""

    def __init__(self, config: EmulatorConfig) -> None:
        self.config = config
        self.seed = config.seed
        self._ns = uuid.uuid5(_NAMESPACE, f"seed:{config.seed}")
        self.project_id = self._id("project")
        self.org_id = "emulated-org"
        self.user_id = self._id("user")
        self.system_id = self._id("system")
        self.test_suite_id = self._id("test-suite")
        self.branch_id = self._id("branch:main")
        self.feature_branch_id = self._id("branch:feature")
        self.metrics_build_id = self._id("metrics-build")
        self.experiences = tuple(self._make_experience(i) for i in range(config.experiences))
        self._experience_index = {e.id: e for e in self.experiences}
        self.builds: dict[uuid.UUID, Build] = {}
        self.batches: tuple[BatchSpec, ...] = self._make_batches()
        self._batch_index = {b.id: b for b in self.batches}
        self.main_batch_id = self.batches[0].id
        self.report = self._make_report()
        self.reports = {self.report.id: self.report}
        self._jobs: dict[uuid.UUID, tuple[JobSpec, ...]] = {}
        self._job_index: dict[uuid.UUID, dict[uuid.UUID, int]] = {}
        self._outputs: OrderedDict[uuid.UUID, MetricsOutput] = OrderedDict()
        self._batch_outputs: dict[uuid.UUID, MetricsOutput] = {}
        self.generated_outputs = 0  # how many job outputs were (re)generated

    # ---- identities ----

    def _id(self, key: str) -> uuid.UUID:
        return uuid.uuid5(self._ns, key)

    def _rng(self, key: str) -> random.Random:
        return random.Random(f"{self.seed}:{key}")

    # ---- the static world ----

    def _make_experience(self, i: int) -> Experience:
        rng = self._rng(f"experience:{i}")
        scenario = _SCENARIOS[i % len(_SCENARIOS)]
        name = f"{scenario} {i // len(_SCENARIOS) + 1:02d}"
        tag_names = sorted(set(rng.sample(_TAG_NAMES, rng.randint(1, 2))))
        tags = tuple(
            ExperienceTag(self._id(f"tag:{t}"), t, BASE_TIME - timedelta(days=90))
            for t in tag_names
        )
        flaky = rng.random() < 0.15
        failure = rng.uniform(0.25, 0.5) if flaky else rng.uniform(0.02, 0.2)
        return Experience(
            self._id(f"experience:{i}"), i, name, tags, failure, rng.uniform(-0.15, 0.3)
        )

    def _build(self, key: str, version: str, branch_id: uuid.UUID, created: datetime) -> uuid.UUID:
        build = Build(self._id(f"build:{key}"), f"planner {version}", version, branch_id, created)
        self.builds[build.id] = build
        return build.id

    def _make_batches(self) -> tuple[BatchSpec, ...]:
        c = self.config
        revision_cut = c.report_batches // 3  # earlier batches ran the previous revision
        latest_revision = 2 if revision_cut > 0 else 1
        out: list[BatchSpec] = []
        # A day after the last report batch, past the report's window (which ends 12 hours
        # after its last batch, or after BASE_TIME when it has none).
        main_created = BASE_TIME + timedelta(days=max(1, c.report_batches), hours=6)
        out.append(
            BatchSpec(
                self._id("batch:main"),
                BatchKind.MAIN,
                0,
                "nightly-main",
                main_created,
                c.jobs_per_batch,
                self.test_suite_id,
                latest_revision,
                self.branch_id,
                self._build("main", f"1.{c.report_batches}.0", self.branch_id, main_created),
                "BATCH_METRICS_RUNNING",
                1.0,
            )
        )
        for k in range(c.report_batches):
            rng = self._rng(f"report-batch:{k}")
            created = BASE_TIME + timedelta(days=k, minutes=rng.randint(0, 120))
            out.append(
                BatchSpec(
                    self._id(f"batch:report:{k}"),
                    BatchKind.REPORT,
                    k,
                    f"nightly-{created:%Y-%m-%d}",
                    created,
                    c.report_jobs_per_batch,
                    self.test_suite_id,
                    1 if k < revision_cut else latest_revision,
                    self.branch_id,
                    self._build(f"report:{k}", f"1.{k}.0", self.branch_id, created),
                    "SUCCEEDED",
                    k / max(1, c.report_batches - 1),
                )
            )
        for d in range(c.decoy_batches):
            # The first decoy is on the report's branch but before its window; the others
            # are on another branch inside it, so only a correct search skips them.
            if d == 0:
                created, branch = BASE_TIME - timedelta(days=3), self.branch_id
            else:
                span = max(1, c.report_batches)
                created = BASE_TIME + timedelta(days=d * span / c.decoy_batches, hours=3)
                branch = self.feature_branch_id
            out.append(
                BatchSpec(
                    self._id(f"batch:decoy:{d}"),
                    BatchKind.DECOY,
                    d,
                    f"feature-run-{d}",
                    created,
                    min(10, c.report_jobs_per_batch),
                    self.test_suite_id,
                    latest_revision,
                    branch,
                    self._build(f"decoy:{d}", f"0.{d}.0-feature", branch, created),
                    "SUCCEEDED",
                    0.5,
                )
            )
        return tuple(out)

    def _make_report(self) -> ReportSpec:
        c = self.config
        report_batches = [b for b in self.batches if b.kind is BatchKind.REPORT]
        revision = max((b.test_suite_revision for b in report_batches), default=1)
        end = BASE_TIME + timedelta(days=max(0, c.report_batches - 1), hours=12)
        return ReportSpec(
            self._id("report"),
            "Nightly regression trend",
            self.test_suite_id,
            revision,
            self.branch_id,
            BASE_TIME - timedelta(hours=1),
            end,
            c.report_respect_revision_boundary,
            end + timedelta(hours=1),
        )

    # ---- lookups ----

    def batch(self, batch_id: uuid.UUID) -> BatchSpec | None:
        return self._batch_index.get(batch_id)

    def experience(self, experience_id: uuid.UUID) -> Experience | None:
        return self._experience_index.get(experience_id)

    def batches_of(self, kind: BatchKind) -> list[BatchSpec]:
        return [b for b in self.batches if b.kind is kind]

    def report_batches(self, report_id: uuid.UUID | None = None) -> list[BatchSpec]:
        """The batches a correct report search finds, oldest first (the ground truth)."""
        report = self.reports[report_id or self.report.id]
        found = [
            b
            for b in self.batches
            if b.test_suite_id == report.test_suite_id
            and b.branch_id == report.branch_id
            and report.start < b.created < report.end
            and (
                not report.respect_revision_boundary
                or b.test_suite_revision == report.test_suite_revision
            )
        ]
        return sorted(found, key=lambda b: b.created)

    # ---- jobs ----

    def jobs(self, batch_id: uuid.UUID) -> tuple[JobSpec, ...]:
        jobs = self._jobs.get(batch_id)
        if jobs is None:
            batch = self._batch_index[batch_id]
            jobs = tuple(self._make_job(batch, i) for i in range(batch.job_count))
            self._jobs[batch_id] = jobs
            self._job_index[batch_id] = {j.id: j.index for j in jobs}
        return jobs

    def job(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> JobSpec | None:
        if batch_id not in self._batch_index:
            return None
        jobs = self.jobs(batch_id)
        index = self._job_index[batch_id].get(job_id)
        return None if index is None else jobs[index]

    def _make_job(self, batch: BatchSpec, i: int) -> JobSpec:
        rng = self._rng(f"job-spec:{batch.id}:{i}")
        experience = self.experiences[i % len(self.experiences)]
        p_fail = min(
            0.9, max(0.0, experience.failure_rate + experience.drift * batch.drift_position)
        )
        u = rng.random()
        if u < 0.01:
            conflated = "CANCELLED"
        elif u < 0.05:
            conflated = "ERROR"
        elif u < 0.05 + 0.35 * p_fail:
            conflated = "BLOCKER"
        elif u < 0.05 + p_fail:
            conflated = "WARNING"
        else:
            conflated = "PASSED"
        has_metrics = conflated != "CANCELLED" and not (conflated == "ERROR" and rng.random() < 0.6)
        if i == _ERROR_WITHOUT_METRICS and batch.job_count >= 8:
            # Every sizeable batch has a job that died before writing any metrics, so
            # that clients always meet that case whatever the seed.
            conflated, has_metrics = "ERROR", False
        job_status = {"CANCELLED": "CANCELLED", "ERROR": "ERROR"}.get(conflated, "SUCCEEDED")
        metrics_status = {
            "PASSED": "PASSED",
            "WARNING": "FAIL_WARN",
            "BLOCKER": "FAIL_BLOCK",
        }.get(conflated, "PASSED" if has_metrics else "NO_STATUS_REPORTED")
        return JobSpec(
            uuid.uuid5(self._ns, f"job:{batch.id}:{i}"),
            batch.id,
            i,
            experience,
            conflated,
            job_status,
            metrics_status,
            has_metrics,
            batch.created + timedelta(milliseconds=50 * i),
            batch.build_id,
        )

    @property
    def cached_outputs(self) -> int:
        """How many job outputs the LRU holds now (at most ``config.cache_jobs``)."""
        return len(self._outputs)

    def job_output(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> MetricsOutput | None:
        """A job's metrics split per object; regenerated when not in the LRU."""
        cached = self._outputs.get(job_id)
        if cached is not None:
            self._outputs.move_to_end(job_id)
            return cached
        job = self.job(batch_id, job_id)
        if job is None:
            return None
        output = _split(job.id, self._write_job(job))
        self._outputs[job_id] = output
        if len(self._outputs) > self.config.cache_jobs:
            self._outputs.popitem(last=False)
        return output

    def job_metrics(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> pb.JobMetrics:
        """The whole JobMetrics message a job's metrics build would have written."""
        job = self.job(batch_id, job_id)
        if job is None:
            raise KeyError(f"no job {job_id} in batch {batch_id}")
        return self._write_job(job)[0].to_proto()

    def _write_job(self, job: JobSpec) -> tuple[MetricsWriter, _TruthBuilder]:
        self.generated_outputs += 1
        return _generate_job(self.seed, job)

    def iter_outputs(self, batch_id: uuid.UUID) -> Iterator[tuple[JobSpec, MetricsOutput]]:
        for job in self.jobs(batch_id):
            output = self.job_output(batch_id, job.id)
            assert output is not None
            yield job, output

    # ---- ground truth over a batch ----

    def scalar_values(self, batch_id: uuid.UUID) -> dict[str, dict[uuid.UUID, float]]:
        out: dict[str, dict[uuid.UUID, float]] = {}
        for job in self.jobs(batch_id):
            for name, value in self._truth(job).scalars.items():
                out.setdefault(name, {})[job.id] = value
        return out

    def series_values(self, batch_id: uuid.UUID, name: str) -> dict[uuid.UUID, list[float]]:
        out: dict[uuid.UUID, list[float]] = {}
        for job in self.jobs(batch_id):
            values = self._truth(job).series.get(name)
            if values is not None:
                out[job.id] = list(values)
        return out

    def metric_statuses(self, batch_id: uuid.UUID) -> dict[str, dict[uuid.UUID, str]]:
        out: dict[str, dict[uuid.UUID, str]] = {}
        for job in self.jobs(batch_id):
            for name, status in self._truth(job).statuses.items():
                out.setdefault(name, {})[job.id] = status
        return out

    def truth(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> Truth:
        job = self.job(batch_id, job_id)
        if job is None:
            raise KeyError(f"no job {job_id} in batch {batch_id}")
        return self._truth(job)

    def _truth(self, job: JobSpec) -> Truth:
        cached = self._outputs.get(job.id)
        if cached is not None:
            return cached.truth
        if len(self.jobs(job.batch_id)) <= self.config.cache_jobs:
            output = self.job_output(job.batch_id, job.id)
            assert output is not None
            return output.truth
        # A batch larger than the LRU would only flush it; generate without keeping.
        writer, builder = self._write_job(job)
        return builder.build(writer)

    # ---- batch metrics ----

    def batch_output(self, batch_id: uuid.UUID) -> MetricsOutput | None:
        cached = self._batch_outputs.get(batch_id)
        if cached is None:
            batch = self.batch(batch_id)
            if batch is None:
                return None
            generated = _generate_batch(
                self.seed, batch, self.jobs(batch_id), self.batch_metrics_plan(batch)
            )
            cached = _split(batch_id, generated)
            self._batch_outputs[batch_id] = cached
        return cached

    def batch_metrics(self, batch_id: uuid.UUID) -> pb.JobMetrics:
        batch = self._batch_index[batch_id]
        plan = self.batch_metrics_plan(batch)
        return _generate_batch(self.seed, batch, self.jobs(batch_id), plan)[0].to_proto()

    def batch_metrics_plan(self, batch: BatchSpec) -> BatchMetricsPlan:
        """What the config makes of a batch's batch metrics (only report batches vary)."""
        c = self.config
        if batch.kind is not BatchKind.REPORT:
            return BatchMetricsPlan()
        return BatchMetricsPlan(
            with_metrics=batch.index not in c.report_batches_without_metrics,
            with_localization=batch.index not in c.report_partial_metric_batches,
            regressed=c.report_regression and batch.index == c.report_batches - 1,
        )

    # ---- ground truth over a report ----

    def report_batch_scalars(
        self, report_id: uuid.UUID | None = None
    ) -> list[tuple[BatchSpec, dict[str, tuple[float, str, str]]]]:
        """Each batch of the report, oldest first, with its SCALAR batch metrics as
        name -> (value, unit, API status); a batch without batch metrics maps to {}."""
        out: list[tuple[BatchSpec, dict[str, tuple[float, str, str]]]] = []
        for batch in self.report_batches(report_id):
            truth = self._batch_truth(batch)
            out.append(
                (
                    batch,
                    {
                        name: (value, truth.units.get(name, ""), truth.statuses[name])
                        for name, value in truth.scalars.items()
                    },
                )
            )
        return out

    def report_batch_metric_statuses(
        self, report_id: uuid.UUID | None = None
    ) -> list[tuple[BatchSpec, dict[str, str]]]:
        """Each batch of the report, oldest first, with every batch metric's API status."""
        return [(b, dict(self._batch_truth(b).statuses)) for b in self.report_batches(report_id)]

    def report_job_statuses(
        self, report_id: uuid.UUID | None = None
    ) -> list[tuple[BatchSpec, dict[str, list[str]]]]:
        """Each batch of the report, oldest first, with experience name -> the conflated
        statuses of its jobs in that batch (in job order)."""
        out: list[tuple[BatchSpec, dict[str, list[str]]]] = []
        for batch in self.report_batches(report_id):
            per_experience: dict[str, list[str]] = {}
            for job in self.jobs(batch.id):
                per_experience.setdefault(job.experience.name, []).append(job.conflated_status)
            out.append((batch, per_experience))
        return out

    def _batch_truth(self, batch: BatchSpec) -> Truth:
        if batch.kind is BatchKind.MAIN:  # its batch metrics are being computed: none yet
            return _TruthBuilder().build(MetricsWriter(batch.id, deterministic=True))
        output = self.batch_output(batch.id)
        assert output is not None
        return output.truth


# ---- generation ----


class _TruthBuilder:
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


def _generate_job(seed: int, job: JobSpec) -> tuple[MetricsWriter, _TruthBuilder]:
    writer = MetricsWriter(job.id, deterministic=True)
    truth = _TruthBuilder()
    if not job.has_metrics:
        return writer, truth
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
    return writer, truth


def _scalar(
    writer: MetricsWriter,
    truth: _TruthBuilder,
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


def _generate_batch(
    seed: int,
    batch: BatchSpec,
    jobs: tuple[JobSpec, ...],
    plan: BatchMetricsPlan,
) -> tuple[MetricsWriter, _TruthBuilder]:
    """Batch-level metrics as a batch metrics build would have written them."""
    writer = MetricsWriter(batch.id, deterministic=True)
    truth = _TruthBuilder()
    if not plan.with_metrics:
        return writer, truth
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
    return writer, truth


# ---- splitting one output into API objects ----

_PNG_HEADER = b"\x89PNG\r\n\x1a\n"


def _split(owner_id: uuid.UUID, generated: tuple[MetricsWriter, _TruthBuilder]) -> MetricsOutput:
    writer, builder = generated
    proto = writer.to_proto()
    metrics: list[StoredMetric] = []
    for m in proto.job_level_metrics.metrics:
        scalar = m.type == pb.SCALAR_METRIC_TYPE
        values = m.metric_values.scalar_metric_values
        metrics.append(
            StoredMetric(
                id=uuid.UUID(m.metric_id.id.data),
                name=m.name,
                api_type="SCALAR" if scalar else "COMPOSITE",
                status=MetricStatus(m.status).name,
                value=values.value if scalar else None,
                unit=(values.unit or None) if scalar else None,
                data_ids=tuple(_referenced_data_ids(m.metric_values)),
                event=m.event_metric,
                body=m.SerializeToString(deterministic=True),
            )
        )
    stored: list[StoredData] = []
    for d in proto.metrics_data:
        data_id = uuid.UUID(d.metrics_data_id.id.data)
        if d.data_type == pb.EXTERNAL_FILE_DATA_TYPE:
            # The platform stores the file itself; its bytes stand in for a real image.
            body = _PNG_HEADER + uuid.uuid5(data_id, "png").bytes
            stored.append(
                StoredData(
                    data_id, d.name, "EXTERNAL_FILE", d.external_file.path, body, "image/png"
                )
            )
        else:
            stored.append(
                StoredData(
                    data_id,
                    d.name,
                    "STANDARD",
                    None,
                    d.SerializeToString(deterministic=True),
                    "application/octet-stream",
                )
            )
    return MetricsOutput(
        owner_id,
        tuple(metrics),
        tuple(stored),
        builder.build(writer),
        {m.id: m for m in metrics},
        {d.id: d for d in stored},
    )


def _referenced_data_ids(message: Message) -> Iterator[str]:
    for descriptor, value in message.ListFields():
        if descriptor.message_type is None:
            continue
        items = value if descriptor.is_repeated else [value]
        for item in items:
            if isinstance(item, pb.MetricsDataId):
                yield item.id.data
            elif isinstance(item, Message):
                yield from _referenced_data_ids(item)


def metric_type_name(value: int) -> str:
    return MetricType(value).name
