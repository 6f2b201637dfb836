"""The bench's batch mode over emissions logs, at a small size: whole `stook run` processes
against an emulator process, every run's output written."""

from __future__ import annotations

import pytest

from stook.bench._emissions_batch import measure_emissions_batch


@pytest.mark.slow
def test_batch_mode_over_emissions_logs_is_measured() -> None:
    said: list[str] = []
    result = measure_emissions_batch(12, 0.0, 1, frames=10, say=said.append)
    assert result["jobs"] == 12
    assert result["rows"] > 12 * 20  # two rows a frame, and a few more, per job with a log
    assert len(result["runs_s"]) == 1
    assert result["median_s"] > 0
    assert result["requests"] > 12  # a log listing per job, and its download
    assert "batch mode over emissions logs: 12 jobs" in said[0]
