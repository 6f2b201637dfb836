"""stook batch summaries in the report batches' batch metrics (`EmulatorConfig.batch_summaries`).

The summary is written by stook.sdk's `BatchSummaryWriter`, the code stook's batch mode
runs, folded from one `JobRecord` per job:

- "exact": each record is what stook's batch fetcher makes of the job as this emulator
  lists it (its listed metrics, from the job's generated output), so a report reads the
  same numbers from the summary as from the job listings;
- "synthetic": records from the job specs alone, with cheap seeded scalar values, so that
  a report of a million jobs can be served without generating a million outputs. Its
  numbers agree with nothing the job endpoints serve: for benchmarks only.

Report batches in `report_batches_without_summary`, and batches whose batch metrics
build wrote nothing, carry none (an older stook, another metrics build).
"""

from __future__ import annotations

import random
from typing import TYPE_CHECKING

from stook.emulator._generate import SCALARS, WrittenMetrics
from stook.emulator._world import BatchKind, BatchSpec, JobSpec, World
from stook.sdk.aggregations import BatchSummaryWriter, JobRecord, Scalar

if TYPE_CHECKING:
    from stook.emulator._store import OutputStore

# A synthetic job's metric statuses: its scalars', and one more (a text metric).
_SYNTHETIC_STATUSES = {
    "PASSED": "PASSED",
    "WARNING": "FAIL_WARN",
    "BLOCKER": "FAIL_BLOCK",
}


def add_summary(
    world: World, store: OutputStore, batch: BatchSpec, written: WrittenMetrics
) -> None:
    """Write the batch's summary into its batch metrics when the config says so."""
    mode = world.config.batch_summaries
    if (
        mode == "off"
        or batch.kind is not BatchKind.REPORT
        or batch.index in world.config.report_batches_without_summary
        or not written.writer.metrics  # the batch metrics build wrote nothing
    ):
        return
    summary = BatchSummaryWriter()
    for job in world.jobs(batch.id):
        summary.update(
            _exact_record(store, job) if mode == "exact" else _synthetic_record(world, job)
        )
    summary.finish(written.writer)


def _exact_record(store: OutputStore, job: JobSpec) -> JobRecord:
    output = store.job_output(job.batch_id, job.id)
    assert output is not None
    return JobRecord(
        job_id=job.id,
        conflated_status=job.conflated_status,
        experience_name=job.experience.name,
        experience_id=job.experience.id,
        scalars={
            m.name: Scalar(m.value, m.unit or "", m.status)
            for m in output.metrics
            if m.api_type == "SCALAR" and not m.event and m.name and m.value is not None
        },
        metric_statuses=[m.status for m in output.metrics],
    )


def _synthetic_record(world: World, job: JobSpec) -> JobRecord:
    if not job.has_metrics:
        return JobRecord(job.id, job.conflated_status, job.experience.name, job.experience.id)
    rng = random.Random(job.id.int ^ world.seed)
    status = _SYNTHETIC_STATUSES.get(job.conflated_status, "PASSED")
    scalars = {name: Scalar(rng.uniform(0.0, 100.0), unit or "") for name, unit in SCALARS.items()}
    return JobRecord(
        job_id=job.id,
        conflated_status=job.conflated_status,
        experience_name=job.experience.name,
        experience_id=job.experience.id,
        scalars=scalars,
        metric_statuses=[status] * (len(scalars) + 1),
    )
