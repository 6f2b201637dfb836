"""`stook demo`'s config-defined metrics: the emulated project's `config.resim.yml` over
what its batch's tests emitted.

The same batch as the demo's batch mode, run with `[metrics_config]` instead of stook's
own aggregations: each job's EMISSIONS_LOG is downloaded and the config's `type: batch`
metrics (SQL over the emitted topics) are written to metrics.binproto, with a preview.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from stook.emulator import write_emissions_config
from stook.sdk import JobMetricsView, MetricStatus, read_job_metrics
from stook.service.modes import BatchInputs, detect, for_stream, load, run_batch, run_on_event_loop
from stook.testing._frames import camera_frame_png

CONFIG_TOML = """\
# Only the config-defined metrics: stook's own batch metrics are off.
[batch]
defaults = false

[output]
summary = false

[metrics_config]
paths = [".resim/metrics/config.resim.yml"]
"""
# The config metric the demo shows, and its SQL's gist.
SHOWN = "Mean localization error"


def write_attached_frames(view: JobMetricsView, folder: Path) -> list[Path]:
    """The camera frames the output's image metrics name, beside it. The emulated tests
    attach no real files, and batch mode names an attached file without downloading it
    (the platform keeps the job's files): the demo draws one in its place, so that the
    preview shows an image where a user's would show theirs."""
    written: list[Path] = []
    for data in view.data:
        path = data.external_path
        if path is None or not path.lower().endswith(".png"):
            continue
        target = (folder / path).resolve()
        if not target.is_relative_to(folder.resolve()):
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(camera_frame_png(hue=len(written) * 40))
        written.append(target)
    return written


def run_config_metrics_demo(
    inputs: Path, output: Path, *, print_output: Callable[[Path], int]
) -> int:
    """Runs batch mode on `inputs` with the emulated project's config; returns how many
    outputs were invalid (0 or 1)."""
    folder = output / "metrics-config"
    config_file = write_emissions_config(folder / ".resim" / "metrics")
    toml = folder / "stook.toml"
    toml.write_text(CONFIG_TOML, encoding="utf-8")
    print(f"\n== config-defined metrics: {config_file.name} over the batch's emissions ==")
    batch = detect(inputs)
    assert isinstance(batch, BatchInputs)
    started = time.perf_counter()
    result = run_on_event_loop(
        run_batch(batch, load(toml), folder, progress=for_stream(label="jobs"))
    )
    seconds = time.perf_counter() - started
    view = read_job_metrics(result.output.read_bytes(), source=str(result.output))
    write_attached_frames(view, result.output.parent)
    invalid = print_output(result.output)
    shown = next(m for m in view.metrics if m.name == SHOWN)
    status = shown.status.name if isinstance(shown.status, MetricStatus) else "?"
    print(
        f"  {SHOWN} (SELECT AVG(error) FROM localization): {shown.value:.4f} {shown.unit}, "
        f"{status}; {len(view.metrics)} config metrics from {result.outcome.jobs_listed} jobs' "
        f"emissions logs, {seconds:.2f} s"
    )
    return invalid
