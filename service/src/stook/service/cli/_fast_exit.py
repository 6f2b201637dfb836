"""Ending the `stook run` process without the interpreter's teardown.

When `stook run` returns, its output is written (atomically, fsync'ed, or not at all) and
every line it says has been said. What is left is Python's finalization: tearing down
~800 modules (polars, numpy, aiohttp, protobuf, ...) and their objects, which took ~0.1 s,
a tenth of a whole 400-job run as a user times it (`time stook run`). So the process's
entry point, after `run` only, flushes stdout, stderr and the log handlers and ends the
process with its exit code at once. The `atexit` handlers still run first (a user's
aggregation may have registered one; coverage saves its data in one): what is skipped is
only the teardown of modules and objects. `main(argv)` called with arguments, as from
another program, never ends the process this way.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import sys

__all__ = ["arm", "exit_now_if_armed"]

_armed = False


def arm() -> None:
    """Let the entry point end the process at once when the command is done."""
    global _armed
    _armed = True


def exit_now_if_armed(code: int) -> None:
    """End the process with `code` now, if armed; otherwise return."""
    if not _armed:
        return
    with contextlib.suppress(Exception):
        atexit._run_exitfuncs()  # what an exit runs before the teardown that is skipped
    logging = sys.modules.get("logging")
    if logging is not None:
        with contextlib.suppress(Exception):
            logging.shutdown()  # flushes and closes every handler, as at exit
    for stream in (sys.stdout, sys.stderr):
        # A closed pipe cannot be flushed; the exit code is still the one to give.
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(code)
