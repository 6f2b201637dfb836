"""What the `stook` console script does to its own process, and no library call does.

Two settings, both measured as whole `stook run` processes (docs/performance.md, "The
process"), both made here and only when `main` is the process's entry point: `main(argv)`
called with arguments (from another program, a test) and every library function leave
the process as they found it.

**Fewer collections.** A fetch allocates a few hundred objects per request, almost all
freed by reference counting as soon as its job is done; at CPython's default threshold the
cyclic collector runs every 700 allocations and finds next to nothing. The console script
raises the youngest generation's threshold to `YOUNG_THRESHOLD` for the whole process:
8-10 % less CPU per whole run (1,000 jobs at 0 ms, 7 interleaved pairs: 1.69 s against
1.83 s). Cycles are still collected, later; what they hold meanwhile is bounded by the
threshold, not by the batch's size.

**No teardown.** When a command returns, its output is in place (written atomically and
fsync'ed, or not at all) and it has said everything it says. What CPython does next is its
finalization: full collections over every object of the ~880 modules a run imported
(polars, numpy, aiohttp, protobuf, rich, ...) while it tears them down one by one: 0.19 s
of a 1.37 s run on the issue-35 harness, 95 % of the time from the output's rename to the
exit. The platform waits for the container to exit, so that is the user's time too, and
nothing of stook's runs in it (no handler, no thread; the run closed its connections). So
`ProcessEnd` ends the process itself, after Python's own exit duties but that teardown:
non-daemon threads have been joined and every `atexit` handler registered after `main`
started (a user's test-metrics function's, multiprocessing's) has run, as `ProcessEnd` is
itself such a handler, registered first. It shuts logging down (flushing every handler),
flushes stdout and stderr, and calls `os._exit` with the command's exit code. Handlers
registered before `main` (interpreter start-up hooks) are skipped; coverage.py measuring a
subprocess saves its data on `os._exit` with its ``patch = _exit`` setting.
"""

from __future__ import annotations

import atexit
import contextlib
import gc
import os
import sys
from typing import Final

__all__ = ["YOUNG_THRESHOLD", "ProcessEnd"]

YOUNG_THRESHOLD: Final = 20_000


class ProcessEnd:
    """Sets the console script's collector; ends the process with `code` once the `atexit`
    handlers registered after it ran."""

    def __init__(self) -> None:
        self.code: int | None = None  # set by `main` once the command has its exit code
        young, *older = gc.get_threshold()
        if young > 0:  # 0 is a collector turned off (PYTHONGC, a parent): it stays off
            gc.set_threshold(max(YOUNG_THRESHOLD, young), *older)
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
