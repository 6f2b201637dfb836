"""Emulated runs whose outputs were recorded before a refactor, to prove it changed no byte.

`tools/record_golden_outputs.py` runs each case with whatever stook is importable (point
PYTHONPATH at an older checkout's `*/src` folders to record with that version) and writes
`tests/golden/<name>.binproto`; `tests/e2e/test_golden_outputs.py` runs the same cases
with the current code and compares the bytes. Re-record only for a deliberate change of
output, and say so in the commit.
"""

from __future__ import annotations

import asyncio
import importlib
import os
import subprocess
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent

# The weighted mean, histogram and statistics a configured batch run adds to the defaults.
BATCH_TOML = """\
[[batch.weighted_mean]]
name = "Distance-weighted localization error"
metric = "Localization error"
weight = "Distance driven"

[[batch.histogram]]
name = "Speeds (all jobs)"
data = "speeds"
lower = 0.0
upper = 40.0
buckets = 20

[[batch.scalar_stats]]
metric = "Max speed"
stats = ["mean", "min", "max", "std", "count", "p50", "p95"]
"""


@dataclass(frozen=True)
class Case:
    name: str
    mode: str  # "batch" or "report"
    toml: str = ""
    emulator: dict[str, Any] = field(default_factory=dict)

    @property
    def recorded(self) -> Path:
        return HERE / f"{self.name}.binproto"


CASES = (
    Case("batch_defaults", "batch", emulator={"seed": 7, "jobs_per_batch": 60}),
    Case("batch_configured", "batch", BATCH_TOML, {"seed": 11, "jobs_per_batch": 45}),
    Case(
        "report_defaults",
        "report",
        emulator={"seed": 7, "report_batches": 8, "report_jobs_per_batch": 15},
    ),
)


def _emulator_types() -> tuple[Any, Any]:
    # Before the emulator became stook-testing's it was stook.service.emulator; recording
    # with an older version must use that version's emulator.
    try:
        module = importlib.import_module("stook.service.emulator")
    except ImportError:
        module = importlib.import_module("stook.emulator")
    return module.Emulator, module.EmulatorConfig


def run_case(case: Case, workdir: Path, *, env: dict[str, str] | None = None) -> bytes:
    """The `metrics.binproto` that `stook run` writes for `case`, as a separate process."""
    emulator_type, config_type = _emulator_types()
    emulator = emulator_type(config_type(**case.emulator))
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    asyncio.run_coroutine_threadsafe(emulator.start(), loop).result(10)
    try:
        inputs, outputs = workdir / "inputs", workdir / "outputs"
        if case.mode == "batch":
            emulator.write_batch_config(inputs)
        else:
            emulator.write_report_config(inputs)
        config = workdir / "stook.toml"
        config.write_text(case.toml)
        done = subprocess.run(
            [
                sys.executable,
                "-c",
                "from stook.service.cli import main; main()",
                "run",
                "--inputs",
                str(inputs),
                "--outputs",
                str(outputs),
                "--config",
                str(config),
                "--log-level",
                "warning",
            ],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
            env=env if env is not None else dict(os.environ),
        )
        if done.returncode != 0:
            raise RuntimeError(f"{case.name}: stook run exited {done.returncode}\n{done.stderr}")
        return (outputs / "metrics.binproto").read_bytes()
    finally:
        asyncio.run_coroutine_threadsafe(emulator.close(), loop).result(10)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(10)
        loop.close()
