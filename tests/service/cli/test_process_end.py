"""The console script ends its process itself once the command is done (cli/_exit.py)."""

from __future__ import annotations

import subprocess
import sys

_SCRIPT = """
import atexit, sys
atexit.register(print, "registered before: skipped")
from stook.service.cli._exit import ProcessEnd
end = ProcessEnd()
atexit.register(print, "registered after: ran")
print("buffered output", end="")  # flushed by the end, not lost
end.code = {code}
sys.exit(0)
"""


def _run(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", _SCRIPT.format(code=code)],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_the_commands_code_and_the_later_handlers_survive_the_end() -> None:
    done = _run("7")
    assert done.returncode == 7
    assert done.stdout == "buffered outputregistered after: ran\n"


def test_without_a_code_the_process_exits_as_python_does() -> None:
    done = _run("None")
    assert done.returncode == 0
    assert "registered before: skipped" in done.stdout
    assert "registered after: ran" in done.stdout


def test_the_console_script_keeps_its_exit_code() -> None:
    done = subprocess.run(
        [sys.executable, "-c", "from stook.service.cli import main; main()", "show", "nothing"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "nothing" in done.stderr
