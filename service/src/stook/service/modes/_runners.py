"""Where a sharded run's shards run: local worker processes, or Ray tasks.

Both runners take pickled shards (`_shards.run_shard`) and hand back pickled results;
`modes/_engine.py` drives them through the same four calls (`workers`, `listen`,
`submit`, `close`).

`[engine] kind = "processes"`: shards in local worker processes.

A `ProcessPoolExecutor` of `workers` processes started with *spawn*: forking a process
that runs an event loop and threads (aiohttp's resolver, the signal watchdog) copies
locks in whatever state they were in. Each process puts the user's folders on its import
path and logs as the driver does (`_shards.init_worker`), then runs shards one at a time,
each with its own event loop and client.

The shards' progress (`ShardProgress`) comes back on a queue of the spawn context,
given to each process at its start; a thread of the driver drains it onto the event loop
until the pool is shut down (and its processes have flushed what they sent).

`[engine] kind = "ray"`: shards as Ray tasks, on a cluster or a local Ray instance.

Ray is imported here only, on first use (`pip install "stook[ray]"`). With `[engine]
address` the run joins that cluster ("auto": the one this machine belongs to,
"ray://head:10001": through Ray Client); without it, it starts a local instance with
`workers` CPUs (default: this machine's) and stops it at the end. Each shard is one task
of one CPU; its argument, the pickled shard, carries the API token: it is never put in a
runtime environment (which Ray logs and shows in its dashboard) nor in a log line.

The workers run stook's code and the user's: they need the same image (or the same
packages and the modules beside stook.toml) as the driver. deploy/README.md has the set-up.

The shards' progress (`ShardProgress`) goes to a small actor of no CPU (`_Board`), which
keeps each running shard's last report; the driver takes them from it a few times a second.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import queue
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from stook.service.modes._config import RAY_INSTALL_HINT, EngineSettings
from stook.service.modes._errors import EngineConfigError
from stook.service.modes._shards import EVERY_S, LogSettings, ShardProgress, init_worker, run_shard

if TYPE_CHECKING:
    import multiprocessing

__all__ = ["ProcessRunner", "RayRunner"]


class ProcessRunner:
    def __init__(
        self, engine: EngineSettings, folders: Sequence[str], logs: LogSettings | None
    ) -> None:
        self._workers = engine.workers or os.cpu_count() or 1
        self._folders = list(folders)
        self._logs = logs
        # Imported here, for a processes run only: the pool's machinery (~10 ms) is no
        # part of a local run's start-up.
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

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


def _run_shard(
    folders: Sequence[str], logs: LogSettings | None, task: bytes, progress: _SendTo | None
) -> bytes:
    return run_shard(folders, logs, task, progress)


class _Board:
    """The running shards' last reports, until the driver takes them (a Ray actor)."""

    def __init__(self) -> None:
        self._reports: dict[int, ShardProgress] = {}

    def report(self, progress: ShardProgress) -> None:
        self._reports[progress.index] = progress

    def take(self) -> list[ShardProgress]:
        taken, self._reports = list(self._reports.values()), {}
        return taken


@dataclass(frozen=True, slots=True)
class _SendTo:
    """A shard's `Send` in a Ray task: a report to the board, not waited for."""

    board: Any  # the _Board actor's handle

    def __call__(self, progress: ShardProgress) -> None:
        self.board.report.remote(progress)


class RayRunner:
    def __init__(
        self, engine: EngineSettings, folders: Sequence[str], logs: LogSettings | None
    ) -> None:
        try:
            import ray
        except ImportError as exc:
            raise EngineConfigError(
                f'[engine] kind = "ray" needs Ray, which cannot be imported ({exc}): '
                f"{RAY_INSTALL_HINT}"
            ) from None
        self._ray = ray
        self._folders = list(folders)
        self._logs = logs
        self._refs: list[Any] = []
        self._board: Any = None
        self._polling: asyncio.Task[None] | None = None
        self._started = False
        if not ray.is_initialized():
            self._init(engine)
            self._started = True
        cpus = int(ray.cluster_resources().get("CPU", 0)) or 1  # type: ignore[no-untyped-call]
        self._workers = engine.workers or cpus
        # A failed shard is failed, not retried: its error is the run's (exit code).
        self._remote = ray.remote(num_cpus=1, max_retries=0)(_run_shard)

    def _init(self, engine: EngineSettings) -> None:
        ray = self._ray
        try:
            if engine.address is not None:
                ray.init(address=engine.address, logging_level=logging.WARNING)
            else:
                ray.init(
                    num_cpus=engine.workers or os.cpu_count() or 1,
                    include_dashboard=False,
                    logging_level=logging.WARNING,
                )
        except Exception as exc:  # Ray's errors for an unreachable or refused cluster vary
            where = engine.address or "a local Ray instance"
            raise EngineConfigError(
                f"[engine] address: cannot start or join {where!r} ({type(exc).__name__}: {exc})"
            ) from None

    @property
    def workers(self) -> int:
        return self._workers

    def listen(self, on_progress: Callable[[ShardProgress], None]) -> None:
        self._board = self._ray.remote(num_cpus=0)(_Board).remote()
        self._polling = asyncio.get_running_loop().create_task(self._poll(on_progress))

    async def _poll(self, on_progress: Callable[[ShardProgress], None]) -> None:
        while True:
            await asyncio.sleep(EVERY_S)
            try:
                reports = await asyncio.wrap_future(self._board.take.remote().future())
            except Exception:  # the board is gone (its node lost): progress moves per shard
                return
            for progress in reports:
                on_progress(progress)

    def submit(self, task: bytes) -> asyncio.Future[bytes]:
        send = None if self._board is None else _SendTo(self._board)
        ref = self._remote.remote(self._folders, self._logs, task, send)
        self._refs.append(ref)
        return asyncio.wrap_future(ref.future())

    def close(self, *, abort: bool) -> None:
        if self._polling is not None:
            self._polling.cancel()
        if self._board is not None:
            with contextlib.suppress(Exception):
                self._ray.kill(self._board)
        if abort:
            for ref in self._refs:
                with contextlib.suppress(Exception):
                    self._ray.cancel(ref, force=True)
        if self._started:
            self._ray.shutdown()
