"""`stook` on a real pseudo-terminal of a given width, and what a person would see on it:
the bytes it wrote played on a small screen that wraps at the width as a terminal does."""

from __future__ import annotations

import fcntl
import os
import pty
import re
import struct
import subprocess
import termios
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True, slots=True)
class TerminalRun:
    code: int
    output: str  # as written, escape sequences and all

    def screen(self, width: int) -> list[str]:
        return Screen(width).play(self.output)


def run_on_a_terminal(
    argv: Sequence[str],
    *,
    cwd: Path,
    env: dict[str, str],
    width: int,
    ctrl_c_when: Callable[[str], bool] | None = None,
    timeout: float = 60.0,
) -> TerminalRun:
    """`argv` with stdin, stdout and stderr on a pseudo-terminal `width` columns wide, its
    controlling terminal. With `ctrl_c_when`, Ctrl-C is typed (the byte 0x03, which the
    terminal turns into SIGINT and echoes as "^C") as soon as the output so far satisfies
    it."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, width, 0, 0))
    env = {k: v for k, v in env.items() if k not in ("COLUMNS", "LINES")}
    proc = subprocess.Popen(
        list(argv),
        cwd=cwd,
        env={**env, "TERM": "xterm-256color"},
        stdin=slave,
        stdout=slave,
        stderr=slave,
        start_new_session=True,  # a session of its own, the terminal its controlling one
        preexec_fn=lambda: fcntl.ioctl(0, termios.TIOCSCTTY, 0),
    )
    os.close(slave)
    chunks: list[bytes] = []

    def pump() -> None:
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # EIO: the last holder of the terminal has gone
                return
            if not chunk:
                return
            chunks.append(chunk)

    reader = threading.Thread(target=pump, daemon=True)
    reader.start()
    try:
        if ctrl_c_when is not None:
            deadline = time.monotonic() + timeout
            while proc.poll() is None and time.monotonic() < deadline:
                if ctrl_c_when(b"".join(chunks).decode("utf-8", "replace")):
                    os.write(master, b"\x03")
                    break
                time.sleep(0.02)
        code = proc.wait(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
        reader.join(10)
        os.close(master)
    return TerminalRun(code, b"".join(chunks).decode("utf-8", "replace"))


_CONTROL = re.compile(r"\x1b\[([0-9;?]*)([A-Za-z])|\x1b[()][0-9A-Za-z]|[\r\n\b]")


class Screen:
    """The rows a terminal `width` columns wide shows after some output: text wraps at
    the last column as xterm does (the cursor waits there until the next character);
    carriage return, line feed, backspace, cursor up and erase-line are followed; other
    escape sequences (colours, cursor shown or hidden) change nothing on it."""

    def __init__(self, width: int) -> None:
        self.width = width
        self.rows: list[list[str]] = [[]]
        self.row = self.col = 0
        self.pending_wrap = False

    def play(self, output: str) -> list[str]:
        at = 0
        for match in _CONTROL.finditer(output):
            self._text(output[at : match.start()])
            at = match.end()
            self._control(match)
        self._text(output[at:])
        return ["".join(row).rstrip() for row in self.rows]

    def _text(self, text: str) -> None:
        for char in text:
            if self.pending_wrap:
                self._move_to(self.row + 1, 0)
            row = self.rows[self.row]
            row.extend(" " * (self.col + 1 - len(row)))
            row[self.col] = char
            if self.col == self.width - 1:
                self.pending_wrap = True
            else:
                self.col += 1

    def _control(self, match: re.Match[str]) -> None:
        token = match.group(0)
        if token == "\r":
            self._move_to(self.row, 0)
        elif token == "\n":
            self._move_to(self.row + 1, self.col)
        elif token == "\b":
            self._move_to(self.row, max(self.col - 1, 0))
        elif match.group(2) == "A":
            self._move_to(max(self.row - int(match.group(1) or 1), 0), self.col)
        elif match.group(2) == "K" and match.group(1) == "2":
            self.rows[self.row] = []

    def _move_to(self, row: int, col: int) -> None:
        while len(self.rows) <= row:
            self.rows.append([])
        self.row, self.col, self.pending_wrap = row, col, False
