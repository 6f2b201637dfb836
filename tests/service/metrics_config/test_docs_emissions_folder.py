"""docs/metrics-config.md's emissions folder example loads: its lines are rows of the
demo's config (every column of its topic's type) and its job.json a metadata row.
(tests/e2e/test_readme_metrics_config.py checks that the demo writes them.)"""

from __future__ import annotations

import json
from pathlib import Path

from stook.emulator import write_emissions_config
from stook.service.metrics_config import EmissionsSet, JobMeta, load_config
from tests.docs_examples import block

PAGE = "docs/metrics-config.md"


def test_the_docs_emissions_lines_and_job_json_load(tmp_path: Path) -> None:
    config = load_config([write_emissions_config(tmp_path / ".resim" / "metrics")])
    lines = block(PAGE, '{"$metadata":', language="json")
    meta = JobMeta.from_mapping(json.loads(block(PAGE, '"job_id":', language="json")))
    emissions = EmissionsSet(config)
    emissions.add_job(meta, lines.encode())
    tables = emissions.tables()
    assert tables["planner_state"]["state"].to_list() == ["CRUISE", "STOP"]
    assert tables["planner_state"]["timestamp"].to_list() == [0, 1_000_000_000]
    assert tables["metadata"]["experience_name"].to_list() == ["Highway merge 01"]
