"""Comparing checkouts: each run imports the checkout it names, not the installed stook.

Seconds are measured on a quiet machine, not here.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from stook.bench._checkouts import compare_checkouts, compare_whole_processes, source_path

ROOT = Path(__file__).resolve().parents[2]


def test_a_checkouts_sources_come_first() -> None:
    assert source_path(ROOT).split(":")[0] == str(ROOT / "proto" / "src")


@pytest.mark.slow
def test_each_round_runs_the_checkout_and_counts_its_cpu() -> None:
    result = compare_checkouts([ROOT], rounds=2, jobs=5)
    row = result[str(ROOT)]
    assert len(row["cpu_us_per_request"]) == 2
    assert all(us > 0 for us in row["cpu_us_per_request"])
    assert row["median_seconds"] > 0


@pytest.mark.slow
def test_a_checkout_without_stook_sources_is_refused(tmp_path: Path) -> None:
    # PYTHONPATH then finds nothing of the checkout's, and the installed stook answers.
    with pytest.raises(RuntimeError, match="imported stook from"):
        compare_checkouts([tmp_path], rounds=1, jobs=2)


@pytest.mark.slow
def test_whole_processes_are_timed_per_checkout_with_their_cpu() -> None:
    result = compare_whole_processes([ROOT], rounds=2, jobs=5, latency_ms=0.0)
    row = result[str(ROOT)]
    assert len(row["seconds"]) == len(row["cpu_seconds"]) == 2
    assert row["median_cpu_seconds"] > 0
    assert row["median_seconds"] > 0
