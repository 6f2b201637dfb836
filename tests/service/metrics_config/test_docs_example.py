"""docs/metrics-config.md's Python example runs as written, in a folder laid out as the
platform's repositories are."""

from __future__ import annotations

from pathlib import Path

import pytest

from stook.sdk import read_job_metrics
from stook.testing.metrics_config_fixture import write_fixture
from tests.docs_examples import block
from tests.service.metrics_config.emitted import emit_job, make_job


def test_the_docs_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    config = write_fixture(tmp_path)
    emit_job(tmp_path, config, make_job(2))
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(block("docs/metrics-config.md", "# metrics-config: "), namespace)
    view = read_job_metrics((tmp_path / "metrics.binproto").read_bytes())
    assert "Max speed" in view.metric_names()
    assert namespace["done"].files == ["frame_2.png"]  # type: ignore[attr-defined]
