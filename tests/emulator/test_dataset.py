"""The seeded data set: sizes, determinism, realistic variety, and agreeing ground truth."""

from __future__ import annotations

import itertools
from collections import Counter

import aiohttp
import pytest
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics

from stook.emulator import BatchKind, Dataset, Emulator, EmulatorConfig
from tests.emulator.support import SMALL, Raw


@pytest.mark.parametrize("jobs", [0, 1, 200, 1000, 5000])
def test_any_batch_size_is_quick_to_list(jobs: int) -> None:
    ds = Dataset(EmulatorConfig(jobs_per_batch=jobs, cache_jobs=16))
    listed = ds.jobs(ds.main_batch_id)
    # Quick because listing generates no job's metrics: outputs are made on first request.
    assert ds.generated_outputs == ds.cached_outputs == 0
    assert len(listed) == jobs
    assert len({j.id for j in listed}) == jobs
    for job in (listed[:1] + listed[-1:]) if jobs else ():
        assert ds.job(ds.main_batch_id, job.id) is job
        assert ds.job_output(ds.main_batch_id, job.id) is not None
    # Only the LRU holds generated outputs, however large the batch.
    for job in listed[:40]:
        ds.job_output(ds.main_batch_id, job.id)
    assert ds.cached_outputs <= 16


async def test_an_empty_batch_lists_nothing() -> None:
    async with Emulator(SMALL.replace(jobs_per_batch=0)) as emu, aiohttp.ClientSession() as s:
        status, body = await Raw(emu, s).get(f"/batches/{emu.batch_id}/jobs")
        assert status == 200
        assert body == {"jobs": [], "nextPageToken": "", "total": 0}


def test_same_seed_same_bytes_other_seed_other_bytes() -> None:
    a, b, c = (Dataset(EmulatorConfig(seed=s)) for s in (7, 7, 8))
    for x, y in ((a, b), (a, c)):
        jx, jy = x.jobs(x.main_batch_id), y.jobs(y.main_batch_id)
        same = [
            x.job_metrics(x.main_batch_id, p.id).SerializeToString(deterministic=True)
            == y.job_metrics(y.main_batch_id, q.id).SerializeToString(deterministic=True)
            for p, q in zip(jx[:10], jy[:10], strict=True)
        ]
        assert all(same) if y is b else not any(same)


def test_variety_of_statuses_metrics_and_experiences() -> None:
    ds = Dataset(EmulatorConfig(jobs_per_batch=200))
    jobs = ds.jobs(ds.main_batch_id)
    statuses = Counter(j.conflated_status for j in jobs)
    assert statuses["PASSED"] > 100
    assert statuses["WARNING"] > 0
    assert statuses["BLOCKER"] > 0
    assert statuses["ERROR"] > 0
    assert statuses.most_common(1)[0][0] == "PASSED"
    assert {j.job_status for j in jobs} >= {"SUCCEEDED", "ERROR"}
    # 40 experiences cycled, named like "Highway merge 01".
    names = [j.experience.name for j in jobs]
    assert names[0] == "Highway merge 01"
    assert len(set(names)) == 40
    assert names[:40] == names[40:80]

    scalars = ds.scalar_values(ds.main_batch_id)
    assert set(scalars) == {
        "Localization error",
        "Distance driven",
        "Max speed",
        "Collisions",
        "Braking distance",
    }
    with_metrics = {j.id for j in jobs if j.has_metrics}
    assert set(scalars["Distance driven"]) == with_metrics
    assert set(scalars["Localization error"]) < with_metrics  # gaps
    speeds = ds.series_values(ds.main_batch_id, "speeds")
    assert all(50 <= len(v) <= 500 for v in speeds.values())
    assert len({len(v) for v in speeds.values()}) > 50
    metric_statuses = ds.metric_statuses(ds.main_batch_id)
    assert set(metric_statuses["Localization error"].values()) >= {"PASSED", "FAIL_WARN"}
    assert set(metric_statuses["Collisions"].values()) == {"PASSED", "FAIL_BLOCK"}
    images = [j for j in jobs if "Camera snapshot" in ds.truth(ds.main_batch_id, j.id).statuses]
    assert 0 < len(images) < len(jobs)


def test_job_status_agrees_with_its_metrics_and_truth_with_the_protos() -> None:
    ds = Dataset(EmulatorConfig(jobs_per_batch=60))
    for job in ds.jobs(ds.main_batch_id):
        truth = ds.truth(ds.main_batch_id, job.id)
        assert truth.overall_status == job.metrics_status
        proto = ds.job_metrics(ds.main_batch_id, job.id)
        values = {
            m.name: m.metric_values.scalar_metric_values.value
            for m in proto.job_level_metrics.metrics
            if m.metric_values.HasField("scalar_metric_values") and not m.event_metric
        }
        assert values == truth.scalars
        event_values = {
            m.name: m.metric_values.scalar_metric_values.value
            for m in proto.job_level_metrics.metrics
            if m.event_metric
        }
        assert event_values == truth.event_scalars
        assert [e.name for e in proto.events] == [e.name for e in truth.events]
        series = {d.name: list(d.series.doubles.series) for d in proto.metrics_data}
        for name, expected in truth.series.items():
            assert series[name] == list(expected)


def test_outputs_pass_resims_validator() -> None:
    ds = Dataset(EmulatorConfig(jobs_per_batch=40, report_batches=2))
    for job in ds.jobs(ds.main_batch_id):
        if job.has_metrics:
            raw = ds.job_metrics(ds.main_batch_id, job.id).SerializeToString()
            validate_job_metrics(resim_pb.JobMetrics.FromString(raw))
    for batch in ds.batches_of(BatchKind.REPORT):
        raw = ds.batch_metrics(batch.id).SerializeToString()
        validate_job_metrics(resim_pb.JobMetrics.FromString(raw))


def test_report_batches_run_the_same_experiences_over_time_with_drift() -> None:
    ds = Dataset(EmulatorConfig(report_batches=14, report_jobs_per_batch=40))
    batches = ds.report_batches()
    assert len(batches) == 14
    times = [b.created for b in batches]
    assert times == sorted(times)
    assert all(round((b - a).total_seconds() / 86400) == 1 for a, b in itertools.pairwise(times))
    experiences = {tuple(j.experience.id for j in ds.jobs(b.id)) for b in batches}
    assert len(experiences) == 1
    # Failure rates drift: early and late batches differ in their pass rates.
    rates = [ds.batch_output(b.id).truth.scalars["Pass rate"] for b in batches]  # type: ignore[union-attr]
    assert len(set(rates)) > 5
    # Decoys (other branch, or before the window) and the main batch are not found.
    kinds = {b.kind for b in batches}
    assert kinds == {BatchKind.REPORT}
    revisions = {b.test_suite_revision for b in batches}
    assert revisions == {1, 2}


def test_histograms_share_buckets_but_for_the_mismatch_jobs() -> None:
    ds = Dataset(EmulatorConfig(jobs_per_batch=20, histogram_bucket_mismatch_jobs=(3, 5)))
    buckets: dict[str, set[tuple[tuple[float, float], ...]]] = {}
    for job, truth in ds.job_truths(ds.main_batch_id):
        proto = ds.job_metrics(ds.main_batch_id, job.id)
        written = {
            m.name: m.metric_values.histogram_metric_values
            for m in proto.job_level_metrics.metrics
            if m.metric_values.HasField("histogram_metric_values")
        }
        assert set(written) == set(truth.histograms)
        for name, histogram in truth.histograms.items():
            assert [(b.lower, b.upper) for b in written[name].buckets] == list(histogram.buckets)
            assert histogram.values == truth.series[histogram.values_data]
            if job.index not in (3, 5):
                buckets.setdefault(name, set()).add(histogram.buckets)
        acceleration = truth.histograms.get("Acceleration distribution")
        if job.index in (3, 5) and acceleration is not None:
            assert len(acceleration.buckets) == 20
            assert acceleration.buckets[0][0] == -10.0
    assert {name: len(b) for name, b in buckets.items()} == {
        "Acceleration distribution": 1,
        "Speed histogram": 1,
    }
    # Only the main batch's jobs are affected.
    report = ds.batches_of(BatchKind.REPORT)[0]
    for _, truth in ds.job_truths(report.id):
        if "Acceleration distribution" in truth.histograms:
            assert len(truth.histograms["Acceleration distribution"].buckets) == 16


def test_detections_per_class_as_bars_and_per_category_agree_with_the_protos() -> None:
    ds = Dataset(EmulatorConfig(jobs_per_batch=40))
    label_sets = set()
    for job, truth in ds.job_truths(ds.main_batch_id):
        if not job.has_metrics:
            assert truth.labelled == {}
            assert truth.per_category == {}
            continue
        bars = truth.labelled["detections per class"]
        label_sets.add(tuple(bars))
        windows = truth.per_category["detections per class (by category)"]
        assert {k: sum(v) for k, v in windows.items()} == bars
        proto = ds.job_metrics(ds.main_batch_id, job.id)
        data = {d.name: d for d in proto.metrics_data}
        labels = list(data["object classes"].series.strings.series)
        values = list(data["detections per class"].series.doubles.series)
        assert dict(zip(labels, values, strict=True)) == bars
        grouped = data["detections per class (by category)"].series_per_category
        assert {
            k: tuple(v.doubles.series) for k, v in grouped.category_to_series.items()
        } == windows
        (chart,) = [m for m in proto.job_level_metrics.metrics if m.name == "Detections per class"]
        assert chart.type == resim_pb.BAR_CHART_METRIC_TYPE
    # Some jobs saw no bus: label sets differ between jobs.
    assert label_sets == {
        ("car", "pedestrian", "cyclist", "truck"),
        ("car", "pedestrian", "cyclist", "truck", "bus"),
    }
    totals = ds.label_totals(ds.main_batch_id, "detections per class")
    assert list(totals) == ["car", "pedestrian", "cyclist", "truck", "bus"]
    assert totals["car"] == sum(
        t.labelled["detections per class"]["car"]
        for _, t in ds.job_truths(ds.main_batch_id)
        if t.labelled
    )


def test_events_and_their_counts() -> None:
    ds = Dataset(EmulatorConfig(jobs_per_batch=40))
    counts = ds.event_counts(ds.main_batch_id)
    assert {name for name, _ in counts} == {"Hard brake", "Lane departure", "Near miss"}
    assert {status for _, status in counts} >= {"PASSED", "FAIL_WARN", "FAIL_BLOCK"}
    for job, truth in ds.job_truths(ds.main_batch_id):
        names = [e.name for e in truth.events]
        assert len(names) == len(set(names))
        if job.conflated_status in ("WARNING", "BLOCKER"):
            (near_miss,) = [e for e in truth.events if e.name == "Near miss"]
            assert near_miss.status == (
                "FAIL_WARN" if job.conflated_status == "WARNING" else "FAIL_BLOCK"
            )
        if not job.has_metrics:
            assert truth.events == ()
        start = int(job.created.timestamp()) * 1_000_000_000
        assert all(e.timestamp_ns >= start for e in truth.events)
    assert sum(counts.values()) == sum(len(t.events) for _, t in ds.job_truths(ds.main_batch_id))
