"""polars and numpy (numpy.ma too), imported in a thread while a fetch's first requests wait.

A run needs them only to turn its first downloaded series into a polars Series, and
importing them takes ~0.15-0.25 s. Imported on the event loop's thread at that moment,
they stopped every request in flight for that long (a tenth of a whole 400-job run as a
user times it). So a fetch that will decode series starts the import in a worker thread
as it sends its first request (:func:`start_importing`), and a job that has a series to
decode awaits it (:func:`decoders_ready`) instead of taking the import lock on the loop's
thread: the other jobs go on listing and downloading meanwhile.
"""

from __future__ import annotations

import asyncio
import importlib
import sys

__all__ = ["decoders_loaded", "decoders_ready", "start_importing"]

# numpy.ma too: polars imports it lazily when it first makes a Series from a numpy array
# (the merged histogram's chunks), ~44 M instructions that would otherwise run on the
# loop's thread in the middle of the fetch.
_MODULES = ("numpy", "polars", "numpy.ma")
_importing: asyncio.Future[None] | None = None
# Set once both are seen imported: every job with a series asks, and once is enough.
_ready = False


def _loaded(name: str) -> bool:
    module = sys.modules.get(name)
    # A module is in sys.modules from the start of its import; its spec says when it is done.
    return module is not None and not getattr(module.__spec__, "_initializing", False)


def _import() -> None:
    for name in _MODULES:
        importlib.import_module(name)


def start_importing() -> None:
    """Start importing the decoders in a thread of the running loop, unless they are in."""
    global _importing
    if all(_loaded(name) for name in _MODULES):
        return
    loop = asyncio.get_running_loop()
    if _importing is None or _importing.get_loop() is not loop or _importing.done():
        _importing = loop.run_in_executor(None, _import)


def decoders_loaded() -> bool:
    """Whether `decoders_ready` has seen the decoders imported: then awaiting it is only
    a coroutine made and finished, which a job with a series can skip."""
    return _ready


async def decoders_ready() -> None:
    """Return once polars and numpy (numpy.ma too) are imported, without blocking the
    event loop."""
    global _ready
    if _ready:
        return
    if all(_loaded(name) for name in _MODULES):
        _ready = True
        return
    start_importing()
    assert _importing is not None
    # Shielded: one job cancelled must not cancel the import the others await.
    await asyncio.shield(_importing)
