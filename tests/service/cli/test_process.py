"""The console script's own process (cli/_process.py): it collects less, and it ends
itself once the command is done, after the atexit handlers registered since it started."""

from __future__ import annotations

import subprocess
import sys

_SCRIPT = """
import atexit, gc, sys
atexit.register(print, "registered before: skipped")
gc.set_threshold({young}, 10, 10)
from stook.service.cli._process import ProcessEnd
end = ProcessEnd()
print(gc.get_threshold()[0], end=" ")
atexit.register(print, "registered after: ran")
print("buffered output", end="")  # flushed by the end, not lost
end.code = {code}
sys.exit(0)
"""


def _run(code: str, young: int = 700) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", _SCRIPT.format(code=code, young=young)],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_the_commands_code_and_the_later_handlers_survive_the_end() -> None:
    done = _run("7")
    assert done.returncode == 7
    assert done.stdout == "20000 buffered outputregistered after: ran\n"


def test_without_a_code_the_process_exits_as_python_does() -> None:
    done = _run("None")
    assert done.returncode == 0
    assert "registered before: skipped" in done.stdout
    assert "registered after: ran" in done.stdout


def test_a_collector_turned_off_stays_off() -> None:
    assert _run("0", young=0).stdout.startswith("0 ")


def test_the_console_script_keeps_its_exit_code() -> None:
    done = subprocess.run(
        [sys.executable, "-c", "from stook.service.cli import main; main()", "show", "nothing"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "nothing" in done.stderr


def test_main_with_arguments_leaves_the_collector_alone() -> None:
    script = (
        "import gc\nfrom stook.service.cli import main\n"
        "try:\n    main(['--version'])\nexcept SystemExit:\n    pass\n"
        "print(gc.get_threshold()[0])"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.stdout.splitlines()[-1] == "700"
