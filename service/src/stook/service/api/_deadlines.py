"""The per-attempt timeouts of one transport's requests, kept on one timer.

Each attempt gets a deadline; when it passes before the attempt ends, the attempt's task is
cancelled, and that cancellation (only that one) becomes a TimeoutError in the transport.
A timer of the loop's per attempt (``call_at``, then ``cancel``) costs a TimerHandle made,
pushed onto the loop's heap and popped off it again through comparisons written in Python,
for every request. Every attempt of one transport has the same timeout, so deadlines come
due in the order the attempts started: a queue, checked by one timer set for its oldest
deadline, does the same for an append and a flag per attempt.
"""

from __future__ import annotations

import asyncio
import time
from collections import deque
from typing import Final

__all__ = ["AttemptDeadline", "Deadlines"]

# The loop runs a timer that is due within its clock's resolution (see
# BaseEventLoop._run_once); a deadline that close is due as well.
_RESOLUTION: Final = time.get_clock_info("monotonic").resolution
# Attempts that ended stay queued behind an older one still running; past this many (and
# twice what was left at the last sweep), they are swept out, so the queue stays the size
# of the attempts in flight, not of those a slow one outlived.
_SWEEP_AT: Final = 256


class AttemptDeadline:
    """One attempt's deadline: it cancels the attempt's task once `when` has passed, unless
    the attempt has `ended`, and remembers that it did (`expired`)."""

    __slots__ = ("ended", "expired", "task", "when")

    def __init__(self, task: asyncio.Task[object], when: float) -> None:
        self.task = task
        self.when = when
        self.expired = False
        self.ended = False

    def expire(self) -> None:
        self.expired = True
        self.task.cancel()


class Deadlines:
    """The deadlines of attempts that each get `timeout` seconds, on `loop`'s clock."""

    def __init__(self, loop: asyncio.AbstractEventLoop, timeout: float) -> None:
        self._loop = loop
        self._timeout = timeout
        self._queue: deque[AttemptDeadline] = deque()
        self._timer: asyncio.TimerHandle | None = None
        self._sweep_at = _SWEEP_AT

    def start(self, task: asyncio.Task[object]) -> AttemptDeadline:
        """The deadline of an attempt starting now in `task`; set its `ended` when it ends."""
        deadline = AttemptDeadline(task, self._loop.time() + self._timeout)
        queue = self._queue
        while queue and queue[0].ended:
            queue.popleft()
        queue.append(deadline)
        if len(queue) > self._sweep_at:
            self._queue = queue = deque(d for d in queue if not d.ended)
            self._sweep_at = max(_SWEEP_AT, 2 * len(queue))
        if self._timer is None:
            self._timer = self._loop.call_at(deadline.when, self._check)
        return deadline

    def close(self) -> None:
        """Stop the timer; attempts still queued are not timed any more."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self._queue.clear()

    def _check(self) -> None:
        """Expire every deadline that has passed; the timer is set again for the next."""
        self._timer = None
        due = self._loop.time() + _RESOLUTION
        queue = self._queue
        while queue:
            deadline = queue[0]
            if deadline.ended:
                queue.popleft()
            elif deadline.when <= due:
                queue.popleft()
                deadline.expire()
            else:
                self._timer = self._loop.call_at(deadline.when, self._check)
                return
