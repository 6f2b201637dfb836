"""The bench's whole-process report comparison: `stook run` on a report's inputs and ReSim's
default report, each a process of its own on one emulator.

A real run at a tiny size checks that both run to the end and write their output (each
raises otherwise); seconds are measured on a quiet machine, not here.
"""

from __future__ import annotations

import pytest

from stook.bench._measure import resim_available
from stook.bench._report_compare import compare_report_whole_process


@pytest.mark.slow
def test_both_reports_run_as_processes_on_one_emulator() -> None:
    result = compare_report_whole_process(3, 2, 0.0, pairs=2)
    assert (result["batches"], result["jobs_per_batch"], result["pairs"]) == (3, 2, 2)
    assert len(result["stook_runs_s"]) == 2
    assert result["stook_median_s"] > 0
    if resim_available():
        assert len(result["resim_runs_s"]) == 2
        assert result["speedup"] == round(result["resim_median_s"] / result["stook_median_s"], 1)
    else:
        assert "speedup" not in result
