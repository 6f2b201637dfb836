"""The `stook` process collects no garbage during its imports, and collects again (with
what was alive then frozen) once its command's work starts; a program using the CLI's
functions keeps its collector as it is. Each case runs in a fresh interpreter, so that
pytest's own collector is left alone."""

from __future__ import annotations

import os
import subprocess
import sys
import uuid
from pathlib import Path

from stook.sdk import MetricsWriter, read_job_metrics

REPO = Path(__file__).resolve().parents[3]


def _printed_by(script: str) -> str:
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()[-1]


def test_pause_then_resume_freezes_what_is_alive() -> None:
    script = (
        "import gc\nfrom stook.service.cli import _collector\n"
        "_collector.pause()\npaused = gc.isenabled()\n_collector.resume()\n"
        "print(paused, gc.isenabled(), gc.get_freeze_count() > 0)\n"
    )
    assert _printed_by(script) == "False True True"


def test_a_collector_turned_off_by_its_program_stays_off() -> None:
    script = (
        "import gc\nfrom stook.service.cli import _collector\n"
        "gc.disable()\n_collector.pause()\n_collector.resume()\n"
        "print(gc.isenabled(), gc.get_freeze_count())\n"
    )
    assert _printed_by(script) == "False 0"


def test_run_cli_called_by_a_program_leaves_its_collector_alone(tmp_path: Path) -> None:
    writer = MetricsWriter(uuid.UUID(int=1))
    writer.scalar("speed", 1.0)
    path = str(writer.write(tmp_path / "metrics.binproto"))
    script = (
        "import gc\nfrom stook.service.cli import run_cli\n"
        f"code = run_cli(['validate', {path!r}])\n"
        "print(code, gc.isenabled(), gc.get_freeze_count())\n"
    )
    assert _printed_by(script) == "0 True 0"


def test_stook_run_collects_again_once_its_work_starts(tmp_path: Path) -> None:
    # A test-mode run whose metrics function records the collector's state as it runs.
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    (inputs / "logs").mkdir(parents=True)
    (tmp_path / "collector_probe.py").write_text(
        "import gc\n\n"
        "def compute(experience, logs, writer):\n"
        "    writer.scalar('collecting', float(gc.isenabled()))\n"
        "    writer.scalar('frozen', float(gc.get_freeze_count() > 0))\n"
    )
    (tmp_path / "stook.toml").write_text('[test]\nmetrics = "collector_probe:compute"\n')
    env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
    env["PYTHONPATH"] = str(REPO)
    argv = [sys.executable, "-c", "from stook.service.cli import main; main()"]
    done = subprocess.run(
        [*argv, "run", "--inputs", str(inputs), "--outputs", str(outputs)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    view = read_job_metrics((outputs / "metrics.binproto").read_bytes())
    values = {m.name: m.value for m in view.metrics}
    assert values == {"collecting": 1.0, "frozen": 1.0}
