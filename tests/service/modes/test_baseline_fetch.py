"""ComparedFetcher: the baseline's jobs come in while the batch's own still do, on one
client, and feed the comparison's baseline side only."""

from __future__ import annotations

import uuid

from stook.emulator import BatchKind, Emulator
from stook.sdk.aggregations import JobRecord, Needs
from stook.service.api import ApiClient
from stook.service.modes._baseline import BaselineSettings, ComparedFetcher
from stook.testing import emulator_config


async def test_both_batches_are_fetched_together_on_one_client() -> None:
    config = emulator_config(
        baseline_pair=True, jobs_per_batch=24, report_batches=2, latency_ms=2.0
    )
    async with Emulator(config) as emu:
        settings = BaselineSettings(previous=True)
        comparison = settings.comparison()
        arrivals: list[str] = []
        fold_baseline = comparison.update_baseline

        def baseline_job(job: JobRecord) -> None:
            arrivals.append("baseline")
            fold_baseline(job)

        comparison.update_baseline = baseline_job  # type: ignore[method-assign]
        candidate_ids: list[uuid.UUID] = []

        def candidate_job(job: JobRecord) -> None:
            arrivals.append("candidate")
            candidate_ids.append(job.job_id)
            comparison.update(job)

        # Two requests in flight for both fetches together: they must share them.
        async with ApiClient(emu.api_url, emu.token, concurrency=2, page_size=10) as api:
            fetcher = ComparedFetcher(
                api,
                emu.project_id,
                emu.batch_id,
                Needs(every_scalar=True),
                comparison,
                settings,
                workers=2,
            )
            outcome = await fetcher.run(candidate_job)
            shared = api.limiter.stats
        assert shared.limit == 2
        assert shared.waits > 0  # the two fetches queued for the same two slots
        assert emu.stats.peak_in_latency["api"] <= 2
        baseline = emu.dataset.batches_of(BatchKind.BASELINE)[0]
    assert outcome is fetcher.outcome
    assert outcome.jobs_done == 24
    assert set(candidate_ids) == {j.id for j in emu.dataset.jobs(emu.batch_id)}
    assert arrivals.count("baseline") == 24
    # Interleaved, not one after the other.
    first_baseline = arrivals.index("baseline")
    last_candidate = len(arrivals) - 1 - arrivals[::-1].index("candidate")
    assert first_baseline < last_candidate, arrivals
    assert comparison.found is not None
    assert comparison.found.batch_id == baseline.id
    assert comparison.baseline.jobs == comparison.candidate.jobs == 24
    assert comparison.directions["Localization error"] == "lower"
    assert comparison.directions["Max speed"] is None


async def test_without_a_baseline_only_the_batch_is_fetched() -> None:
    async with Emulator(
        emulator_config(jobs_per_batch=6, report_batches=0, decoy_batches=0)
    ) as emu:
        settings = BaselineSettings(branch="feature/planner-tuning")
        comparison = settings.comparison()
        async with ApiClient(emu.api_url, emu.token, page_size=10) as api:
            fetcher = ComparedFetcher(
                api,
                emu.project_id,
                emu.batch_id,
                Needs(every_scalar=True),
                comparison,
                settings,
                workers=4,
            )
            await fetcher.run(comparison.update)
        listed_jobs = emu.stats.endpoints["api:list_jobs"]
    assert comparison.found is None
    assert "no finished batch" in comparison.not_found
    assert comparison.baseline.jobs == 0
    assert comparison.directions == {}  # no probe without a baseline
    assert listed_jobs == 1  # the batch's own listing only
