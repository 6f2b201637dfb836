"""The per-attempt deadlines of a transport, on one timer (api/_deadlines.py)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any, cast

from stook.service.api._deadlines import Deadlines


class FakeTimer:
    def __init__(self, when: float, callback: Callable[[], None]) -> None:
        self.when = when
        self.callback = callback
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class FakeLoop:
    """A clock set by hand, and the timers set on it."""

    def __init__(self) -> None:
        self.now = 0.0
        self.timers: list[FakeTimer] = []

    def time(self) -> float:
        return self.now

    def call_at(self, when: float, callback: Callable[[], None]) -> FakeTimer:
        timer = FakeTimer(when, callback)
        self.timers.append(timer)
        return timer

    def pending(self) -> list[FakeTimer]:
        return [t for t in self.timers if not t.cancelled]

    def run_until(self, now: float) -> None:
        """Advance the clock, running each timer as it comes due."""
        while due := [t for t in self.pending() if t.when <= now]:
            timer = min(due, key=lambda t: t.when)
            self.now = timer.when
            timer.cancelled = True  # a timer runs once
            timer.callback()
        self.now = now


class FakeTask:
    def __init__(self) -> None:
        self.cancels = 0

    def cancel(self) -> bool:
        self.cancels += 1
        return True


def deadlines(loop: FakeLoop, timeout: float) -> Deadlines:
    return Deadlines(cast(asyncio.AbstractEventLoop, loop), timeout)


def task() -> Any:
    return FakeTask()


def test_a_deadline_that_passes_cancels_its_attempt_once() -> None:
    loop = FakeLoop()
    timed = deadlines(loop, 10.0)
    attempt = task()
    timed.start(attempt)
    loop.run_until(9.9)
    assert attempt.cancels == 0
    loop.run_until(10.0)
    assert attempt.cancels == 1
    loop.run_until(100.0)
    assert attempt.cancels == 1
    assert loop.pending() == []  # nothing left to time: the timer is not set again
    assert timed.end(attempt)  # expired
    assert timed._running == {}
    assert timed._expired == set()


def test_an_attempt_that_ended_is_not_cancelled() -> None:
    loop = FakeLoop()
    timed = deadlines(loop, 10.0)
    attempt = task()
    timed.start(attempt)
    assert not timed.end(attempt)
    loop.run_until(100.0)
    assert attempt.cancels == 0


def test_each_attempt_gets_its_own_deadline_on_one_timer() -> None:
    loop = FakeLoop()
    timed = deadlines(loop, 10.0)
    first, second, third = task(), task(), task()
    timed.start(first)
    loop.run_until(3.0)
    timed.start(second)
    loop.run_until(4.0)
    timed.start(third)
    assert not timed.end(first)  # the first ends in time; the others do not
    assert len(loop.pending()) == 1
    loop.run_until(12.9)
    assert [first.cancels, second.cancels, third.cancels] == [0, 0, 0]
    loop.run_until(13.0)
    assert [first.cancels, second.cancels, third.cancels] == [0, 1, 0]
    loop.run_until(13.9)
    assert third.cancels == 0
    loop.run_until(14.0)
    assert [first.cancels, second.cancels, third.cancels] == [0, 1, 1]
    assert (timed.end(second), timed.end(third)) == (True, True)


def test_a_task_attempts_again_after_its_deadline_passed() -> None:
    loop = FakeLoop()
    timed = deadlines(loop, 10.0)
    attempt = task()
    timed.start(attempt)
    loop.run_until(10.0)
    assert timed.end(attempt)
    timed.start(attempt)  # the retry, in the same task
    loop.run_until(19.9)
    assert attempt.cancels == 1
    assert not timed.end(attempt)
    loop.run_until(100.0)
    assert attempt.cancels == 1


def test_deadlines_come_due_in_the_order_attempts_started() -> None:
    # A task whose attempt ended and that attempts again is timed from its new start.
    loop = FakeLoop()
    timed = deadlines(loop, 10.0)
    first, second = task(), task()
    timed.start(first)
    loop.run_until(1.0)
    timed.start(second)
    loop.run_until(2.0)
    timed.end(first)
    timed.start(first)
    loop.run_until(11.0)
    assert [first.cancels, second.cancels] == [0, 1]
    loop.run_until(12.0)
    assert [first.cancels, second.cancels] == [1, 1]


def test_a_timer_that_runs_early_by_the_clocks_resolution_still_expires() -> None:
    # The loop runs a timer up to its clock's resolution before it is due.
    loop = FakeLoop()
    attempt = task()
    deadlines(loop, 10.0).start(attempt)
    (timer,) = loop.pending()
    loop.now = timer.when - 1e-12
    timer.callback()
    assert attempt.cancels == 1


def test_closing_stops_the_timer() -> None:
    loop = FakeLoop()
    timed = deadlines(loop, 10.0)
    attempt = task()
    timed.start(attempt)
    timed.close()
    assert loop.pending() == []
    assert attempt.cancels == 0
    assert not timed.end(attempt)  # an attempt may end after its transport closed


def test_attempts_that_ended_behind_a_slow_one_do_not_pile_up() -> None:
    loop = FakeLoop()
    timed = deadlines(loop, 10.0)
    slow = task()
    timed.start(slow)
    for _ in range(10_000):
        fast = task()
        timed.start(fast)
        timed.end(fast)
    assert len(timed._running) == 1
    loop.run_until(10.0)
    assert slow.cancels == 1
