"""The bench's config-defined metrics point at a tiny size: real emission files loaded by
EmissionsSet and by DuckDB's read_json, the fixture's batch queries run on the tables."""

from __future__ import annotations

import json
from pathlib import Path

from stook.bench._metrics_config_load import measure_metrics_config_load, write_jobs


def test_the_jobs_files_are_emission_lines_made_from_their_numbers(tmp_path: Path) -> None:
    paths = write_jobs(tmp_path / "a", 2, 3)
    again = write_jobs(tmp_path / "b", 2, 3)
    assert [p.read_bytes() for p in paths] == [p.read_bytes() for p in again]
    rows = [json.loads(line) for line in paths[1].read_text(encoding="utf-8").splitlines()]
    assert rows[2] == {
        "$metadata": {"topic": "speed", "timestamp": 20_000_000},
        "$data": {"lane": "l", "speed": 7.0},
    }


def test_loading_and_the_batch_queries_are_measured() -> None:
    said: list[str] = []
    result = measure_metrics_config_load(3, 10, 2, say=said.append)
    assert (result["jobs"], result["rows"], result["runs"]) == (3, 30, 2)
    assert len(result["load_runs_s"]) == len(result["read_json_runs_s"]) == 2
    assert result["load_rows_per_s"] > 0
    assert result["read_json_rows_per_s"] > 0
    assert result["batch_metrics"] == 6  # the fixture's
    assert result["batch_queries"] == 9  # and their status queries
    assert result["queries_per_s"] > 0
    assert said[0].startswith("  3 jobs x 10 rows: EmissionsSet")
