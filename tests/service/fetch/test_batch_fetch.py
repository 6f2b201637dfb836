"""The hand-off of listed jobs from the lister to the workers (fetch/_batch_fetch.py)."""

from __future__ import annotations

import asyncio
from typing import Any, cast

import pytest

from stook.service.api import Job
from stook.service.fetch._batch_fetch import _JobQueue


def jobs(n: int) -> list[Job]:
    # Stand-ins: the queue hands on what it is given.
    return [cast(Job, i) for i in range(n)]


async def test_every_job_is_taken_once_in_order_and_the_workers_stop() -> None:
    queue: _JobQueue[Job] = _JobQueue(room=4, low=2)
    taken: list[Any] = []
    put = most_queued = 0

    async def work(*, while_plenty: bool = False) -> None:
        while True:
            if while_plenty and not queue.plenty():
                return
            job = queue.take()
            if job is None:
                if await queue.more():
                    continue
                return
            taken.append(job)
            await asyncio.sleep(0)

    async def lister() -> None:  # a worker too, as BatchFetcher's
        nonlocal put, most_queued
        for job in jobs(50):
            full = queue.put(job)
            put += 1
            most_queued = max(most_queued, put - len(taken))  # put and not taken yet
            if full:
                assert queue.plenty()
                await work(while_plenty=True)
                assert put - len(taken) <= 2
                assert not queue.plenty()
        queue.close()
        await work()

    async with asyncio.TaskGroup() as group:
        group.create_task(lister())
        for _ in range(2):
            group.create_task(work())
    assert taken == jobs(50)
    assert most_queued == 4


async def test_workers_of_an_empty_queue_stop_once_it_is_closed() -> None:
    queue: _JobQueue[Job] = _JobQueue(room=4, low=2)
    waiting = [asyncio.ensure_future(queue.more()) for _ in range(3)]
    await asyncio.sleep(0)
    queue.put(jobs(1)[0])
    await asyncio.sleep(0)
    assert [w.done() for w in waiting] == [True, False, False]
    assert waiting[0].result() is True
    queue.put(jobs(2)[1])
    queue.close()
    assert queue.take() == jobs(2)[0]
    assert await asyncio.gather(*waiting[1:]) == [True, True]  # one job is left
    assert queue.take() == jobs(2)[1]  # a job listed before the close is still taken
    assert await queue.more() is False


async def test_a_worker_cancelled_once_woken_passes_the_job_on() -> None:
    queue: _JobQueue[Job] = _JobQueue(room=4, low=2)
    first = asyncio.ensure_future(queue.more())
    second = asyncio.ensure_future(queue.more())
    await asyncio.sleep(0)
    queue.put(jobs(1)[0])  # wakes the first
    first.cancel()
    with pytest.raises(asyncio.CancelledError):
        await first
    assert await second is True
    assert queue.take() == jobs(2)[0]
