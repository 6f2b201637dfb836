"""What runs in a worker: one shard of a run, its progress reports and its failure.

A shard is a contiguous piece of the batch's jobs (or of the report's batches), fetched by
the same asyncio core as a local run (`BatchFetcher`, `ReportFetcher`, given the piece
instead of listing) with `[fetch] concurrency` requests in flight, and folded into fresh
partial states of the run's aggregations. It goes to the worker as pickled bytes, so that
the user's modules (`[[batch.custom]]`) are on the worker's import path before its
aggregations are unpickled, and comes back as pickled bytes: the aggregations' states, one
blob each (their sizes are what the driver logs), and what the fetch saw.

While it runs, a shard sends a `ShardProgress` (jobs, or a report's batches, done so far
and the shard client's traffic) every `EVERY_S` seconds while it changed: coalesced, never
one message per job. Progress is best-effort: a report lost (a worker killed) changes only
what is shown.

A shard's failure comes back as plain values (`RemoteError`): exceptions do not reliably
survive pickling (ours take keyword-only arguments, and a user's aggregation may raise
anything). So a worker sends the error's class (by import path) and its one-line, already
redacted message; the driver raises an instance of the same class with that message, so
that the run's exit code and its one line are what a local run gives. Errors that are not
stook's own also carry the worker's traceback, as a note, for the unexpected-error report.

The token travels inside the shard's `ApiAccess`, whose repr hides it; it is in no log line.

Where the shards run, worker processes or Ray tasks (`ProcessRunner`, `RayRunner`), is
at the end of this module.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib
import logging
import os
import pickle
import queue
import signal
import sys
import threading
import time
import traceback
import uuid
from collections.abc import AsyncIterator, Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

from stook.sdk import StookError
from stook.sdk.aggregations import Aggregation, Needs
from stook.service.api import (
    ApiClient,
    Batch,
    Job,
    Report,
    RetryPolicy,
    redact_text,
)
from stook.service.fetch import BatchFetcher, FetchOutcome, ReportFetcher, ReportOutcome
from stook.service.modes._config import RAY_INSTALL_HINT, EngineSettings, FetchSettings
from stook.service.modes._errors import EngineConfigError, ShardError
from stook.service.modes._event_loop import run_on_event_loop
from stook.service.modes._inputs import ApiAccess
from stook.service.modes._logging import configure_logging
from stook.service.modes._pipeline import Fetcher, Traffic, fetch_records

if TYPE_CHECKING:
    import multiprocessing

#: Seconds between a shard's reports: the display redraws at most 4 times a second.
EVERY_S = 0.25


@dataclass(frozen=True, slots=True)
class ShardProgress:
    index: int  # the shard's
    jobs_done: int
    jobs_listed: int = 0  # report mode: the jobs its batches' listings gave so far
    batches_done: int = 0  # report mode
    requests: int = 0
    retries: int = 0
    bytes_received: int = 0

    @property
    def traffic(self) -> Traffic:
        return Traffic(
            requests=self.requests, retries=self.retries, bytes_received=self.bytes_received
        )


#: Where a worker sends its reports (a queue's put); it must not block for long.
Send = Callable[[ShardProgress], None]


@contextlib.asynccontextmanager
async def reporting(
    read: Callable[[], ShardProgress], send: Send | None, every: float = EVERY_S
) -> AsyncIterator[None]:
    """While the block runs, `send` what `read` says every `every` seconds, if it changed."""
    if send is None:
        yield
        return

    async def report() -> None:
        last = None
        while True:
            await asyncio.sleep(every)
            now = read()
            if now != last:
                send(now)
                last = now

    task = asyncio.create_task(report())
    try:
        yield
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


@dataclass(frozen=True, slots=True)
class RemoteError:
    module: str
    qualname: str
    message: str
    trace: str | None = None  # the worker's traceback, for errors that are not stook's

    @classmethod
    def of(cls, error: BaseException) -> RemoteError:
        kind = type(error)
        trace = None
        if not isinstance(error, StookError):
            trace = redact_text("".join(traceback.format_exception(error)))
        return cls(kind.__module__, kind.__qualname__, redact_text(str(error)), trace)

    def rebuild(self) -> Exception:
        """An exception of the worker's class with its message (ShardError if it cannot be)."""
        kind = _find(self.module, self.qualname)
        error: Exception
        if kind is not None and issubclass(kind, Exception):
            # Not kind(message): constructors with keyword-only arguments would refuse it.
            error = kind.__new__(kind, self.message)
            Exception.__init__(error, self.message)
        else:
            error = ShardError(f"{self.qualname}: {self.message}")
        if self.trace is not None:
            error.add_note(f"in a worker:\n{self.trace}")
        return error


def _find(module: str, qualname: str) -> type | None:
    try:
        found: object = importlib.import_module(module)
        for part in qualname.split("."):
            found = getattr(found, part)
    except (ImportError, AttributeError):
        return None
    return found if isinstance(found, type) else None


_T = TypeVar("_T")
_O = TypeVar("_O")
_O_co = TypeVar("_O_co", covariant=True)

#: Where this worker sends its shards' progress (`init_worker`); None: nowhere.
_send_progress: Send | None = None

#: How a worker logs: (JSON lines or not, None: as its stderr decides; the level).
LogSettings = tuple[bool | None, str]


def split(items: Sequence[_T], shards: int) -> list[list[_T]]:
    """`items` in at most `shards` contiguous pieces, in order, none empty, sizes within one."""
    count = min(shards, len(items))
    if count == 0:
        return []
    size, extra = divmod(len(items), count)
    pieces, start = [], 0
    for index in range(count):
        end = start + size + (index < extra)
        pieces.append(list(items[start:end]))
        start = end
    return pieces


@dataclass(slots=True)
class _Shard:
    index: int
    access: ApiAccess
    settings: FetchSettings
    retry: RetryPolicy | None
    needs: Needs
    aggregations: list[Aggregation[Any]]

    def fold(self, record: Any) -> None:
        for aggregation in self.aggregations:
            aggregation.update(record)

    async def _fetch(
        self,
        fetcher_for: Callable[[ApiClient], Fetcher[Any, _O]],
        progress_of: Callable[[_O, Traffic], ShardProgress],
        send: Send | None,
    ) -> tuple[_O, Traffic]:
        """The shard's piece fetched and folded, its progress sent while it runs (the
        deadline is the driver's)."""

        def watch(
            fetcher: Fetcher[Any, _O], api: ApiClient
        ) -> contextlib.AbstractAsyncContextManager[None]:
            return reporting(lambda: progress_of(fetcher.outcome, Traffic.of(api)), send)

        return await fetch_records(
            self.access, self.settings, fetcher_for, self.fold, retry=self.retry, watch=watch
        )


@dataclass(slots=True)
class BatchShard(_Shard):
    batch_id: uuid.UUID
    jobs: list[Job]

    @property
    def size(self) -> int:
        return len(self.jobs)

    async def fetch(self, send: Send | None = None) -> tuple[FetchOutcome, Traffic]:
        def fetcher_for(api: ApiClient) -> BatchFetcher:
            return BatchFetcher(
                api,
                self.access.project_id,
                self.batch_id,
                self.needs,
                jobs=self.jobs,
            )

        def progress_of(outcome: FetchOutcome, traffic: Traffic) -> ShardProgress:
            return ShardProgress(
                self.index,
                jobs_done=outcome.jobs_done + len(outcome.missing),  # as batch mode shows
                requests=traffic.requests,
                retries=traffic.retries,
                bytes_received=traffic.bytes_received,
            )

        return await self._fetch(fetcher_for, progress_of, send)


@dataclass(slots=True)
class ReportShard(_Shard):
    report_id: uuid.UUID
    use_summaries: bool
    report: Report
    batches: list[Batch]

    @property
    def size(self) -> int:
        return len(self.batches)

    async def fetch(self, send: Send | None = None) -> tuple[ReportOutcome, Traffic]:
        def fetcher_for(api: ApiClient) -> ReportFetcher:
            return ReportFetcher(
                api,
                self.access.project_id,
                self.report_id,
                self.needs,
                use_summaries=self.use_summaries,
                batches=(self.report, self.batches),
            )

        def progress_of(outcome: ReportOutcome, traffic: Traffic) -> ShardProgress:
            return ShardProgress(
                self.index,
                jobs_done=outcome.jobs_done,  # as report mode shows
                jobs_listed=outcome.jobs,
                batches_done=outcome.batches_done,
                requests=traffic.requests,
                retries=traffic.retries,
                bytes_received=traffic.bytes_received,
            )

        return await self._fetch(fetcher_for, progress_of, send)


@dataclass(frozen=True, slots=True)
class ShardDone:
    index: int
    size: int  # jobs (batch mode) or batches (report mode) in the shard
    states: list[bytes]  # each aggregation's pickled partial state, in the run's order
    outcome: FetchOutcome | ReportOutcome
    requests: int
    retries: int
    bytes_received: int
    seconds: float


@dataclass(frozen=True, slots=True)
class ShardFailed:
    index: int
    error: RemoteError


def init_worker(
    folders: Sequence[str], logs: LogSettings | None, progress: Send | None = None
) -> None:
    """A pool process's start: the user's folders on the path, logging as the driver's,
    and where its shards' progress goes (`ShardProgress`).

    SIGINT is the driver's to handle (Ctrl-C reaches the whole process group): it stops the
    workers itself, so they say nothing of their own.
    """
    global _send_progress
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _send_progress = progress
    _prepare(folders, logs)


def run_shard(
    folders: Sequence[str], logs: LogSettings | None, task: bytes, progress: Send | None = None
) -> bytes:
    """The worker's entry point: fetch and fold one pickled shard; a pickled result back.
    Its progress goes to `progress`, or to where `init_worker` said.

    Never raises for the shard's own failures: they come back as `ShardFailed`.
    """
    _prepare(folders, logs)
    started = time.monotonic()
    index = -1
    try:
        shard: BatchShard | ReportShard = pickle.loads(task)
        index = shard.index
        outcome, traffic = run_on_event_loop(_fetch(shard, progress or _send_progress))
        done = ShardDone(
            index=index,
            size=shard.size,
            states=[pickle.dumps(a, protocol=pickle.HIGHEST_PROTOCOL) for a in shard.aggregations],
            outcome=outcome,
            requests=traffic.requests,
            retries=traffic.retries,
            bytes_received=traffic.bytes_received,
            seconds=time.monotonic() - started,
        )
        return pickle.dumps(done, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as error:
        return pickle.dumps(ShardFailed(index, RemoteError.of(error)))


async def _fetch(
    shard: BatchShard | ReportShard, send: Send | None
) -> tuple[FetchOutcome | ReportOutcome, Traffic]:
    if isinstance(shard, BatchShard):
        return await shard.fetch(send)
    return await shard.fetch(send)


def _prepare(folders: Sequence[str], logs: LogSettings | None) -> None:
    for folder in reversed(folders):
        if folder not in sys.path:
            sys.path.insert(0, folder)
    if logs is not None:
        json, level = logs
        configure_logging(json=json, level=level)


# --- where shards run: worker processes or Ray -----------------------------------------------

# Where a sharded run's shards run: local worker processes, or Ray tasks.
#
# Both runners take pickled shards (`_shards.run_shard`) and hand back pickled results;
# `modes/_engine.py` drives them through the same four calls (`workers`, `listen`,
# `submit`, `close`).
#
# `[engine] kind = "processes"`: shards in local worker processes.
#
# A `ProcessPoolExecutor` of `workers` processes started with *spawn*: forking a process
# that runs an event loop and threads (aiohttp's resolver, the signal watchdog) copies
# locks in whatever state they were in. Each process puts the user's folders on its import
# path and logs as the driver does (`_shards.init_worker`), then runs shards one at a time,
# each with its own event loop and client.
#
# The shards' progress (`ShardProgress`) comes back on a queue of the spawn context,
# given to each process at its start; a thread of the driver drains it onto the event loop
# until the pool is shut down (and its processes have flushed what they sent).
#
# `[engine] kind = "ray"`: shards as Ray tasks, on a cluster or a local Ray instance.
#
# Ray is imported here only, on first use (`pip install "stook[ray]"`). With `[engine]
# address` the run joins that cluster ("auto": the one this machine belongs to,
# "ray://head:10001": through Ray Client); without it, it starts a local instance with
# `workers` CPUs (default: this machine's) and stops it at the end. Each shard is one task
# of one CPU; its argument, the pickled shard, carries the API token: it is never put in a
# runtime environment (which Ray logs and shows in its dashboard) nor in a log line.
#
# The workers run stook's code and the user's: they need the same image (or the same
# packages and the modules beside stook.toml) as the driver. deploy/README.md has the set-up.
#
# The shards' progress (`ShardProgress`) goes to a small actor of no CPU (`_Board`), which
# keeps each running shard's last report; the driver takes them from it a few times a second.


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
