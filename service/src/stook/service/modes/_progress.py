"""A one-line progress display for terminals: jobs done of listed, requests/s, retries."""

from __future__ import annotations

import sys
import time
from typing import Protocol, TextIO


class Progress(Protocol):
    def update(self, *, done: int, listed: int, requests: int, retries: int) -> None: ...

    def close(self) -> None: ...


class NoProgress:
    def update(self, *, done: int, listed: int, requests: int, retries: int) -> None:
        pass

    def close(self) -> None:
        pass


class TerminalProgress:
    """Redraws one line at most `hz` times a second; only meant for a TTY."""

    def __init__(self, stream: TextIO | None = None, *, label: str = "jobs", hz: float = 8.0):
        self._stream = stream or sys.stderr
        self._label = label
        self._interval = 1.0 / hz
        self._started = time.monotonic()
        self._last = 0.0
        self._drawn = False

    def update(self, *, done: int, listed: int, requests: int, retries: int) -> None:
        now = time.monotonic()
        if now - self._last < self._interval:
            return
        self._last = now
        rate = requests / max(now - self._started, 1e-9)
        line = (
            f"{self._label} {done}/{listed}  {rate:,.0f} req/s  "
            f"{retries} retries  {now - self._started:.1f}s"
        )
        self._stream.write("\r\x1b[2K" + line)
        self._stream.flush()
        self._drawn = True

    def close(self) -> None:
        if self._drawn:
            self._stream.write("\r\x1b[2K")
            self._stream.flush()


def for_stream(stream: TextIO | None = None, *, label: str = "jobs") -> Progress:
    out = stream or sys.stderr
    try:
        tty = out.isatty()
    except (AttributeError, ValueError):
        tty = False
    return TerminalProgress(out, label=label) if tty else NoProgress()


class Tally:
    """A Progress that remembers the last counts it was given, for the line that an
    interrupted run ends with; it passes every update on to the display it wraps."""

    def __init__(self, shown: Progress | None = None) -> None:
        self._shown = shown or NoProgress()
        self.done = 0
        self.listed = 0

    def update(self, *, done: int, listed: int, requests: int, retries: int) -> None:
        self.done, self.listed = done, listed
        self._shown.update(done=done, listed=listed, requests=requests, retries=retries)

    def close(self) -> None:
        self._shown.close()
