"""Start-up without the cyclic garbage collector.

Importing what a command needs creates objects that live as long as the process (modules,
classes, functions): the collector runs over them again and again during the imports and
finds next to nothing: 10 % of `stook validate`'s instructions (its teardown included)
and 2.5 % of `stook run`'s before its first request. The `stook` process pauses it first
thing, and resumes it once the command's imports are done, with every object alive then
frozen (`gc.freeze`) out of its reach: later collections do not walk the modules either.
A program calling `run_cli` or `main(argv)` keeps its collector as it is.
"""

from __future__ import annotations

import gc

__all__ = ["pause", "resume"]

_paused = False


def pause() -> None:
    """Stop collecting, if the collector is on."""
    global _paused
    if gc.isenabled():
        gc.disable()
        _paused = True


def resume() -> None:
    """Freeze what is alive and collect again, if `pause` stopped the collector."""
    global _paused
    if _paused:
        _paused = False
        gc.freeze()
        gc.enable()
