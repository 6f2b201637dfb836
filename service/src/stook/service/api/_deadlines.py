"""The per-attempt timeouts of one transport's requests, kept on one timer.

Each attempt gets a deadline; when it passes before the attempt ends, the attempt's task is
cancelled, and that cancellation (only that one) becomes a TimeoutError in the transport.
A timer of the loop's per attempt (``call_at``, then ``cancel``) costs a TimerHandle made,
pushed onto the loop's heap and popped off it again through comparisons written in Python,
for every request. Every attempt of one transport has the same timeout, so deadlines come
due in the order the attempts started: the attempts running, oldest first, checked by one
timer set for the oldest deadline, do the same for a dict entry set and deleted per attempt.
"""

from __future__ import annotations

import asyncio
import time
from typing import Final

__all__ = ["Deadlines"]

# The loop runs a timer that is due within its clock's resolution (see
# BaseEventLoop._run_once); a deadline that close is due as well.
_RESOLUTION: Final = time.get_clock_info("monotonic").resolution


class Deadlines:
    """The deadlines of attempts that each get `timeout` seconds, on `loop`'s clock.

    An attempt is known by its task: a task runs one attempt of a transport at a time.
    """

    def __init__(self, loop: asyncio.AbstractEventLoop, timeout: float) -> None:
        self._loop = loop
        self._timeout = timeout
        # The deadline of each attempt running, by its task; a dict keeps the order the
        # attempts started in, the order their deadlines come due. An entry per attempt, not
        # an object: one made and dropped per request cost three times as much.
        self._running: dict[asyncio.Task[object], float] = {}
        # The tasks whose attempt's deadline passed (and were cancelled for it), until
        # their attempt ends.
        self._expired: set[asyncio.Task[object]] = set()
        self._timer: asyncio.TimerHandle | None = None

    def start(self, task: asyncio.Task[object]) -> None:
        """An attempt starts now in `task`; `end` it when it ends, however it ends."""
        when = self._loop.time() + self._timeout
        self._running[task] = when
        if self._timer is None:
            self._timer = self._loop.call_at(when, self._check)

    def end(self, task: asyncio.Task[object]) -> bool:
        """The attempt of `task` ended: whether its deadline passed (the task was then
        cancelled once, for it)."""
        expired = self._expired
        if expired and task in expired:
            expired.remove(task)
            return True
        # Not `del`: a transport closed while its requests ran has forgotten them.
        self._running.pop(task, None)
        return False

    def close(self) -> None:
        """Stop the timer; attempts still running are not timed any more."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self._running.clear()

    def _check(self) -> None:
        """Expire every deadline that has passed; the timer is set again for the next."""
        self._timer = None
        due = self._loop.time() + _RESOLUTION
        running = self._running
        passed = []
        for task, when in running.items():
            if when > due:
                self._timer = self._loop.call_at(when, self._check)
                break
            passed.append(task)
        for task in passed:
            del running[task]
            self._expired.add(task)
            task.cancel()
