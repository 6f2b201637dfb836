"""`stook run` ends its process without Python's teardown, after saying all it has to say.

The teardown (finalizing ~800 modules) took ~0.1 s of every run; the process now ends at
once when `run` returns. An object of `__main__` whose finalizer prints shows whether the
teardown ran; a handler registered with atexit, which must run either way (a user's own,
coverage's), shows that it did.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import Emulator
from tests.e2e.support import OUTPUT_NAME, EmulatorThread, config, read_output
from tests.failures import failure_lines

REPO = Path(__file__).resolve().parents[2]
MARK = "teardown-ran"
AT_EXIT = "atexit-ran"
# The entry point as the console script calls it, with both markers first.
ENTRY = (
    "import atexit, sys\n"
    "class Mark:\n"
    f"    def __del__(self): sys.stderr.write({MARK!r} + '\\n')\n"
    "mark = Mark()\n"
    f"atexit.register(lambda: print({AT_EXIT!r}, file=sys.stderr))\n"
    "from stook.service.cli import main\n"
    "main()\n"
)

pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=6, seed=5)) as emulator:
        yield emulator


def _stook(tmp: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
    env["PYTHONPATH"] = str(REPO)
    return subprocess.run(
        [sys.executable, "-c", ENTRY, *args],
        cwd=tmp,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def _batch(tmp: Path, emu: Emulator, **changes: str) -> list[str]:
    inputs = tmp / "inputs"
    inputs.mkdir()
    document = {
        "authToken": emu.info.token,
        "apiURL": emu.info.api_url,
        "batchID": str(emu.info.batch_id),
        "projectID": str(emu.info.project_id),
    } | changes
    (inputs / "batch_metrics_config.json").write_text(json.dumps(document))
    return ["run", "--inputs", str(inputs), "--outputs", str(tmp / "outputs")]


def test_a_run_that_succeeds_ends_without_the_teardown(tmp_path: Path, emu: Emulator) -> None:
    done = _stook(tmp_path, *_batch(tmp_path, emu))
    assert done.returncode == 0, done.stderr
    assert MARK not in done.stderr
    assert AT_EXIT in done.stderr
    read_output(tmp_path / "outputs" / OUTPUT_NAME)


def test_a_run_that_fails_says_its_one_line_and_keeps_its_exit_code(
    tmp_path: Path, emu: Emulator
) -> None:
    done = _stook(tmp_path, *_batch(tmp_path, emu, authToken="not-the-token"))
    assert done.returncode == 3
    assert len(failure_lines(done.stderr)) == 1, done.stderr
    assert MARK not in done.stderr
    assert AT_EXIT in done.stderr


def test_other_commands_end_as_usual(tmp_path: Path) -> None:
    done = _stook(tmp_path, "--version")
    assert done.returncode == 0
    assert MARK in done.stderr
    assert AT_EXIT in done.stderr
