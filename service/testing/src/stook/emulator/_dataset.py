"""The emulator's data set: its world, the outputs its metrics builds wrote, the truth.

Everything derives from (seed, object key), so nothing has to be stored: `_world` lays
out the project, `_generate` writes a job's or batch's metrics on demand and `_store`
keeps the most recently used. `Dataset` is the one object the server and tests use, and
answers the ground-truth questions tests ask of a batch or a report.
"""

from __future__ import annotations

import uuid
from collections import Counter
from collections.abc import Iterator

from stook.emulator._config import EmulatorConfig
from stook.emulator._emissions import EmissionsStore, EmittedLog, Row
from stook.emulator._generate import (
    BatchMetricsPlan,
    Truth,
    batch_metrics_plan,
    generate_batch,
    no_metrics,
)
from stook.emulator._store import MetricsOutput, OutputStore
from stook.emulator._world import BatchKind, BatchSpec, JobSpec, World
from stook.proto import metrics_pb2 as pb


class Dataset(World):
    """The world, derived lazily from a config, with its jobs' and batches' outputs."""

    def __init__(self, config: EmulatorConfig) -> None:
        super().__init__(config)
        self._store = OutputStore(self)
        self._emissions = EmissionsStore(self.seed, config.emission_frames, config.cache_jobs)

    @property
    def generated_outputs(self) -> int:
        """How many job outputs were (re)generated so far."""
        return self._store.generated_jobs

    @property
    def cached_outputs(self) -> int:
        """How many generated job outputs are kept (at most `config.cache_jobs`)."""
        return self._store.cached_jobs

    # ---- job metrics ----

    def job_output(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> MetricsOutput | None:
        """A job's metrics split per object; regenerated when not in the LRU."""
        return self._store.job_output(batch_id, job_id)

    def job_metrics(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> pb.JobMetrics:
        """The whole JobMetrics message a job's metrics build would have written."""
        job = self.job(batch_id, job_id)
        if job is None:
            raise KeyError(f"no job {job_id} in batch {batch_id}")
        return self._store.write_job(job).to_proto()

    def iter_outputs(self, batch_id: uuid.UUID) -> Iterator[tuple[JobSpec, MetricsOutput]]:
        for job in self.jobs(batch_id):
            output = self.job_output(batch_id, job.id)
            assert output is not None
            yield job, output

    # ---- ground truth over a batch ----

    def scalar_values(self, batch_id: uuid.UUID) -> dict[str, dict[uuid.UUID, float]]:
        out: dict[str, dict[uuid.UUID, float]] = {}
        for job in self.jobs(batch_id):
            for name, value in self._store.job_truth(job).scalars.items():
                out.setdefault(name, {})[job.id] = value
        return out

    def series_values(self, batch_id: uuid.UUID, name: str) -> dict[uuid.UUID, list[float]]:
        out: dict[uuid.UUID, list[float]] = {}
        for job in self.jobs(batch_id):
            values = self._store.job_truth(job).series.get(name)
            if values is not None:
                out[job.id] = list(values)
        return out

    def metric_statuses(self, batch_id: uuid.UUID) -> dict[str, dict[uuid.UUID, str]]:
        out: dict[str, dict[uuid.UUID, str]] = {}
        for job in self.jobs(batch_id):
            for name, status in self._store.job_truth(job).statuses.items():
                out.setdefault(name, {})[job.id] = status
        return out

    def job_truths(self, batch_id: uuid.UUID) -> Iterator[tuple[JobSpec, Truth]]:
        """Every job of a batch with what its metrics build wrote, in job order."""
        for job in self.jobs(batch_id):
            yield job, self._store.job_truth(job)

    def event_counts(self, batch_id: uuid.UUID) -> Counter[tuple[str, str]]:
        """How many events of each (name, status) the batch's jobs wrote."""
        return Counter((e.name, e.status) for _, t in self.job_truths(batch_id) for e in t.events)

    def label_totals(self, batch_id: uuid.UUID, data_name: str) -> dict[str, float]:
        """Per label, the sum over the batch's jobs of a label-indexed doubles data (such
        as "detections per class"), labels in order of first appearance."""
        totals: dict[str, float] = {}
        for _, truth in self.job_truths(batch_id):
            for label, value in truth.labelled.get(data_name, {}).items():
                totals[label] = totals.get(label, 0.0) + value
        return totals

    def truth(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> Truth:
        job = self.job(batch_id, job_id)
        if job is None:
            raise KeyError(f"no job {job_id} in batch {batch_id}")
        return self._store.job_truth(job)

    # ---- batch metrics ----

    def batch_output(self, batch_id: uuid.UUID) -> MetricsOutput | None:
        return self._store.batch_output(batch_id)

    def batch_metrics(self, batch_id: uuid.UUID) -> pb.JobMetrics:
        batch = self._batch_index[batch_id]
        plan = self.batch_metrics_plan(batch)
        return generate_batch(self.seed, batch, self.jobs(batch_id), plan).to_proto()

    def batch_metrics_plan(self, batch: BatchSpec) -> BatchMetricsPlan:
        """What the config makes of a batch's batch metrics (only report batches vary)."""
        return batch_metrics_plan(self.config, batch)

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
            return no_metrics(batch.id).truth()
        output = self.batch_output(batch.id)
        assert output is not None
        return output.truth

    # ---- emissions (config-defined metrics) ----

    def emissions_log(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> EmittedLog | None:
        """A job's EMISSIONS_LOG as stored; None when the job uploaded none (or is unknown)."""
        job = self.job(batch_id, job_id)
        return None if job is None else self._emissions.log(job)

    def job_emissions(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> bytes | None:
        """The `emissions.resim.jsonl` a job uploaded; None when it has none."""
        log = self.emissions_log(batch_id, job_id)
        return None if log is None else log.body

    def emitted_rows(self, batch_id: uuid.UUID) -> Iterator[tuple[JobSpec, list[Row] | None]]:
        """Every job of a batch with the rows it emitted (None: no emissions log), in job
        order: the ground truth of the config-defined metrics."""
        for job in self.jobs(batch_id):
            yield job, self._emissions.rows(job)
