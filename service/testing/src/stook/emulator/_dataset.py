"""Seeded synthetic ReSim data: a project, a main batch, a report's batches over time.

Everything derives from (seed, object key), so nothing has to be stored: a job's
metrics are regenerated on demand from (seed, batch, job index) and only the most
recently used outputs are kept. The ground truth that tests compare against is
recorded while generating, never read back from the protobufs.
"""

from __future__ import annotations

import uuid
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass, field

from google.protobuf.message import Message

from stook.emulator._config import EmulatorConfig
from stook.emulator._generate import (
    BatchMetricsPlan,
    Truth,
    WrittenMetrics,
    batch_metrics_plan,
    generate_batch,
    generate_job,
    no_metrics,
)
from stook.emulator._world import BatchKind, BatchSpec, JobSpec, World
from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricStatus, MetricType


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


class Dataset(World):
    """The emulator's world, derived lazily from a config."""

    def __init__(self, config: EmulatorConfig) -> None:
        super().__init__(config)
        self._outputs: OrderedDict[uuid.UUID, MetricsOutput] = OrderedDict()
        self._batch_outputs: dict[uuid.UUID, MetricsOutput] = {}
        self.generated_outputs = 0  # how many job outputs were (re)generated

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
        return self._write_job(job).to_proto()

    def _write_job(self, job: JobSpec) -> WrittenMetrics:
        self.generated_outputs += 1
        return generate_job(self.seed, job)

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
        return self._write_job(job).truth()

    # ---- batch metrics ----

    def batch_output(self, batch_id: uuid.UUID) -> MetricsOutput | None:
        cached = self._batch_outputs.get(batch_id)
        if cached is None:
            batch = self.batch(batch_id)
            if batch is None:
                return None
            generated = generate_batch(
                self.seed, batch, self.jobs(batch_id), self.batch_metrics_plan(batch)
            )
            cached = _split(batch_id, generated)
            self._batch_outputs[batch_id] = cached
        return cached

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


# ---- splitting one output into API objects ----

_PNG_HEADER = b"\x89PNG\r\n\x1a\n"


def _split(owner_id: uuid.UUID, written: WrittenMetrics) -> MetricsOutput:
    proto = written.to_proto()
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
        written.truth(),
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
