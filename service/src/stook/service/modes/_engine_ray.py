"""`[engine] kind = "ray"`: shards as Ray tasks, on a cluster or a local Ray instance.

Ray is imported here only, on first use (`pip install "stook[ray]"`). With `[engine]
address` the run joins that cluster ("auto": the one this machine belongs to,
"ray://head:10001": through Ray Client); without it, it starts a local instance with
`workers` CPUs (default: this machine's) and stops it at the end. Each shard is one task
of one CPU; its argument, the pickled shard, carries the API token: it is never put in a
runtime environment (which Ray logs and shows in its dashboard) nor in a log line.

The workers run stook's code and the user's: they need the same image (or the same
packages and the modules beside stook.toml) as the driver. deploy/README.md has the set-up.

The shards' progress (`_shard_progress`) goes to a small actor of no CPU (`_Board`), which
keeps each running shard's last report; the driver takes them from it a few times a second.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from stook.service.modes._engine_config import RAY_INSTALL_HINT, EngineConfigError, EngineSettings
from stook.service.modes._shard_progress import EVERY_S, ShardProgress
from stook.service.modes._shards import LogSettings, run_shard

__all__ = ["RayRunner"]


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
