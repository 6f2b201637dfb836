"""`stook bench`'s fetch loads run at a small size: each load costs what its plan says, and
ReSim's fetcher (every blob of every job) is measured on the same emulator.

Only requests are checked: seconds and memory are measured on a quiet machine, not here.
"""

from __future__ import annotations

from typing import Any

import pytest

from stook.bench._fetch_loads import LOADS, fetch_load_targets, run_fetch_loads
from stook.bench._measure import resim_available


@pytest.mark.slow
def test_the_fetch_loads_run_and_cost_what_their_plans_say() -> None:
    said: list[str] = []
    result = run_fetch_loads(6, 0.0, concurrency=8, isolate=False, say=said.append)
    rows = {row["client"]: row for row in result["rows"]}
    loads = [rows[f"stook {load}"] for load in LOADS]
    assert all(row["jobs"] == 6 for row in loads)
    defaults, histogram, every = (row["requests"] for row in loads)
    # Listings only; then one metric blob and its data per job on top; then every blob.
    assert defaults < histogram < every
    assert len(said) == len(result["rows"])
    if resim_available():
        resim = rows["resim fetch_job_metrics_by_batch"]
        assert resim["jobs"] == 6
        assert every <= resim["requests"]
        assert set(result["targets"]) == {f"fetch {load} vs resim" for load in LOADS}


def test_targets_compare_each_load_with_resim() -> None:
    def row(client: str, seconds: float) -> dict[str, Any]:
        return {
            "client": client,
            "jobs": 1000,
            "seconds": seconds,
            "requests": 10,
            "peak_rss_mb": 1.0,
        }

    rows = [
        row("stook defaults", 0.5),
        row("stook histogram metric", 1.0),
        row("stook every metric", 4.0),
        row("resim fetch_job_metrics_by_batch", 16.0),
    ]
    targets = fetch_load_targets(rows)
    assert targets["fetch histogram metric vs resim"]["measured"] == 16.0
    assert targets["fetch histogram metric vs resim"]["met"]
    assert targets["fetch every metric vs resim"]["measured"] == 4.0
    assert not targets["fetch every metric vs resim"]["met"]  # 4x, under the 5x target
    assert fetch_load_targets(rows[:3]) == {}
