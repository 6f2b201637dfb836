"""The demo's comparison step: a batch against its baseline, with seeded regressions.

The emulator serves a candidate/baseline pair (`baseline_pair`): three experiences that
passed in the baseline fail in the candidate, and "Localization error" is 20 % higher;
every other metric only varies from run to run. stook finds the baseline (`previous =
true`), fetches both batches side by side and says what changed, with its statistics.
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from pathlib import Path

from stook.emulator import EmulatorConfig, EmulatorProcess
from stook.sdk import TextMetric, read_job_metrics
from stook.service.modes import (
    BatchInputs,
    detect,
    for_stream,
    parse,
    run_batch,
    run_on_event_loop,
)

COMPARISON_CONFIG = """\
# Batch mode compared with the previous finished batch of the same suite and branch.
[batch]
defaults = false

[batch.baseline]
previous = true
better = { "Max speed" = "higher" }
min_effect = 0.05
"""
REGRESSED_EXPERIENCES = (3, 11, 17)


def run_comparison_demo(output: Path, *, seed: int, print_output: Callable[[Path], int]) -> int:
    """Compare the emulator's candidate with its baseline; the number of invalid outputs."""
    folder = output / "comparison"
    folder.mkdir(parents=True, exist_ok=True)
    config_path = folder / "stook.toml"
    config_path.write_text(COMPARISON_CONFIG, encoding="utf-8")
    config = parse(tomllib.loads(COMPARISON_CONFIG), source=str(config_path))
    emulator_config = EmulatorConfig(
        seed=seed,
        jobs_per_batch=80,
        report_batches=4,
        baseline_pair=True,
        baseline_regressed_experiences=REGRESSED_EXPERIENCES,
        baseline_shift_metric="Localization error",
        baseline_shift=0.2,
        latency_ms=5.0,
    )
    print("\n== batch mode with a baseline: what changed since the previous batch ==")
    with EmulatorProcess(emulator_config) as emulator:
        inputs = folder / "inputs"
        emulator.write_batch_config(inputs)
        batch = detect(inputs)
        assert isinstance(batch, BatchInputs)
        result = run_on_event_loop(
            run_batch(batch, config, folder, progress=for_stream(label="jobs"))
        )
    invalid = print_output(result.output)
    view = read_job_metrics(result.output.read_bytes(), source=str(result.output))
    text = view.metric("Compared with baseline", TextMetric).text
    print("  " + text.replace("\n", "\n    "))
    return invalid
