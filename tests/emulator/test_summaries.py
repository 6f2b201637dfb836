"""Batch summaries in the emulator's report batches: which batches carry one, exact ones
agree with the job outputs, synthetic ones cost no job output."""

from __future__ import annotations

import pytest
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics

from stook.emulator import BatchKind, Dataset, EmulatorConfig
from stook.sdk import read_metrics_data
from stook.sdk.aggregations import SUMMARY_DATA_NAME, BatchSummary, summary_from_data


def _summary(ds: Dataset, batch_id: object) -> BatchSummary | None:
    output = ds.batch_output(batch_id)  # type: ignore[arg-type]
    assert output is not None
    found = [d for d in output.data if d.name == SUMMARY_DATA_NAME]
    return summary_from_data(read_metrics_data(found[0].body)) if found else None


def test_off_by_default() -> None:
    ds = Dataset(EmulatorConfig(report_batches=2, report_jobs_per_batch=5))
    assert all(_summary(ds, b.id) is None for b in ds.report_batches())


def test_a_bad_mode_is_refused() -> None:
    with pytest.raises(ValueError, match="batch_summaries must be"):
        EmulatorConfig(batch_summaries="sometimes")


def test_exact_summaries_agree_with_the_job_outputs() -> None:
    ds = Dataset(
        EmulatorConfig(report_batches=3, report_jobs_per_batch=12, batch_summaries="exact")
    )
    batch = ds.report_batches()[1]
    summary = _summary(ds, batch.id)
    assert summary is not None
    scalars = ds.scalar_values(batch.id)
    for job in summary.jobs:
        spec = ds.job(batch.id, job.job_id)
        assert spec is not None
        assert (job.conflated_status, job.experience_name) == (
            spec.conflated_status,
            spec.experience.name,
        )
        assert job.has_metrics == spec.has_metrics
        want = {
            name: by_job[job.job_id] for name, by_job in scalars.items() if job.job_id in by_job
        }
        assert {name: value for name, (value, _) in job.scalars.items()} == want
    msg = resim_pb.JobMetrics()
    msg.ParseFromString(ds.batch_metrics(batch.id).SerializeToString())
    validate_job_metrics(msg)  # ReSim's validator accepts the batch's output with it


def test_synthetic_summaries_generate_no_job_output() -> None:
    ds = Dataset(
        EmulatorConfig(report_batches=2, report_jobs_per_batch=300, batch_summaries="synthetic")
    )
    for batch in ds.report_batches():
        summary = _summary(ds, batch.id)
        assert summary is not None
        assert len(summary.jobs) == 300
        assert {j.job_id for j in summary.jobs} == {j.id for j in ds.jobs(batch.id)}
    assert ds.generated_outputs == 0


def test_some_batches_go_without() -> None:
    ds = Dataset(
        EmulatorConfig(
            report_batches=4,
            report_jobs_per_batch=3,
            batch_summaries="synthetic",
            report_batches_without_summary=(1,),
            report_batches_without_metrics=(2,),
        )
    )
    carried = [_summary(ds, b.id) is not None for b in ds.report_batches()]
    assert carried == [True, False, False, True]
    main = ds.batches_of(BatchKind.MAIN)[0]
    assert _summary(ds, main.id) is None  # batch mode's batch is stook's to summarise
