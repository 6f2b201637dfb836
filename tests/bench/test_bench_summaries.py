"""`stook bench`'s batch-summaries section at its quick size: a report with summaries
costs requests per batch, the per-job fallback requests per job.

Only requests are checked: seconds and memory are measured on a quiet machine, not here.
"""

from __future__ import annotations

import pytest

from stook.bench._summaries import QUICK_FALLBACK, QUICK_SUMMARIES, run_summary_bench


@pytest.mark.slow
def test_summaries_cost_requests_per_batch_the_fallback_per_job() -> None:
    said: list[str] = []
    result = run_summary_bench(True, say=said.append)
    batches, jobs = QUICK_SUMMARIES
    summarised = result["with_summaries"]
    assert summarised["jobs"] == batches * jobs
    assert summarised["job_listings"] == 0
    # The report, the batch listing, then per batch: its metrics, its data, one download.
    assert summarised["requests"] <= 3 * batches + 5
    (fallback,) = result["fallback"]
    assert fallback["job_listings"] >= QUICK_FALLBACK[0][0] * QUICK_FALLBACK[0][1]
    extrapolated = result["fallback_extrapolated"]
    assert extrapolated["jobs"] == batches * jobs
    assert extrapolated["requests"] > batches * jobs
    assert len(said) == 5
