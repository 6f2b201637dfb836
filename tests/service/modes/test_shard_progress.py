"""The running shards' progress: added to the finished shards', superseded by a result,
and sent by a worker only when it changed."""

from __future__ import annotations

import asyncio

from stook.service.modes._engine import ShardsProgress
from stook.service.modes._pipeline import Traffic
from stook.service.modes._progress import FetchProgress
from stook.service.modes._shards import ShardProgress, reporting


def test_running_shards_add_their_jobs_and_traffic() -> None:
    live = ShardsProgress()
    live.reported(ShardProgress(0, jobs_done=3, requests=10, retries=1, bytes_received=500))
    live.reported(ShardProgress(1, jobs_done=2, requests=7, bytes_received=300))
    live.reported(ShardProgress(0, jobs_done=5, requests=16, retries=1, bytes_received=800))
    snapshot, traffic = live.add_to(
        FetchProgress(jobs_done=0, jobs_listed=20, jobs_total=20), Traffic(requests=2)
    )
    assert (snapshot.jobs_done, snapshot.jobs_listed, snapshot.batches_done) == (7, 20, None)
    assert (traffic.requests, traffic.retries, traffic.bytes_received) == (25, 1, 1100)


def test_a_result_supersedes_its_shard_s_reports_even_late_ones() -> None:
    live = ShardsProgress()
    live.reported(ShardProgress(0, jobs_done=4, requests=9))
    live.finished(0)  # its result is now in the driver's outcome
    live.reported(ShardProgress(0, jobs_done=5, requests=11))  # sent before, read after
    base = FetchProgress(jobs_done=6, jobs_listed=6)
    assert live.add_to(base, Traffic(requests=12)) == (base, Traffic(requests=12))


def test_a_report_s_batches_and_listed_jobs_are_added() -> None:
    live = ShardsProgress()
    live.reported(ShardProgress(1, jobs_done=8, jobs_listed=12, batches_done=2))
    snapshot, _ = live.add_to(
        FetchProgress(jobs_done=10, jobs_listed=10, batches_done=3, batches_total=9), Traffic()
    )
    assert (snapshot.jobs_done, snapshot.jobs_listed, snapshot.batches_done) == (18, 22, 5)
    assert snapshot.batches_total == 9


def test_a_worker_sends_only_what_changed() -> None:
    sent: list[ShardProgress] = []
    done = 0

    def read() -> ShardProgress:
        return ShardProgress(0, jobs_done=done)

    async def run() -> None:
        nonlocal done
        async with reporting(read, sent.append, every=0.01):
            await asyncio.sleep(0.1)  # nothing done: one report of 0
            done = 3
            await asyncio.sleep(0.1)

    asyncio.run(run())
    assert [p.jobs_done for p in sent] == [0, 3]


def test_without_a_sink_nothing_is_started() -> None:
    async def run() -> int:
        async with reporting(lambda: ShardProgress(0, jobs_done=0), None):
            return len(asyncio.all_tasks())

    assert asyncio.run(run()) == 1  # the run itself only
