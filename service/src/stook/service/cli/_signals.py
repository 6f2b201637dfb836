"""SIGINT and SIGTERM end `stook` promptly: exit 130 or 143, one line, no partial output.

Where the program is when a signal arrives decides what the handler does:

- No event loop running (start-up imports, argument parsing): it raises `Interrupted`
  on the spot, as Python does with KeyboardInterrupt, for SIGTERM too.
- The loop running another task, or the loop itself: raising there could leave asyncio
  or aiohttp half-updated, so the handler cancels the main task instead. The
  cancellation unwinds every task group, and `run` turns it into `Interrupted`.
- The main task itself running: that is synchronous work (folding in the last job,
  finishing aggregations, writing the output), which no cancellation could reach before
  it ends, so the handler raises on the spot. A write cut short this way removes its
  temporary file on the way out.

A run that has already produced its outcome (written its output or failed) ignores
later signals: the process is leaving anyway. When `install` took the process's
signals, a watchdog also ends the process `GRACE_S` after the first signal, should
the unwinding itself ever get stuck.

Only the standard library is imported here: `main` installs the handlers before the
commands import aiohttp or polars, so that a signal during those ends in one line too.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import asyncio
    from collections.abc import Callable, Coroutine, Iterator
    from types import FrameType
    from typing import Any, Final, TypeVar

    _T = TypeVar("_T")

__all__ = ["GRACE_S", "SIGNALS", "Interrupted", "handled", "install", "run"]

SIGNALS: Final = (signal.SIGINT, signal.SIGTERM)
# Seconds from the first signal to a forced exit, inside the 2 s that stook promises.
GRACE_S: Final = 1.5


class Interrupted(BaseException):
    """SIGINT or SIGTERM asked stook to stop.

    A BaseException like KeyboardInterrupt, so that no ``except Exception`` on its way
    up (a retry loop, a user's aggregation) can swallow it.
    """

    def __init__(self, signum: int) -> None:
        self.signum = signum
        super().__init__(f"interrupted by {self.signal_name}")

    @property
    def signal_name(self) -> str:
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        """128 + the signal's number, the shell's convention: 130 for SIGINT, 143 for SIGTERM."""
        return 128 + self.signum


class _Guard:
    """The process's one signal handler and what it knows about the running program."""

    def __init__(self) -> None:
        self.reset()
        # Called by the watchdog before it ends the process; it says the one line.
        self.on_give_up: Callable[[Interrupted], object] | None = None
        # Set by the first signal, for the watchdog thread that `install` starts. The
        # handler only sets an event: starting a thread from a signal handler could wait
        # for a lock that the interrupted code holds.
        self.alarm: threading.Event | None = None

    def reset(self) -> None:
        self.signum: int | None = None
        self.settled = False
        self.loop: asyncio.AbstractEventLoop | None = None
        self.main_task: asyncio.Task[Any] | None = None

    def handle(self, signum: int, _frame: FrameType | None) -> None:
        if self.settled:
            return  # the outcome is decided and being reported; the process is leaving
        loop, task = self.loop, self.main_task
        if task is not None and task.done():
            return  # the run has ended; its result or error is on its way out
        if self.signum is None:
            self.signum = signum
            if self.alarm is not None:
                self.alarm.set()
        if loop is None or task is None:
            raise Interrupted(signum)
        import asyncio

        if asyncio.current_task(loop) is task:
            raise Interrupted(signum)
        loop.call_soon_threadsafe(task.cancel)

    def watch(self, alarm: threading.Event) -> None:
        """The watchdog thread: from the first signal, `GRACE_S` for the run to end."""
        alarm.wait()
        if self.signum is not None:
            time.sleep(GRACE_S)
            self._give_up(self.signum)

    def _give_up(self, signum: int) -> None:
        stop = Interrupted(signum)
        if self.on_give_up is not None:
            with contextlib.suppress(Exception):
                self.on_give_up(stop)
        # The one hard exit: the main thread is stuck (that is why we are here), so
        # sys.exit from this thread could not end the process; `stook` promises to end
        # within 2 s of a signal, whatever the run was doing.
        os._exit(stop.exit_code)

    def quiet_after_signal(self, loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        """The loop's exception handler: once a signal arrived, what tasks report while
        they are torn down are echoes of the interruption, not news."""
        if self.signum is None:
            loop.default_exception_handler(context)


_guard = _Guard()


def install(*, on_give_up: Callable[[Interrupted], object] | None = None) -> None:
    """Take SIGINT and SIGTERM for the whole process (the `stook` entry point, first thing).

    Also starts the watchdog, which `handled` alone does not: a test calling `run_cli` in
    its own process must never be ended by it.
    """
    if _guard.alarm is None:
        _guard.alarm = threading.Event()
        watchdog = threading.Thread(
            target=_guard.watch, args=(_guard.alarm,), name="stook-signal-watchdog", daemon=True
        )
        watchdog.start()
    _guard.on_give_up = on_give_up
    for signum in SIGNALS:
        signal.signal(signum, _guard.handle)


@contextlib.contextmanager
def handled(*, on_give_up: Callable[[Interrupted], object] | None = None) -> Iterator[None]:
    """Signals handled as described above for one command; the previous handlers after it.

    Outside the main thread signals cannot be handled (nor arrive); then this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.getsignal(signum) for signum in SIGNALS}
    _guard.reset()
    if on_give_up is not None:
        _guard.on_give_up = on_give_up
    for signum in SIGNALS:
        signal.signal(signum, _guard.handle)
    try:
        yield
    finally:
        _guard.settled = True
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def settle() -> None:
    """The command's outcome is decided: later signals change nothing."""
    _guard.settled = True


def run(
    main: Coroutine[Any, Any, _T],
    *,
    loop_factory: Callable[[], asyncio.AbstractEventLoop] | None = None,
) -> _T:
    """`asyncio.run(main)` on the loop `loop_factory` makes (asyncio's own by default),
    where SIGINT and SIGTERM cancel `main` and raise Interrupted."""
    import asyncio

    async def guarded() -> _T:
        loop = asyncio.get_running_loop()
        loop.set_exception_handler(_guard.quiet_after_signal)
        _guard.loop, _guard.main_task = loop, asyncio.current_task()
        return await main

    try:
        with asyncio.Runner(loop_factory=loop_factory) as runner:
            result = runner.run(guarded())
    except BaseException as error:
        main.close()  # never started if the signal came first; no "never awaited" warning
        _guard.loop = _guard.main_task = None
        # Whatever the cancellation surfaced as, a signal is why the run ended.
        if _guard.signum is not None and not isinstance(error, Interrupted):
            raise Interrupted(_guard.signum) from None
        raise
    # Completed: the output is in place, and a signal from now on cannot take it back.
    _guard.settled = True
    _guard.loop = _guard.main_task = None
    return result
