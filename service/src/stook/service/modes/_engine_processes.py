"""`[engine] kind = "processes"`: shards in local worker processes.

A `ProcessPoolExecutor` of `workers` processes started with *spawn*: forking a process
that runs an event loop and threads (aiohttp's resolver, the signal watchdog) copies
locks in whatever state they were in. Each process puts the user's folders on its import
path and logs as the driver does (`_shards.init_worker`), then runs shards one at a time,
each with its own event loop and client.

The shards' progress (`_shard_progress`) comes back on a queue of the spawn context,
given to each process at its start; a thread of the driver drains it onto the event loop
until the pool is shut down (and its processes have flushed what they sent).
"""

from __future__ import annotations

import asyncio
import contextlib
import multiprocessing
import os
import queue
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor

from stook.service.modes._engine_config import EngineSettings
from stook.service.modes._shard_progress import ShardProgress
from stook.service.modes._shards import LogSettings, init_worker, run_shard

__all__ = ["ProcessRunner"]


class ProcessRunner:
    def __init__(
        self, engine: EngineSettings, folders: Sequence[str], logs: LogSettings | None
    ) -> None:
        self._workers = engine.workers or os.cpu_count() or 1
        self._folders = list(folders)
        self._logs = logs
        self._futures: list[asyncio.Future[bytes]] = []
        context = multiprocessing.get_context("spawn")
        self._progress: multiprocessing.Queue[ShardProgress] = context.Queue()
        self._drain: threading.Thread | None = None
        self._stop = threading.Event()
        self._pool = ProcessPoolExecutor(
            max_workers=self._workers,
            mp_context=context,
            initializer=init_worker,
            initargs=(self._folders, logs, self._progress.put),
        )

    @property
    def workers(self) -> int:
        return self._workers

    def listen(self, on_progress: Callable[[ShardProgress], None]) -> None:
        loop = asyncio.get_running_loop()
        self._drain = threading.Thread(
            target=self._drain_progress,
            args=(loop, on_progress),
            name="stook-shard-progress",
            daemon=True,
        )
        self._drain.start()

    def _drain_progress(
        self, loop: asyncio.AbstractEventLoop, on_progress: Callable[[ShardProgress], None]
    ) -> None:
        # A timeout, not a sentinel put by the driver: a worker terminated while writing
        # could hold the queue's write lock, and the driver's put would then wait forever.
        while not self._stop.is_set():
            try:
                progress = self._progress.get(timeout=0.1)
                loop.call_soon_threadsafe(on_progress, progress)
            except queue.Empty:
                continue
            except (EOFError, OSError, ValueError, RuntimeError):  # closed: queue or loop
                return

    def submit(self, task: bytes) -> asyncio.Future[bytes]:
        future = asyncio.wrap_future(self._pool.submit(run_shard, self._folders, self._logs, task))
        self._futures.append(future)
        return future

    def close(self, *, abort: bool) -> None:
        try:
            self._shutdown(abort=abort)
        finally:
            self._stop.set()
            if self._drain is not None:
                self._drain.join()
            self._progress.close()

    def _shutdown(self, *, abort: bool) -> None:
        if not abort:
            self._pool.shutdown(wait=True)
            return
        # Shards still running would go on to their end: stop their processes. (Python
        # 3.14's executor has terminate_workers(); before it, its process table.)
        for future in self._futures:
            future.cancel()  # a result (or a broken pool) arriving later is then dropped
        processes = list((getattr(self._pool, "_processes", None) or {}).values())
        self._pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            with contextlib.suppress(Exception):
                process.terminate()
        for process in processes:
            with contextlib.suppress(Exception):
                process.join(timeout=1.0)
