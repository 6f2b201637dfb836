"""The emulator's knobs, in one frozen dataclass that crosses process boundaries."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Literal

Origin = Literal["api", "storage"]
ORIGINS: tuple[Origin, ...] = ("api", "storage")


@dataclass(frozen=True, slots=True)
class Outage:
    """A window in which one origin answers 503 to everything, as a load balancer does when
    the service behind it is down.

    It begins with the first request to `origin` that arrives once `after_requests`
    requests to it have been answered and `after_s` seconds have passed since the emulator
    started, and lasts `duration_s` seconds of wall time.
    """

    origin: Origin
    duration_s: float
    after_requests: int = 0
    after_s: float = 0.0

    def __post_init__(self) -> None:
        if self.origin not in ORIGINS:
            raise ValueError(f"an outage's origin must be one of {ORIGINS}, got {self.origin!r}")
        if self.duration_s <= 0:
            raise ValueError("an outage's duration_s must be positive")
        if self.after_requests < 0 or self.after_s < 0:
            raise ValueError("an outage's after_requests and after_s cannot be negative")


@dataclass(frozen=True, slots=True)
class EmulatorConfig:
    """What the emulated ReSim serves and how badly it behaves.

    Every random choice (data, faults, jitter) derives from `seed`, so two emulators with
    equal configs answer equal requests with equal bytes.
    """

    seed: int = 0
    token: str = "stook-emulator-token"

    # ---- the data set ----
    jobs_per_batch: int = 30  # jobs of the main batch (the one batch mode reads)
    experiences: int = 40  # distinct experiences, cycled across jobs
    report_batches: int = 12  # batches of the report's test suite, one a day
    report_jobs_per_batch: int = 40
    decoy_batches: int = 3  # batches on another branch, inside the report window
    report_respect_revision_boundary: bool = False
    # The latest report batch's "Mean localization error" jumps to twice its usual level
    # (a seeded regression); "Mean distance driven" always stays within 1% of its level.
    report_regression: bool = True
    # Indices (creation order, from 0) of report batches that list no batch metrics at all,
    # and of report batches whose batch metrics lack "Mean localization error" (gaps).
    report_batches_without_metrics: tuple[int, ...] = ()
    report_partial_metric_batches: tuple[int, ...] = ()
    # From this report batch on, a step change: see _steps.py. None: no step.
    report_step_change_batch: int | None = None
    # Indices of experiences whose localization error varies wildly (see _steps.py).
    report_unstable_experiences: tuple[int, ...] = ()
    # A finished baseline batch for batch mode's comparison (see _baseline_pair.py): these
    # experiences (indices) pass there and fail in the main batch, and the main batch's
    # `baseline_shift_metric` is (1 + baseline_shift) times the baseline's.
    baseline_pair: bool = False
    baseline_regressed_experiences: tuple[int, ...] = ()
    baseline_shift_metric: str = "Localization error"
    baseline_shift: float = 0.0
    cache_jobs: int = 256  # generated job outputs kept (an LRU); the rest is regenerated
    # Frames each job emits to its emissions log (two rows a frame, plus a few; see
    # _emissions.py): 500 gives the thousand rows a job of the benchmarks emits.
    emission_frames: int = 40
    # stook batch summaries in the report batches' batch metrics data (see _summaries.py):
    # "off"; "exact", built from every job's generated metrics as stook's batch mode
    # would; "synthetic", from the job specs alone with cheap values (benchmarks of a
    # million jobs: the job endpoints do not agree with it). Report batches (indices)
    # in report_batches_without_summary have none, as if written by another build.
    batch_summaries: str = "off"
    report_batches_without_summary: tuple[int, ...] = ()
    # The metrics set every batch was launched with (its `metricsSetName`; None: none).
    metrics_set_name: str | None = None
    # Indices of experiences the API no longer has: their GET and tag listing answer 404
    # (their jobs still name them), as after an experience was deleted.
    missing_experiences: tuple[int, ...] = ()

    # ---- answers the API spec allows (see _quirks.py) ----
    # Everything at once that changes no correct client's output: empty fields left out,
    # scalar values listed as null (kept in the Metric message), enum values the spec does
    # not list yet, unnamed metrics data, nine-digit fractional timestamps.
    spec_quirks: bool = False
    # Indices of jobs (in every batch) listed with a conflated status and metric statuses
    # the spec does not list yet, and of jobs listed without either.
    future_status_jobs: tuple[int, ...] = ()
    unreported_status_jobs: tuple[int, ...] = ()

    # ---- paging ----
    default_page_size: int = 25
    max_page_size: int = 100

    # ---- presigned URLs ----
    url_lifetime_s: float = 3600.0

    # ---- latency and faults (both origins unless fault_origins says otherwise) ----
    latency_ms: float = 0.0
    latency_jitter_ms: float = 0.0
    fault_5xx: float = 0.0
    fault_429: float = 0.0
    fault_reset: float = 0.0
    fault_truncate: float = 0.0
    fault_origins: tuple[Origin, ...] = ORIGINS
    retry_after_max_s: int = 1  # a fault 429 carries Retry-After 0..this (whole seconds)
    max_consecutive_faults: int = 2  # the same request never faults more often in a row
    # Indices of main-batch jobs whose metrics, metrics-data and event listings always
    # answer 500: permanent, unlike the faults above, so a client exhausts its retries.
    broken_jobs: tuple[int, ...] = ()
    # Whole-origin outages (503 to everything for a while); see Outage.
    outages: tuple[Outage, ...] = ()
    # Indices of main-batch jobs whose metrics-data blobs are garbage (not a MetricsData
    # message), every time: a client that downloads one must fail with invalid data.
    corrupt_data_jobs: tuple[int, ...] = ()
    # Indices of main-batch jobs whose "Acceleration distribution" histogram uses other
    # buckets than the rest (20 over -10..10 instead of 16 over -8..8): a client merging
    # the jobs' histograms must refuse, naming two jobs.
    histogram_bucket_mismatch_jobs: tuple[int, ...] = ()
    # After this many API requests the token counts as expired: every later API request is
    # answered 401, as when a platform token runs out mid-run. None: it never expires.
    revoke_token_after_requests: int | None = None

    # ---- rate limits (token buckets; None: unlimited) ----
    rate_limit_rps: float | None = None  # API origin
    rate_limit_burst: int | None = None  # default: max(1, rate)
    storage_rate_limit_rps: float | None = None
    storage_rate_limit_burst: int | None = None
    # Requests both origins answer at once (a server's capacity); beyond it a request is
    # answered 429 with Retry-After at once, as a gateway's concurrency limit does. None:
    # unlimited. `stook bench --probe` is tested against it.
    max_in_flight: int | None = None

    def __post_init__(self) -> None:
        fractions = (self.fault_5xx, self.fault_429, self.fault_reset, self.fault_truncate)
        if any(not 0.0 <= f <= 1.0 for f in fractions) or sum(fractions) > 1.0:
            raise ValueError("fault fractions must lie in [0, 1] and sum to at most 1")
        for name in ("jobs_per_batch", "report_batches", "report_jobs_per_batch", "decoy_batches"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} cannot be negative")
        if self.experiences < 1:
            raise ValueError("experiences must be at least 1")
        if not 1 <= self.default_page_size <= self.max_page_size:
            raise ValueError("need 1 <= default_page_size <= max_page_size")
        if self.url_lifetime_s <= 0:
            raise ValueError("url_lifetime_s must be positive")
        if self.latency_ms < 0 or self.latency_jitter_ms < 0:
            raise ValueError("latencies cannot be negative")
        if self.max_consecutive_faults < 0 or self.retry_after_max_s < 0:
            raise ValueError("max_consecutive_faults and retry_after_max_s cannot be negative")
        if self.cache_jobs < 1:
            raise ValueError("cache_jobs must be at least 1")
        if isinstance(self.emission_frames, bool) or self.emission_frames < 0:
            raise ValueError("emission_frames cannot be negative")
        if self.batch_summaries not in ("off", "exact", "synthetic"):
            raise ValueError("batch_summaries must be 'off', 'exact' or 'synthetic'")
        for rate in (self.rate_limit_rps, self.storage_rate_limit_rps):
            if rate is not None and rate <= 0:
                raise ValueError("a rate limit must be positive (or None)")
        if self.max_in_flight is not None and self.max_in_flight < 1:
            raise ValueError("max_in_flight must be at least 1 (or None)")
        if any(o not in ORIGINS for o in self.fault_origins):
            raise ValueError(f"fault_origins must be drawn from {ORIGINS}")
        step = self.report_step_change_batch
        if step is not None and (isinstance(step, bool) or not isinstance(step, int) or step < 0):
            raise ValueError("report_step_change_batch must be a batch index (from 0) or None")
        if self.revoke_token_after_requests is not None and self.revoke_token_after_requests < 0:
            raise ValueError("revoke_token_after_requests cannot be negative")
        for name in (
            "broken_jobs",
            "corrupt_data_jobs",
            "histogram_bucket_mismatch_jobs",
            "report_batches_without_metrics",
            "report_partial_metric_batches",
            "future_status_jobs",
            "unreported_status_jobs",
            "report_unstable_experiences",
            "baseline_regressed_experiences",
            "report_batches_without_summary",
            "missing_experiences",
        ):
            indices = getattr(self, name)
            if any(isinstance(i, bool) or not isinstance(i, int) or i < 0 for i in indices):
                raise ValueError(f"{name} must hold indices (whole numbers from 0)")

    @property
    def fault_total(self) -> float:
        return self.fault_5xx + self.fault_429 + self.fault_reset + self.fault_truncate

    def replace(self, **changes: Any) -> EmulatorConfig:
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> EmulatorConfig:
        """Settings by name (JSON-like values: lists for tuples, dicts for outages), each
        checked against its field's type; ValueError naming the setting at fault."""
        import msgspec

        known = {f.name for f in dataclasses.fields(cls)}
        unknown = set(values) - known
        if unknown:
            raise ValueError(f"unknown emulator settings: {sorted(unknown)}")
        plain = dict(values)
        if "outages" in plain:
            plain["outages"] = [
                dataclasses.asdict(o) if isinstance(o, Outage) else o for o in plain["outages"]
            ]
        try:
            return msgspec.convert(plain, cls)
        except msgspec.ValidationError as exc:
            # "Expected `float`, got `str` - at `$.fault_5xx`" -> "fault_5xx: expected ..."
            text, _, where = str(exc).partition(" - at ")
            name = where.strip("`").removeprefix("$.")
            text = text.replace("`", "")
            raise ValueError(f"{name}: {text[:1].lower()}{text[1:]}" if name else text) from None
