"""How far a running shard got, sent from its worker to the driver a few times a second.

Without it a sharded run's progress display would move only when a whole shard finishes.
A worker's shard sends a `ShardProgress` (jobs, or a report's batches, done so far and the
shard client's traffic) every `EVERY_S` seconds while it changed: coalesced, never one
message per job, so that a big shard costs the driver a few small messages a second. The
driver (`LiveShards`) keeps the last report of each shard still running and adds them to
what the finished shards gave; a finished shard's result supersedes its reports, and a
report arriving after it is dropped, so that nothing is counted twice and the final numbers
are the results'.

Progress is best-effort: a report lost (a worker killed) changes only what is shown.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass

from stook.service.modes._open_api import Traffic
from stook.service.modes._progress import Snapshot

__all__ = ["EVERY_S", "LiveShards", "Send", "ShardProgress", "reporting"]

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


class LiveShards:
    """The driver's view of its running shards: the last report of each."""

    def __init__(self) -> None:
        self._running: dict[int, ShardProgress] = {}
        self._finished: set[int] = set()

    def reported(self, progress: ShardProgress) -> None:
        if progress.index not in self._finished:  # late: the result is in already
            self._running[progress.index] = progress

    def finished(self, index: int) -> None:
        """Shard `index`'s result is in: it counts from now on, its reports no longer."""
        self._finished.add(index)
        self._running.pop(index, None)

    def add_to(self, snapshot: Snapshot, traffic: Traffic) -> tuple[Snapshot, Traffic]:
        """What the finished shards (and the driver) did, with the running shards' reports."""
        running = list(self._running.values())
        if not running:
            return snapshot, traffic
        batches = snapshot.batches_done  # None: batch mode
        if batches is not None:
            batches += sum(p.batches_done for p in running)
        snapshot = dataclasses.replace(
            snapshot,
            jobs_done=snapshot.jobs_done + sum(p.jobs_done for p in running),
            jobs_listed=snapshot.jobs_listed + sum(p.jobs_listed for p in running),
            batches_done=batches,
        )
        for progress in running:
            traffic = traffic + progress.traffic
        return snapshot, traffic
