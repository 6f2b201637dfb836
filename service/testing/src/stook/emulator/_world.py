"""The emulated project's layout: experiences, builds, batches, their jobs and the report.

Every spec derives from (seed, key) alone, so equal seeds give equal worlds and nothing
has to be stored; a batch's jobs are laid out on first use. What a job's metrics build
writes is `_generate`'s business, and keeping it `_store`'s.
"""

from __future__ import annotations

import enum
import random
import uuid
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from stook.emulator._baseline_pair import baseline_batch, in_pair, pair_job
from stook.emulator._config import EmulatorConfig
from stook.emulator._steps import localization_factor, step_status

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
# A parameter sweep: each job of a main or report batch runs with one value of each, cycled
# by job index (max_speed fastest), so that every sizeable batch covers every combination.
SWEEP_PARAMETERS: dict[str, tuple[str, ...]] = {
    "max_speed": ("10", "15", "20", "25"),
    "planner_mode": ("cautious", "assertive"),
}

# A fixed job slot that makes every seed show a job without metrics (in batches of 8 or
# more jobs); `_generate` has the slots of the other cases every seed shows.
_ERROR_WITHOUT_METRICS = 6


class BatchKind(enum.StrEnum):
    MAIN = "main"  # the batch that batch mode reads
    REPORT = "report"  # one of the report's test-suite batches
    DECOY = "decoy"  # same project, but outside the report's search
    BASELINE = "baseline"  # the main batch's baseline (config.baseline_pair)


@dataclass(frozen=True, slots=True)
class ExperienceTag:
    id: uuid.UUID
    name: str
    created: datetime


@dataclass(frozen=True, slots=True)
class CustomField:
    """An experience's custom field as the API gives it: values are text whatever the type."""

    name: str
    type: str  # text, number, timestamp or json
    values: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Experience:
    id: uuid.UUID
    index: int
    name: str
    tags: tuple[ExperienceTag, ...]
    failure_rate: float  # chance of WARNING or BLOCKER at the first report batch
    drift: float  # change of that chance across the report's batches
    custom_fields: tuple[CustomField, ...] = ()


def custom_fields(index: int) -> tuple[CustomField, ...]:
    """Experience `index`'s custom fields, from its index alone (no draw of the seeded
    generators, so every other value of the world stays as it was): one of each type the
    spec lists, one field of two values, and every fifth experience without any."""
    if index % 5 == 4:
        return ()
    surveyed = BASE_TIME - timedelta(days=30 + index)
    sensors = ("lidar", "camera") if index % 2 == 0 else ("camera",)
    return (
        CustomField("Lighting", "text", (("noon", "dusk", "night")[index % 3],)),
        CustomField("Speed limit", "number", (str(30 + 10 * (index % 4)),)),
        CustomField("Sensors", "text", sensors),
        CustomField("Surveyed", "timestamp", (surveyed.isoformat().replace("+00:00", "Z"),)),
        CustomField("Road", "json", (f'{{"lanes": {1 + index % 3}}}',)),
    )


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
    # The job's batch parameters (name, value), sorted by name; () for a job run without.
    parameters: tuple[tuple[str, str], ...] = ()
    # Its "Acceleration distribution" uses other buckets than every other job's
    # (EmulatorConfig.histogram_bucket_mismatch_jobs).
    odd_histogram_buckets: bool = False
    localization_factor: float = 1.0  # see _steps.py

    @property
    def parameter_map(self) -> dict[str, str]:
        return dict(self.parameters)


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


class World:
    """The project's specs, derived lazily from a config: IDs, batches, jobs, the report."""

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
            self._id(f"experience:{i}"),
            i,
            name,
            tags,
            failure,
            rng.uniform(-0.15, 0.3),
            custom_fields(i),
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
        if (baseline := baseline_batch(self, main_created)) is not None:
            out.append(baseline)
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
        if in_pair(self, batch):
            return pair_job(self, batch, i)
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
        report_index = batch.index if batch.kind is BatchKind.REPORT else None
        conflated = step_status(self.config, report_index, experience.index, conflated)
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
            _sweep_parameters(batch, i),
            batch.kind is BatchKind.MAIN and i in self.config.histogram_bucket_mismatch_jobs,
            localization_factor(self.config, experience.index, str(batch.id))
            if report_index is not None
            else 1.0,
        )


def _sweep_parameters(batch: BatchSpec, i: int) -> tuple[tuple[str, str], ...]:
    """A job's parameters: the sweep's values for its index; none in decoy batches, which
    ran without a sweep."""
    if batch.kind is BatchKind.DECOY:
        return ()
    out: list[tuple[str, str]] = []
    stride = 1
    for name, values in SWEEP_PARAMETERS.items():
        out.append((name, values[(i // stride) % len(values)]))
        stride *= len(values)
    return tuple(sorted(out))
