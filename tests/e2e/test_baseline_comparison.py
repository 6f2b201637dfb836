"""Batch mode with [batch.baseline], `stook run` as a real process against the emulator's
candidate/baseline pair: the seeded regressions are found and named, the unchanged
metrics are not flagged, no baseline is NOT_APPLICABLE, a bad table exits 2 unsent."""

from __future__ import annotations

import json
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import BatchKind, Emulator
from stook.sdk import JobMetricsView, MetricStatus
from tests.e2e.processes import stook_command
from tests.e2e.support import (
    OUTPUT_NAME,
    EmulatorThread,
    bar_chart,
    by_name,
    config,
    read_output,
    text_of,
    write_batch_inputs,
)

pytestmark = pytest.mark.usefixtures("isolated")

REGRESSED = (3, 11, 17)  # experience indices that pass in the baseline and fail now
PAIR = config(
    seed=7,
    jobs_per_batch=60,
    report_batches=4,
    report_jobs_per_batch=10,
    baseline_pair=True,
    baseline_regressed_experiences=REGRESSED,
    baseline_shift_metric="Localization error",
    baseline_shift=0.25,
)
TOML = """\
[batch]
defaults = false

[batch.baseline]
previous = true
better = { "Max speed" = "higher" }
"""


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(PAIR) as emulator:
        yield emulator


def stook_run(emu: Emulator, tmp: Path, toml: str) -> tuple[subprocess.CompletedProcess[str], Path]:
    inputs, outputs = tmp / "inputs", tmp / "outputs"
    write_batch_inputs(inputs, emu)
    (tmp / "stook.toml").write_text(toml)
    env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
    argv = [*stook_command(), "run", "--inputs", str(inputs), "--outputs", str(outputs)]
    argv += ["--config", str(tmp / "stook.toml"), "--log-level", "warning"]
    done = subprocess.run(argv, cwd=tmp, env=env, capture_output=True, text=True, timeout=120)
    return done, outputs / OUTPUT_NAME


def verdict_lines(text: str) -> dict[str, str]:
    return {
        line[2:].split(":", 1)[0]: line.split(": ", 1)[1].split(",", 1)[0]
        for line in text.splitlines()
        if line.startswith("- ")
    }


def test_the_seeded_regressions_are_found_and_named(emu: Emulator, tmp_path: Path) -> None:
    done, output = stook_run(emu, tmp_path, TOML)
    assert done.returncode == 0, done.stderr
    view: JobMetricsView = read_output(output)
    metrics = by_name(view)
    ds = emu.dataset
    baseline = ds.batches_of(BatchKind.BASELINE)[0]
    names = sorted(ds.experiences[i].name for i in REGRESSED)

    comparison = metrics["Compared with baseline"]
    text = text_of(comparison)
    assert comparison.status is MetricStatus.FAIL_WARN
    assert view.status is MetricStatus.FAIL_WARN
    assert f"Baseline: {baseline.friendly_name} (batch {baseline.id}, build planner " in text
    assert f"created {baseline.created:%Y-%m-%d %H:%M} UTC" in text
    assert f"Newly failing experiences (3): {', '.join(names)}" in text
    assert "Fixed experiences (0): none" in text

    verdicts = verdict_lines(text)
    assert verdicts["Localization error"] == "REGRESSED"  # the seeded shift
    for unchanged in ("Max speed", "Distance driven", "Collisions"):
        assert verdicts[unchanged] in ("NO CHANGE", "INCONCLUSIVE"), (unchanged, text)
    assert "Localization error: REGRESSED" in text
    assert "lower is better, from the failure definition" in text
    assert "higher is better, from the config" in text
    assert "paired over 40 experiences" in text

    assert bar_chart(view, metrics["Newly failing and fixed experiences"]) == dict.fromkeys(
        names, 1.0
    )
    assert metrics["Localization error vs baseline"].status is MetricStatus.FAIL_WARN
    assert metrics["Max speed vs baseline"].status is MetricStatus.PASSED
    assert "Pass rate difference vs baseline" in metrics

    # Byte-identical run to run: the bootstrap is seeded from the two batch IDs.
    again, second = stook_run(emu, tmp_path / "again", TOML)
    assert again.returncode == 0, again.stderr
    assert second.read_bytes() == output.read_bytes()


def test_block_on_regression_blocks(emu: Emulator, tmp_path: Path) -> None:
    toml = TOML.replace("previous = true", 'branch = "main"\nblock_on_regression = true')
    done, output = stook_run(emu, tmp_path, toml)
    assert done.returncode == 0, done.stderr
    view = read_output(output)
    assert by_name(view)["Compared with baseline"].status is MetricStatus.FAIL_BLOCK
    assert view.status is MetricStatus.FAIL_BLOCK


def test_no_comparable_batch_is_not_applicable(emu: Emulator, tmp_path: Path) -> None:
    toml = TOML.replace("previous = true", 'branch = "release/9"')
    done, output = stook_run(emu, tmp_path, toml)
    assert done.returncode == 0, done.stderr
    view = read_output(output)
    comparison = by_name(view)["Compared with baseline"]
    assert comparison.status is MetricStatus.NOT_APPLICABLE
    assert text_of(comparison) == (
        "No baseline to compare with: project has no branch named 'release/9'."
    )
    assert [m.name for m in view.metrics] == ["Compared with baseline"]


def test_a_bad_table_exits_2_before_any_request(emu: Emulator, tmp_path: Path) -> None:
    before = emu.stats.requests["api"]
    done, output = stook_run(emu, tmp_path, TOML.replace("previous = true", "previous = 1"))
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1  # said once, as a JSON event off a terminal
    event = json.loads(lines[0])
    assert (event["event"], event["exit_code"]) == ("stook failed", 2)
    assert event["error"] == (
        f"{tmp_path / 'stook.toml'}: [batch.baseline] previous must be true (or left out)"
    )
    assert not output.exists()
    assert emu.stats.requests["api"] == before


def test_a_metric_no_job_has_is_a_config_error(emu: Emulator, tmp_path: Path) -> None:
    toml = TOML + 'metrics = ["Localisation error"]\n'
    toml = toml.replace('better = { "Max speed" = "higher" }\n', "")
    done, output = stook_run(emu, tmp_path, toml)
    assert done.returncode == 2, done.stderr
    event = json.loads(done.stderr.strip().splitlines()[-1])
    assert event["error"].endswith(
        "no job in the batch has a scalar metric named 'Localisation error'; "
        "did you mean 'Localization error'?"
    )
    assert not output.exists()


def test_the_demo_shows_a_comparison(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from stook.testing._demo import _print_output
    from stook.testing._demo_baseline import REGRESSED_EXPERIENCES, run_comparison_demo

    assert run_comparison_demo(tmp_path, seed=0, print_output=_print_output) == 0
    shown = capsys.readouterr().out
    assert "== batch mode with a baseline" in shown
    assert "- Localization error: REGRESSED" in shown
    assert f"Newly failing experiences ({len(REGRESSED_EXPERIENCES)}): " in shown
    assert (tmp_path / "comparison" / OUTPUT_NAME).exists()
