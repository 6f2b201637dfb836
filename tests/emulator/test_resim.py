"""Faithfulness: ReSim's own fetchers, run unchanged against the emulator, get the truth."""

from __future__ import annotations

import asyncio
import uuid
from typing import Any

import pytest
from resim.metrics.fetch_job_metrics import fetch_job_metrics_by_batch
from resim.metrics.fetch_report_metrics import fetch_batches_for_report, fetch_jobs_for_batches
from resim.metrics.python.metrics import (
    BarChartMetric,
    ExternalFileMetricsData,
    GroupedMetricsData,
    HistogramMetric,
    ScalarMetric,
    SeriesMetricsData,
)
from resim.sdk.client import AuthenticatedClient

from stook.emulator import Emulator, EmulatorConfig

# ReSim's fetcher drops these on purpose: they need external files it does not download.
_DROPPED_TYPES = {"IMAGE", "IMAGE_LIST"}


def _status_name(status: Any) -> str:
    name: str = status.name
    return name.removesuffix("_METRIC_STATUS")


async def test_resim_fetch_job_metrics_by_batch_gets_the_ground_truth() -> None:
    config = EmulatorConfig(jobs_per_batch=30, default_page_size=7, max_page_size=10)
    async with Emulator(config) as emu:
        # ReSim's fetcher blocks and starts a thread per request; keep it off the loop.
        fetched = await asyncio.to_thread(
            fetch_job_metrics_by_batch,
            token=emu.token,
            api_url=emu.api_url,
            project_id=emu.project_id,
            batch_id=emu.batch_id,
        )
        ds = emu.dataset
        jobs = ds.jobs(emu.batch_id)
        assert set(fetched) == {j.id for j in jobs}
        assert emu.stats.leaked_tokens == 0
        assert emu.stats.unauthorized == 0

        seen_types: set[str] = set()
        for job in jobs:
            truth = ds.truth(emu.batch_id, job.id)
            unpacked = fetched[job.id]
            expected = {n for n, t in truth.metric_types.items() if t not in _DROPPED_TYPES}
            assert {m.name for m in unpacked.metrics} == expected, job
            seen_types.update(truth.metric_types.values())
            for metric in unpacked.metrics:
                assert metric.id is not None
                assert _status_name(metric.status) == truth.statuses[metric.name]
                if isinstance(metric, ScalarMetric):
                    expected_value = {**truth.scalars, **truth.event_scalars}[metric.name]
                    assert metric.value == expected_value
                elif isinstance(metric, HistogramMetric):
                    histogram = truth.histograms[metric.name]
                    assert metric.buckets is not None
                    assert [(b.lower, b.upper) for b in metric.buckets] == list(histogram.buckets)
                    assert metric.values_data is not None
                    assert metric.values_data.name == histogram.values_data
                    assert isinstance(metric.values_data, SeriesMetricsData)
                    assert list(metric.values_data.series) == list(histogram.values)
                    seen_types.add("shared buckets")
                elif isinstance(metric, BarChartMetric):
                    (values,) = metric.values_data
                    assert isinstance(values, SeriesMetricsData)
                    assert values.index_data is not None
                    labelled = dict(
                        zip(list(values.index_data.series), list(values.series), strict=True)
                    )
                    assert labelled == truth.labelled[values.name]
                    seen_types.add("labelled bars")
            assert {d.name for d in unpacked.metrics_data} == (
                set(truth.data_names) - set(truth.external_data_names)
            )
            for data in unpacked.metrics_data:
                assert not isinstance(data, ExternalFileMetricsData)
                if isinstance(data, GroupedMetricsData):
                    categories = {k: list(v) for k, v in data.category_to_series.items()}
                    expected_categories = truth.per_category[data.name]
                    assert categories == {k: list(v) for k, v in expected_categories.items()}
                    seen_types.add("per category")
                if data.name in truth.series:
                    assert isinstance(data, SeriesMetricsData)
                    assert list(data.series) == list(truth.series[data.name])
            if not job.has_metrics:
                assert unpacked.metrics == []
                assert unpacked.metrics_data == []
        # The batch exercised what it should: every metric type and some gaps.
        assert {"SCALAR", "DOUBLE_OVER_TIME", "HISTOGRAM", "TEXT", "BAR_CHART"} <= seen_types
        assert {"shared buckets", "labelled bars", "per category"} <= seen_types
        assert any(not j.has_metrics for j in jobs)


@pytest.mark.parametrize("respect_revision", [False, True])
async def test_resim_report_fetch_finds_the_report_batches(respect_revision: bool) -> None:
    config = EmulatorConfig(
        jobs_per_batch=3,
        report_batches=12,
        report_jobs_per_batch=5,
        default_page_size=4,
        max_page_size=5,
        report_respect_revision_boundary=respect_revision,
    )
    async with Emulator(config) as emu:
        client = AuthenticatedClient(base_url=emu.api_url, token=emu.token)
        async with client:
            batches = await fetch_batches_for_report(
                client=client, report_id=emu.report_id, project_id=emu.project_id
            )
            expected = emu.dataset.report_batches()
            assert [uuid.UUID(b.batch_id) for b in batches] == [b.id for b in expected]
            assert len(expected) == (8 if respect_revision else 12)
            jobs = await fetch_jobs_for_batches(
                client=client, batch_ids=[b.batch_id for b in batches], project_id=emu.project_id
            )
        for batch in expected:
            listed = jobs[str(batch.id)]
            assert [uuid.UUID(j.job_id) for j in listed] == [
                j.id for j in emu.dataset.jobs(batch.id)
            ]
            # The report's batches run the same experiences.
            assert [j.experience_name for j in listed] == [
                e.name for e in emu.dataset.experiences[:5]
            ]
