"""docs/metrics-config.md's Python example runs as written, in a folder laid out as the
platform's repositories are, and its quick start runs as a shell runs it."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from stook.sdk import MetricStatus, ScalarMetric, read_job_metrics
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


def test_the_quick_start_runs_as_written(tmp_path: Path) -> None:
    """The page's quick start, pasted into a shell: its config checks, and `eval` writes
    the value, status and preview the text after it says."""
    script = block("docs/metrics-config.md", "cat > emissions.resim.jsonl", language="bash")
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"
    done = subprocess.run(
        ["bash", "-e", "-c", script],
        cwd=tmp_path,
        env={**os.environ, "PATH": path, "NO_COLOR": "1"},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    check = ".resim/metrics/config.resim.yml: 1 topics, 1 metrics, ok\n"
    assert done.stdout.startswith(check), done.stdout
    view = read_job_metrics((tmp_path / "out" / "metrics.binproto").read_bytes())
    speed = view.metric("Max speed", ScalarMetric)
    assert (speed.value, speed.unit, speed.view.status) == (31.0, "m/s", MetricStatus.FAIL_WARN)
    assert (tmp_path / "out" / "metrics.html").is_file()
