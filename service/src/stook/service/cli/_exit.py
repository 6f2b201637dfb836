"""How the `stook` process ends: the interpreter's teardown skipped, nothing else.

When a command returns, its output is in place (written atomically and fsync'ed, or not at
all) and it has said everything it says. What CPython does next is its finalization: full
garbage collections over every object the ~880 modules of a run created (polars, numpy,
aiohttp, protobuf, rich, ...) while it tears the modules down one by one. In a `stook run`
process that was 0.19 s of a 1.37 s run on the issue-35 harness, and 95 % of the time from
the output's rename to the process's exit (docs/performance.md, "The end of a run"); the
platform waits for the container to exit, so it is the user's time too. Nothing of stook's
runs in it: no handler, no thread, no open connection (the run closed them).

So the console script ends the process itself, in one place, after Python's own exit duties
except that teardown: non-daemon threads have been joined and every `atexit` handler
registered after `main` started (a user's test-metrics function's, multiprocessing's) has
run, as at any exit. `ProcessEnd` is itself such a handler, registered first, so it runs
last; it shuts logging down (flushing every handler), flushes stdout and stderr, and calls
`os._exit` with the command's exit code. Handlers registered before `main` (interpreter
start-up hooks) are skipped; coverage.py measuring a subprocess saves its data on
`os._exit` with its ``patch = _exit`` setting. `main(argv)` called with arguments, from
another program or a test, never ends its process: it exits as any Python program does.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import sys

__all__ = ["ProcessEnd"]


class ProcessEnd:
    """Ends the process with `code` once the `atexit` handlers registered after it ran."""

    def __init__(self) -> None:
        self.code: int | None = None  # set by `main` once the command has its exit code
        atexit.register(self._end)

    def _end(self) -> None:
        if self.code is None:
            return  # `main` did not finish (an uncaught error): Python's own exit
        logging = sys.modules.get("logging")
        if logging is not None:
            logging.shutdown()
        for stream in (sys.stdout, sys.stderr):
            # A closed pipe cannot be flushed; the exit code is still the command's.
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(self.code)
