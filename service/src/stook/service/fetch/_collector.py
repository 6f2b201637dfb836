"""Fewer cyclic garbage collections while a fetch runs.

A fetch allocates a few hundred objects per request (answers, listing items, records),
almost all freed by reference counting as soon as a job is done; yet at the default
threshold (a young collection every 700 allocations, an older one every tenth) the
collector ran ~170 times in a 1,000-job run, and each full collection walked the ~90,000
objects the imports left behind: ~38 µs of CPU per request at 0 ms latency, 14 % of the
client's (docs/benchmarks.md's history, in git). While a fetch runs, the objects that
existed before it are frozen (never scanned: they live for the whole process anyway) and
a young collection waits for 20,000 allocations. Cycles are still collected, later; the
memory they can hold meanwhile is bounded by that threshold, not by the batch's size.
Both are undone when the last fetch running ends.
"""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator
from typing import Final

__all__ = ["FETCH_GC_THRESHOLD", "fewer_collections"]

FETCH_GC_THRESHOLD: Final = 20_000

# Fetches may nest or overlap (a baseline's fetch beside its candidate's): the settings
# are the process's, so the first to start sets them and the last to end restores them.
_running = 0
_saved: tuple[int, int, int] | None = None
_froze = False


@contextlib.contextmanager
def fewer_collections() -> Iterator[None]:
    global _running, _saved, _froze
    if _running == 0:
        _saved = gc.get_threshold()
        # Objects someone else froze stay theirs: unfrozen at the end only if frozen here.
        _froze = gc.get_freeze_count() == 0
        if _froze:
            gc.freeze()
        if _saved[0] > 0:  # 0 turns the collector off: it stays off
            gc.set_threshold(max(FETCH_GC_THRESHOLD, _saved[0]), *_saved[1:])
    _running += 1
    try:
        yield
    finally:
        _running -= 1
        if _running == 0 and _saved is not None:
            gc.set_threshold(*_saved)
            if _froze:
                gc.unfreeze()
            _saved = None
