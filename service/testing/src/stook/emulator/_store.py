"""Generated outputs as the API and object storage serve them, kept for reuse.

A job's or batch's output is split into one `StoredMetric` per Metric and one
`StoredData` per MetricsData, each with the bytes its presigned URL serves. Batch outputs
are few and all kept; job outputs are kept in an LRU of `EmulatorConfig.cache_jobs` and
regenerated on a miss, so memory stays flat however large a batch.
"""

from __future__ import annotations

import uuid
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass, field

from google.protobuf.message import Message

from stook.emulator._baseline_pair import generate_pair_job, in_pair
from stook.emulator._generate import (
    Truth,
    WrittenMetrics,
    batch_metrics_plan,
    generate_batch,
    generate_job,
)
from stook.emulator._page_templates import PageTemplate
from stook.emulator._summaries import add_summary
from stook.emulator._world import JobSpec, World
from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricStatus


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
class StoredEvent:
    """One Event as the API lists it."""

    id: uuid.UUID
    name: str
    description: str
    timestamp_ns: int
    timestamp_type: str  # ABSOLUTE or RELATIVE
    tags: tuple[str, ...]
    status: str
    metric_ids: tuple[uuid.UUID, ...]


@dataclass(frozen=True, slots=True)
class MetricsOutput:
    """One job's (or batch's) output split into the per-object API view."""

    owner_id: uuid.UUID
    metrics: tuple[StoredMetric, ...]
    data: tuple[StoredData, ...]
    truth: Truth
    _metric_index: dict[uuid.UUID, StoredMetric] = field(repr=False)
    _data_index: dict[uuid.UUID, StoredData] = field(repr=False)
    events: tuple[StoredEvent, ...] = ()
    # The API's pages of this output's metric listings, serialized once (by the handler's
    # key: which listing, which page), kept as long as the output is.
    listing_pages: dict[tuple[str, ...], PageTemplate] = field(
        default_factory=dict, repr=False, compare=False
    )

    @property
    def event_metrics(self) -> tuple[StoredMetric, ...]:
        return tuple(m for m in self.metrics if m.event)

    @property
    def event_tags(self) -> list[str]:
        """The distinct tags of the events, sorted."""
        return sorted({t for e in self.events for t in e.tags})

    def event(self, event_id: uuid.UUID) -> StoredEvent | None:
        return next((e for e in self.events if e.id == event_id), None)

    def metric(self, metric_id: uuid.UUID) -> StoredMetric | None:
        return self._metric_index.get(metric_id)

    def data_item(self, data_id: uuid.UUID) -> StoredData | None:
        return self._data_index.get(data_id)

    @property
    def size(self) -> int:
        return sum(len(m.body) for m in self.metrics) + sum(len(d.body) for d in self.data)


class OutputStore:
    """A world's job and batch outputs, generated on first use and then looked up."""

    def __init__(self, world: World) -> None:
        self._world = world
        self._capacity = world.config.cache_jobs
        self._job_outputs: OrderedDict[uuid.UUID, MetricsOutput] = OrderedDict()
        self._batch_outputs: dict[uuid.UUID, MetricsOutput] = {}
        self.generated_jobs = 0  # how many job outputs were (re)generated

    @property
    def cached_jobs(self) -> int:
        return len(self._job_outputs)

    def write_job(self, job: JobSpec) -> WrittenMetrics:
        """A job's metrics generated afresh, counted in `generated_jobs`."""
        self.generated_jobs += 1
        batch = self._world.batch(job.batch_id)
        if batch is not None and in_pair(self._world, batch):
            return generate_pair_job(self._world, job, batch)
        return generate_job(self._world.seed, job)

    def job_output(self, batch_id: uuid.UUID, job_id: uuid.UUID) -> MetricsOutput | None:
        """A job's metrics split per object; regenerated when not in the LRU."""
        cached = self._job_outputs.get(job_id)
        if cached is not None:
            self._job_outputs.move_to_end(job_id)
            return cached
        job = self._world.job(batch_id, job_id)
        if job is None:
            return None
        output = split_output(job.id, self.write_job(job))
        self._job_outputs[job_id] = output
        if len(self._job_outputs) > self._capacity:
            self._job_outputs.popitem(last=False)
        return output

    def job_truth(self, job: JobSpec) -> Truth:
        cached = self._job_outputs.get(job.id)
        if cached is not None:
            return cached.truth
        if len(self._world.jobs(job.batch_id)) <= self._capacity:
            output = self.job_output(job.batch_id, job.id)
            assert output is not None
            return output.truth
        # A batch larger than the LRU would only flush it; generate without keeping.
        return self.write_job(job).truth()

    def batch_output(self, batch_id: uuid.UUID) -> MetricsOutput | None:
        cached = self._batch_outputs.get(batch_id)
        if cached is None:
            world = self._world
            batch = world.batch(batch_id)
            if batch is None:
                return None
            generated = generate_batch(
                world.seed, batch, world.jobs(batch_id), batch_metrics_plan(world.config, batch)
            )
            add_summary(world, self, batch, generated)
            cached = split_output(batch_id, generated)
            self._batch_outputs[batch_id] = cached
        return cached


# ---- splitting one output into API objects ----

_PNG_HEADER = b"\x89PNG\r\n\x1a\n"


def split_output(owner_id: uuid.UUID, written: WrittenMetrics) -> MetricsOutput:
    """What the API lists and object storage serves of one written output."""
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
    events = tuple(
        StoredEvent(
            id=uuid.UUID(e.event_id.id.data),
            name=e.name,
            description=e.description,
            timestamp_ns=e.timestamp.seconds * 1_000_000_000 + e.timestamp.nanos,
            timestamp_type="RELATIVE" if e.timestamp_type == pb.RELATIVE_TIMESTAMP else "ABSOLUTE",
            tags=tuple(e.tags),
            status=MetricStatus(e.status).name,
            metric_ids=tuple(uuid.UUID(m.id.data) for m in e.metrics),
        )
        for e in proto.events
    )
    return MetricsOutput(
        owner_id,
        tuple(metrics),
        tuple(stored),
        written.truth(),
        {m.id: m for m in metrics},
        {d.id: d for d in stored},
        events,
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
