"""`stook demo`: the metrics build end to end on an embedded default, no ReSim account needed.

1. Test mode: the SDK example writes every metric type for one synthetic test.
2. Batch mode: the emulator (in its own process, with latency and transient faults)
   serves a batch; stook fetches and aggregates it with an example config.
3. Report mode: the same emulator serves a test suite's batches over two weeks, with a
   step change half-way; stook draws them over time, says what regressed in the latest
   batch and where, earlier, a level moved (change points).
4. Batch mode with a baseline: a batch compared with the previous one (_demo_baseline).
5. Config-defined metrics: the batch's emissions logs through the emulated project's
   config.resim.yml (_demo_metrics_config), between 2 and 3.
Each output is validated and summarised; the batch summary adds jobs, requests,
retries and seconds.
"""

from __future__ import annotations

import shlex
import time
import tomllib
from pathlib import Path

from stook.emulator import EmulatorConfig, EmulatorProcess
from stook.sdk import TextMetric, find_problems, read_job_metrics
from stook.service.modes import (
    BatchInputs,
    ReportInputs,
    StookConfig,
    TestInputs,
    detect,
    for_stream,
    parse,
    run_batch,
    run_on_event_loop,
    run_report,
    run_test_mode,
)
from stook.service.preview import PREVIEW_NAME, summary_lines, write_preview
from stook.testing._demo_baseline import run_comparison_demo
from stook.testing._demo_metrics_config import run_config_metrics_demo
from stook.testing._frames import write_example_frames

REPORT_BATCHES = 14

EXAMPLE_CONFIG = """\
# The example stook.toml the demo runs with.
[fetch]
concurrency = 64

[test]
metrics = "stook.sdk.example:every_metric_type"

[[batch.weighted_mean]]
name = "Distance-weighted localization error"
metric = "Localization error"
weight = "Distance driven"

[[batch.histogram]]
name = "Speed distribution"
data = "speeds"
lower = 0.0
upper = 40.0
buckets = 20

[[batch.scalar_stats]]
metric = "Max speed"
stats = ["min", "p50", "p95", "max"]

[report]
top_n = 8
regression_window = 10
regression_threshold = 3.5
"""


def _print_output(path: Path) -> int:
    view = read_job_metrics(path.read_bytes(), source=str(path))
    problems = find_problems(view.raw)
    for line in summary_lines(view):
        print("  " + line)
    verdict = "valid" if not problems else f"INVALID: {problems[0]}"
    print(f"  {path}: {path.stat().st_size:,} bytes, {verdict}")
    # Every metric drawn, offline: open it in a browser.
    print(f"  preview: {write_preview([path], path.with_name(PREVIEW_NAME))}")
    return len(problems)


def _text_of(path: Path, name: str) -> str | None:
    view = read_job_metrics(path.read_bytes(), source=str(path))
    if name not in view.metric_names():
        return None
    return view.metric(name, TextMetric).text


def run_demo(*, jobs: int, output: Path, seed: int) -> int:
    output.mkdir(parents=True, exist_ok=True)
    config_path = output / "stook.toml"
    config_path.write_text(EXAMPLE_CONFIG, encoding="utf-8")
    config: StookConfig = parse(tomllib.loads(EXAMPLE_CONFIG), source=str(config_path))
    invalid = 0

    print("== test mode: one test, every metric type (stook.sdk.example) ==")
    test_inputs = output / "test-inputs"
    for folder in ("experience", "logs"):
        (test_inputs / folder).mkdir(parents=True, exist_ok=True)
    mode = detect(test_inputs)
    assert isinstance(mode, TestInputs)
    test_output = run_on_event_loop(
        run_test_mode(mode, config, output / "test-mode" / "metrics.binproto")
    ).output
    # The example's IMAGE metrics name these files beside the output.
    write_example_frames(test_output.parent)
    invalid += _print_output(test_output)

    print(f"\n== batch mode: {jobs} jobs from the emulated ReSim API ==")
    emulator_config = EmulatorConfig(
        seed=seed,
        jobs_per_batch=jobs,
        report_batches=REPORT_BATCHES,
        report_jobs_per_batch=40,
        # Half-way through the report a batch metric and one experience's failure rate
        # move to a new level, for the change points to find; ten experiences, so that each
        # runs four times per batch.
        experiences=10,
        report_step_change_batch=REPORT_BATCHES // 2,
        report_unstable_experiences=(3,),
        cache_jobs=max(jobs, 1) + REPORT_BATCHES * 40,
        latency_ms=10.0,
        fault_5xx=0.03,
        fault_429=0.01,
        retry_after_max_s=0,
    )
    inputs = output / "inputs"
    report_inputs = output / "report-inputs"
    with EmulatorProcess(emulator_config) as emulator:
        emulator.write_batch_config(inputs)
        batch = detect(inputs)
        assert isinstance(batch, BatchInputs)
        started = time.perf_counter()
        result = run_on_event_loop(
            run_batch(batch, config, output, progress=for_stream(label="jobs"))
        )
        seconds = time.perf_counter() - started
        stats = emulator.stats()
        invalid += _print_output(result.output)
        faults = sum(stats.faults.values())
        print(
            f"  {result.outcome.jobs_listed} jobs ({len(result.outcome.missing)} missing), "
            f"{result.requests:,} requests, {result.retries} retries after {faults} injected "
            f"faults, {result.bytes_received / 1e6:.1f} MB, {seconds:.2f} s"
        )
        invalid += run_config_metrics_demo(inputs, output, print_output=_print_output)

        print(f"\n== report mode: {REPORT_BATCHES} batches of a test suite over time ==")
        emulator.write_report_config(report_inputs)
        report_mode = detect(report_inputs)
        assert isinstance(report_mode, ReportInputs)
        started = time.perf_counter()
        report = run_on_event_loop(
            run_report(report_mode, config, output / "report", progress=for_stream(label="jobs"))
        )
        seconds = time.perf_counter() - started
    invalid += _print_output(report.output)
    print(
        f"  {report.outcome.batches} batches, {report.outcome.jobs} jobs, "
        f"{report.requests:,} requests, {report.retries} retries, {seconds:.2f} s"
    )
    if report.regressions is not None:
        print("  Regressions: " + report.regressions.text.replace("\n", "\n    "))
    changes = _text_of(report.output, "Change points")
    if changes is not None:
        print("  Change points: " + changes.replace("\n", "\n    "))
    invalid += run_comparison_demo(output, seed=seed, print_output=_print_output)
    print()
    print("\n".join(run_it_yourself(jobs=jobs, seed=seed, output=output, config=config_path)))
    return 0 if invalid == 0 else 4


def run_it_yourself(*, jobs: int, seed: int, output: Path, config: Path) -> list[str]:
    """The commands that run the demo's batch and report mode again, by hand: the demo's
    emulator has stopped by now, so the first starts one that rewrites the inputs' configs
    with its own address."""
    inputs, report_inputs = output / "inputs", output / "report-inputs"
    emulate = [
        "stook", "emulate", "--jobs", str(jobs), "--batches", str(REPORT_BATCHES),
        "--seed", str(seed), "--inputs", str(inputs), "--report-inputs", str(report_inputs),
        # The demo's report: ten experiences, a step half-way, one unstable experience.
        "--set", "experiences=10", "--set", "report_jobs_per_batch=40",
        "--set", f"report_step_change_batch={REPORT_BATCHES // 2}",
        "--set", "report_unstable_experiences=[3]",
    ]  # fmt: skip
    runs = [
        ["stook", "run", "--inputs", str(folder), "--output", str(output / "yours" / name),
         "--config", str(config)]
        for folder, name in ((inputs, "batch"), (report_inputs, "report"))
    ]  # fmt: skip
    return [
        f"Config used: {config}. Run it yourself: start an emulator in one shell "
        "(it serves until Ctrl-C),",
        "  " + shlex.join(emulate),
        "then, in another shell, batch mode and report mode:",
        *("  " + shlex.join(command) for command in runs),
    ]
