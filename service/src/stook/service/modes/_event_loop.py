"""The event loop of stook's own runs: uvloop where it is installed, else asyncio's.

uvloop runs the loop in libuv, compiled, where asyncio runs it in Python: every request
wakes the loop several times, so a batch run at 0 ms latency and concurrency 64 costs
3.8 % fewer instructions with it, and ~4 % less wall time on a quiet machine (on a loaded
one the noise hides it; docs/performance.md). It is a dependency of
stook wherever it has wheels (CPython, not Windows); elsewhere asyncio's loop runs, and
every run works the same on either.

``STOOK_EVENT_LOOP`` picks by hand: ``asyncio`` (asyncio's own loop: to tell a uvloop
problem from stook's), ``uvloop`` (insist: exit 2 when it is not installed) or ``auto``
(the default: uvloop when it imports).
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable, Coroutine
from typing import Any, Final, TypeVar

from stook.service.modes._errors import ConfigError

__all__ = ["EVENT_LOOP_ENV", "event_loop_factory", "run_on_event_loop"]

EVENT_LOOP_ENV: Final = "STOOK_EVENT_LOOP"
_CHOICES: Final = ("auto", "uvloop", "asyncio")

_T = TypeVar("_T")


def event_loop_factory() -> Callable[[], asyncio.AbstractEventLoop] | None:
    """What makes the loop of a run (``asyncio.Runner``'s `loop_factory`): uvloop's, or
    None for asyncio's own. Raises :class:`ConfigError` for a ``STOOK_EVENT_LOOP`` it cannot
    honour."""
    choice = os.environ.get(EVENT_LOOP_ENV, "auto").strip().lower() or "auto"
    if choice not in _CHOICES:
        raise ConfigError(f"{EVENT_LOOP_ENV} must be auto, uvloop or asyncio, got {choice!r}")
    if choice == "asyncio":
        return None
    try:
        import uvloop
    except ImportError:
        if choice == "uvloop":
            raise ConfigError(
                f"{EVENT_LOOP_ENV}=uvloop, but uvloop is not installed here "
                "(pip install uvloop, or set it to auto or asyncio)"
            ) from None
        return None
    factory: Callable[[], asyncio.AbstractEventLoop] = uvloop.new_event_loop
    return factory


def run_on_event_loop(main: Coroutine[Any, Any, _T]) -> _T:
    """``asyncio.run(main)`` on the loop `event_loop_factory` picks."""
    try:
        factory = event_loop_factory()
    except ConfigError:
        main.close()  # never started: no "never awaited" warning
        raise
    with asyncio.Runner(loop_factory=factory) as runner:
        return runner.run(main)
