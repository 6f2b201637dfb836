"""`stook run` as a real process, its stderr read line by line while it runs: for tests
that signal it, time it, or must not wait for ever when it hangs."""

from __future__ import annotations

import os
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def stook_command() -> list[str]:
    script = Path(sys.executable).parent / "stook"
    if script.exists():
        return [str(script)]
    return [sys.executable, "-c", "from stook.service.cli import main; main()"]


def catches(pid: int, signum: int) -> bool:
    """Whether process `pid` has a handler of its own for `signum` (Linux /proc)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("SigCgt:"):
            return bool(int(line.split()[1], 16) >> (signum - 1) & 1)
    return False


class StookProcess:
    """``stook run --inputs tmp/inputs --outputs tmp/outputs ARGS`` started in `tmp`, with
    no STOOK_* settings from the environment and the repository on the import path."""

    def __init__(
        self,
        tmp: Path,
        *args: str,
        toml: str | None = None,
        python_path: Sequence[Path] = (),
    ) -> None:
        self.outputs = tmp / "outputs"
        argv = [*stook_command(), "run", "--inputs", str(tmp / "inputs")]
        argv += ["--outputs", str(self.outputs), *args]
        if toml is not None:
            (tmp / "stook.toml").write_text(toml)
            argv += ["--config", str(tmp / "stook.toml")]
        env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
        env["PYTHONPATH"] = os.pathsep.join([*map(str, python_path), str(REPO)])
        self.started = time.monotonic()
        self.proc = subprocess.Popen(
            argv,
            cwd=tmp,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines: list[str] = []
        self._fresh: queue.Queue[str | None] = queue.Queue()
        self._reader = threading.Thread(target=self._pump, daemon=True)
        self._reader.start()

    def _pump(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))
            self._fresh.put(line)
        self._fresh.put(None)

    @property
    def err(self) -> str:
        return "\n".join(self.lines)

    def wait_for_line(self, text: str, timeout: float = 60.0) -> None:
        """Until a line of stderr holds `text`."""
        deadline = time.monotonic() + timeout
        while not any(text in line for line in self.lines):
            try:
                line = self._fresh.get(timeout=max(deadline - time.monotonic(), 0.0))
            except queue.Empty:
                self.kill()
                pytest.fail(f"no line with {text!r} in {timeout:g} s:\n{self.err}")
            if line is None:
                pytest.fail(f"stook exited before a line with {text!r}:\n{self.err}")

    def wait_until(self, ready: Callable[[], bool], what: str, timeout: float = 60.0) -> None:
        """Until `ready()` is true, polled every millisecond while the process runs."""
        deadline = time.monotonic() + timeout
        while not ready():
            if self.proc.poll() is not None:
                pytest.fail(f"stook exited before {what}:\n{self.err}")
            if time.monotonic() > deadline:
                self.kill()
                pytest.fail(f"not {what} in {timeout:g} s:\n{self.err}")
            time.sleep(0.001)

    def finish(self, timeout: float) -> int:
        """The exit status; a process still running after `timeout` seconds hangs."""
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            pytest.fail(f"stook still running after {timeout:g} s (hung):\n{self.err}")
        self._reader.join(10)
        return code

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)
        self._reader.join(10)
