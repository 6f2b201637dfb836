"""The repeated target points: both clients' runs, with their CPU and the emulator's."""

from __future__ import annotations

import sys

import pytest

from stook.bench._measure import BARE_LOOP, STOOK
from stook.bench._repeat import repeat_target_points


@pytest.mark.slow
@pytest.mark.skipif(sys.platform != "linux", reason="the emulator's CPU is read from /proc")
def test_a_repeated_point_records_each_runs_cpu_and_the_emulators() -> None:
    said: list[str] = []
    (point,) = repeat_target_points(2, points=((0.0, 20, 4),), say=said.append)
    assert (point["jobs"], point["concurrency"], point["repeats"]) == (20, 4, 2)
    for client in (STOOK, BARE_LOOP):
        runs = point["runs"][client]
        assert len(runs) == 2
        for run in runs:
            assert run["requests_per_second"] > 0
            assert run["cpu_us_per_request"] > 0
            # The emulator served every request of the run: it spent CPU on them.
            assert run["emulator_cpu_us_per_request"] is not None
            assert run["emulator_busy"] is not None
        median = point["median"][client]
        assert set(median) == {
            "seconds",
            "requests_per_second",
            "cpu_us_per_request",
            "emulator_cpu_us_per_request",
        }
    stook, bare = point["median"][STOOK], point["median"][BARE_LOOP]
    assert point["stook_share_of_bare_by_cpu"] == round(
        bare["cpu_us_per_request"] / stook["cpu_us_per_request"], 3
    )
    assert 0 <= point["emulator_held_bare"] <= 2
    (line,) = said
    assert "CPU per request" in line
    assert "the emulator held the bare loop in" in line
