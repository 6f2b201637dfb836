"""The README's config-defined-metrics commands run as written after `stook demo`: the
demo leaves its config and its batch's jobs offline (a folder per job: emissions and
job.json), `check` passes, and `eval` writes the very output of the demo's batch run."""

from __future__ import annotations

import json
import shlex
import subprocess
from pathlib import Path

import pytest

from stook.sdk import find_problems, read_job_metrics
from tests.docs_examples import block
from tests.e2e.processes import stook_command

STOOK = ".venv/bin/stook"


def _readme_commands() -> list[list[str]]:
    """The block's commands, continuation lines joined and comments dropped."""
    text = block("README.md", "metrics-config check", language="bash").replace("\\\n", " ")
    return [shlex.split(line, comments=True) for line in text.splitlines() if line.strip()]


@pytest.mark.slow
def test_the_readmes_metrics_config_commands_run_after_the_demo(tmp_path: Path) -> None:
    commands = _readme_commands()
    assert commands[0] == ["make", "demo"], commands
    assert [c[:3] for c in commands[1:]] == [
        [STOOK, "metrics-config", "check"],
        [STOOK, "metrics-config", "eval"],
    ], commands
    demo = subprocess.run(
        [*stook_command(), "demo", "--jobs", "12"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=180,
        check=False,
    )
    assert demo.returncode == 0, demo.stderr
    # The demo prints the same commands (with `stook` for the venv's script).
    for command in commands[1:]:
        assert shlex.join(["stook", *command[1:]]) in demo.stdout, demo.stdout
    runs = tmp_path / "demo-output" / "metrics-config" / "runs"
    assert len(list(runs.glob("*/job.json"))) == 12
    # docs/metrics-config.md's example: lines and metadata of the demo's first job.
    (job,) = runs.glob("*-5b23a57f-d931-582e-ac66-48aa6ca6a1f8")
    lines = block("docs/metrics-config.md", '{"$metadata":', language="json").splitlines()
    assert set(lines) <= set((job / "emissions.resim.jsonl").read_text().splitlines())
    shown = json.loads(block("docs/metrics-config.md", '"job_id":', language="json"))
    assert shown.items() <= json.loads((job / "job.json").read_text()).items()
    assert (job / "frame_0039.png").is_file()
    for command in commands[1:]:
        done = subprocess.run(
            [*stook_command(), *command[1:]],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        assert done.returncode == 0, done.stderr
        # No metric failed: no error line on stderr (a missing frame would say one).
        assert "ERROR" not in done.stderr, done.stderr
    output = Path(commands[2][commands[2].index("-o") + 1])
    offline = read_job_metrics((tmp_path / output / "metrics.binproto").read_bytes())
    assert not find_problems(offline.raw)
    assert (tmp_path / output / "metrics.html").is_file()
    assert len(offline.metrics) > 5
    # The image metric's frame, found in its job's folder, is copied beside the output.
    assert list((tmp_path / output).glob("frame_*.png"))
    # Offline, the very output of the demo's batch run over the API: the same bytes.
    online = tmp_path / "demo-output" / "metrics-config" / "metrics.binproto"
    assert (tmp_path / output / "metrics.binproto").read_bytes() == online.read_bytes()
