"""ruptures, imported in a thread while report mode waits on the network
(see `import_change_points_when_idle`).

The change-point search (sdk/aggregations/report/_change_points.py) runs once every batch
is in, and its first call imports ruptures, which imports scipy's sparse, spatial,
optimize, stats and signal packages: about a second of CPU. Where the fetch waits on
the network (a slow API), that second fits into the waiting. Where it does not (a fast
API: the fetch keeps the process busy), a thread importing alongside only takes the GIL
from the fetch, and the import costs the same a little later; so the thread imports a
package at a time, and only after a moment in which the process used less than
`_BUSY` of a CPU. The search imports ruptures as before: what the thread has imported
is ready, a package it is importing makes the search wait for it, and an import that
failed in the thread is tried again (and fails, if it does) there.
"""

from __future__ import annotations

import importlib
import sys
import threading
import time

# ruptures' heavy imports, a fraction of a second each, in the order it imports them.
_STEPS = ("scipy.sparse", "scipy.spatial", "scipy.optimize", "scipy.stats", "scipy.signal")
# How long a look at the process's CPU use takes (long enough that the report's first
# requests, the only wait of a fast fetch, do not look like one), and the share of a CPU
# above which the process is busy.
_WINDOW = 0.2
_BUSY = 0.6


def import_change_points_when_idle() -> threading.Thread:
    """Start importing ruptures in a daemon thread (a process that ends first need not wait)."""
    thread = threading.Thread(target=_import_when_idle, name="stook-import-ruptures", daemon=True)
    thread.start()
    return thread


def _import_when_idle() -> None:
    for module in (*_STEPS, "ruptures"):
        while _busy():
            if "ruptures" in sys.modules:  # the search got there first
                return
        try:
            importlib.import_module(module)
        except Exception:  # the search imports it itself, and says why it fails there
            return


def _busy() -> bool:
    """Whether the process used more than `_BUSY` of a CPU over the next `_WINDOW`."""
    wall, cpu = time.monotonic(), time.process_time()
    time.sleep(_WINDOW)
    return time.process_time() - cpu > _BUSY * (time.monotonic() - wall)
