"""`[engine] kind = "ray"`: shards as Ray tasks, on a cluster or a local Ray instance.

Ray is imported here only, on first use (`pip install "stook[ray]"`). With `[engine]
address` the run joins that cluster ("auto": the one this machine belongs to,
"ray://head:10001": through Ray Client); without it, it starts a local instance with
`workers` CPUs (default: this machine's) and stops it at the end. Each shard is one task
of one CPU; its argument, the pickled shard, carries the API token: it is never put in a
runtime environment (which Ray logs and shows in its dashboard) nor in a log line.

The workers run stook's code and the user's: they need the same image (or the same
packages and the modules beside stook.toml) as the driver. deploy/README.md has the set-up.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
from collections.abc import Callable, Sequence
from typing import Any

from stook.service.modes._engine_config import RAY_INSTALL_HINT, EngineConfigError, EngineSettings
from stook.service.modes._shard_progress import ShardProgress
from stook.service.modes._shards import LogSettings, run_shard

__all__ = ["RayRunner"]


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
        self._started = False
        if not ray.is_initialized():
            self._init(engine)
            self._started = True
        cpus = int(ray.cluster_resources().get("CPU", 0)) or 1  # type: ignore[no-untyped-call]
        self._workers = engine.workers or cpus
        # A failed shard is failed, not retried: its error is the run's (exit code).
        self._remote = ray.remote(num_cpus=1, max_retries=0)(run_shard)

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
        """Ray tasks send no progress while they run: a run's progress moves per shard."""

    def submit(self, task: bytes) -> asyncio.Future[bytes]:
        ref = self._remote.remote(self._folders, self._logs, task)
        self._refs.append(ref)
        return asyncio.wrap_future(ref.future())

    def close(self, *, abort: bool) -> None:
        if abort:
            for ref in self._refs:
                with contextlib.suppress(Exception):
                    self._ray.cancel(ref, force=True)
        if self._started:
            self._ray.shutdown()
