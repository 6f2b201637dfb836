"""`stook bench`'s whole-process comparison: `stook run` and ReSim's fetcher as processes.

A real run at a tiny size checks that both clients run to the end against one emulator and
that what each asked of it is counted; seconds are measured on a quiet machine, not here.
"""

from __future__ import annotations

import pytest

from stook.bench._measure import resim_available
from stook.bench._whole_process import SPEEDUP_TARGET, measure_whole_process, whole_process_target


@pytest.mark.slow
def test_both_clients_run_as_processes_on_one_emulator() -> None:
    said: list[str] = []
    result = measure_whole_process(4, 0.0, 2, say=said.append)
    assert result["jobs"] == 4
    assert len(result["stook_runs_s"]) == 2
    assert result["stook_median_s"] > 0
    # The job listing, then each job's metrics and metricsData listings and one download.
    assert result["stook_requests"] >= 1 + 4 * 3
    assert len(said) == 1
    if resim_available():
        assert len(result["resim_runs_s"]) == 2
        assert result["resim_requests"] > 0
        assert result["speedup"] == round(result["resim_median_s"] / result["stook_median_s"], 1)
        assert set(whole_process_target(result)) == {"whole_process_vs_resim"}


def test_the_target_is_judged_on_the_medians() -> None:
    result = {"jobs": 400, "latency_ms": 10.0, "pairs": 5, "speedup": SPEEDUP_TARGET}
    target = whole_process_target(result)["whole_process_vs_resim"]
    assert target["met"] is True
    assert target["measured"] == SPEEDUP_TARGET
    assert "median of 5 interleaved pairs" in target["at"]
    assert (
        whole_process_target(result | {"speedup": SPEEDUP_TARGET - 0.1})["whole_process_vs_resim"][
            "met"
        ]
        is False
    )


def test_no_resim_measurement_no_target() -> None:
    assert whole_process_target(None) == {}
    assert whole_process_target({"jobs": 4, "latency_ms": 0.0, "pairs": 1}) == {}
