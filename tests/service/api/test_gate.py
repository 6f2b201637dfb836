"""The per-origin gate: failing origins make requests wait together, and resume together."""

from __future__ import annotations

import asyncio
import time
import uuid

import pytest
from aiohttp import web

from stook.service.api._client import ApiClient
from stook.service.api._gate import OriginGate, Passage
from stook.service.api._retry import RetryPolicy
from tests.service.conftest import RecordingSleep
from tests.service.scripted_server import ScriptedServer, answer_json

PROJECT = uuid.UUID("11111111-1111-4111-8111-111111111111")
BATCH = uuid.UUID("22222222-2222-4222-8222-222222222222")
BATCH_PATH = f"/v1/projects/{PROJECT}/batches/{BATCH}"


def gate_on(sleep: RecordingSleep, *, trip_after: int = 5) -> OriginGate:
    """A gate on the recording sleep's clock; the n-th closure lasts n seconds."""
    return OriginGate(
        "the API",
        pause=float,
        max_pause=3.0,
        clock=sleep.now,
        sleep=sleep,
        trip_after=trip_after,
    )


def fail(
    gate: OriginGate,
    *,
    request: object | None = None,
    probe: bool = False,
    retry_after: float | None = None,
) -> None:
    """A transient failure of `request`; by default of a request of its own."""
    gate.failed(
        request=request if request is not None else object(),
        reason="HTTP 503",
        origin="http://api.test",
        retry_after=retry_after,
        probe=probe,
    )


def test_failures_among_answers_leave_it_open(sleep: RecordingSleep) -> None:
    gate = gate_on(sleep)
    for _ in range(3):
        for _ in range(4):
            fail(gate)
        gate.answered(gate.closures)
    assert gate.is_open
    assert gate.stats.trips == 0


def test_one_request_failing_again_and_again_leaves_it_open(sleep: RecordingSleep) -> None:
    """A job whose listings always answer 500 is that job's trouble, not the origin's."""
    gate = gate_on(sleep)
    metrics, data = object(), object()
    for _ in range(50):
        fail(gate, request=metrics)
        fail(gate, request=data)
    assert gate.is_open
    fail(gate)
    fail(gate)
    fail(gate)  # a fifth request: now five have failed with no answer between
    assert not gate.is_open


def real_time_gate() -> OriginGate:
    """A gate on the real clock whose n-th closure lasts n tenths of a second: for waits
    on a probe's outcome, which a clock advanced by the sleep alone cannot show."""
    return OriginGate(
        "the API",
        pause=lambda n: n / 10,
        max_pause=1.0,
        clock=time.monotonic,
        sleep=asyncio.sleep,
    )


async def test_a_run_of_failures_closes_it_and_one_probe_goes_out() -> None:
    gate = real_time_gate()
    closed_at = time.monotonic()
    for _ in range(5):
        fail(gate)
    assert not gate.is_open
    waiting = [asyncio.create_task(gate.enter(deadline=closed_at + 10)) for _ in range(10)]
    first, _ = await asyncio.wait(waiting, return_when=asyncio.FIRST_COMPLETED)
    assert len(first) == 1
    assert time.monotonic() - closed_at >= 0.1  # the first closure: pause(1)
    await asyncio.sleep(0.2)  # the others wait on the probe, however long it takes
    assert [task.result() for task in waiting if task.done()] == [Passage.PROBE]
    # The probe's answer lets every waiter through at once.
    gate.answered(sent_in=gate.closures)
    assert gate.is_open
    results = await asyncio.gather(*waiting)
    assert results.count(Passage.PROBE) == 1
    assert results.count(Passage.OPEN) == 9
    assert gate.stats.probes == 1
    assert gate.stats.reopened == 1


async def test_a_failed_probe_closes_it_for_longer_up_to_the_cap(sleep: RecordingSleep) -> None:
    gate = gate_on(sleep)
    for _ in range(5):
        fail(gate)
    opened_at = []
    for _ in range(4):
        before = sleep.now()
        assert await gate.enter(deadline=100.0) is Passage.PROBE
        opened_at.append(sleep.now() - before)
        fail(gate, probe=True)
    assert opened_at == pytest.approx([1.0, 2.0, 3.0, 3.0])  # pause(n), capped at 3


async def test_failures_echoing_from_before_the_closure_do_not_extend_it(
    sleep: RecordingSleep,
) -> None:
    gate = gate_on(sleep)
    for _ in range(64):  # all 64 workers' requests fail; only the probe's failure counts
        fail(gate)
    assert await gate.enter(deadline=100.0) is Passage.PROBE
    assert sleep.now() == pytest.approx(1.0)


async def test_an_answer_to_a_request_sent_before_the_closure_does_not_reopen_it(
    sleep: RecordingSleep,
) -> None:
    gate = gate_on(sleep)
    sent_in = gate.closures  # a request sent while it was open...
    for _ in range(5):
        fail(gate)
    gate.answered(sent_in)  # ...answered after it closed
    assert not gate.is_open
    gate.answered(gate.closures)  # a request sent since
    assert gate.is_open


async def test_a_retry_after_holds_it_closed_as_long_as_asked(sleep: RecordingSleep) -> None:
    gate = gate_on(sleep)
    for _ in range(4):
        fail(gate)
    fail(gate, retry_after=7.0)
    assert await gate.enter(deadline=100.0) is Passage.PROBE
    assert sleep.now() == pytest.approx(7.0)


async def test_a_waiter_leaves_at_its_deadline(sleep: RecordingSleep) -> None:
    gate = gate_on(sleep)
    for _ in range(5):
        fail(gate)
    assert await gate.enter(deadline=0.5) is Passage.TIMED_OUT
    assert sleep.now() == pytest.approx(0.5)


async def test_a_probe_that_ends_without_news_lets_the_next_one_go() -> None:
    gate = real_time_gate()
    for _ in range(5):
        fail(gate)
    deadline = time.monotonic() + 10
    assert await gate.enter(deadline) is Passage.PROBE
    second = asyncio.create_task(gate.enter(deadline))
    await asyncio.sleep(0.2)
    assert not second.done()  # a probe is out
    gate.probe_finished()  # e.g. cancelled
    assert await asyncio.wait_for(second, 1.0) is Passage.PROBE


async def test_workers_wait_together_at_a_failing_origin(server: ScriptedServer) -> None:
    """64 requests against an API that answers 503 to everything for a while, then recovers.

    Each alone would retry on its own schedule (about 400 requests in that time with these
    backoffs); behind the gate only the first wave and one probe at a time go out, and
    once the API answers every request is through within moments.
    """
    outage = 1.0
    started: list[float] = []
    answered: list[float] = []
    served_in_outage = 0

    async def down_then_up(request: web.Request) -> web.StreamResponse:
        nonlocal served_in_outage
        now = time.monotonic()
        if not started:
            started.append(now)
        if now - started[0] < outage:
            served_in_outage += 1
            return web.json_response({"error": "unavailable"}, status=503)
        answered.append(now)
        return await answer_json({"batchID": str(BATCH), "status": "SUCCEEDED"})(request)

    server.script(BATCH_PATH, down_then_up)
    policy = RetryPolicy(initial_backoff=0.02, max_backoff=0.2, retry_for=20.0)
    async with ApiClient(server.base_url, "tok-" + "x" * 20, retry=policy) as api:
        batches = await asyncio.gather(*(api.get_batch(PROJECT, BATCH) for _ in range(64)))
        gate = api.gate
    assert len(batches) == 64
    assert served_in_outage <= 64 + 25, served_in_outage  # the first wave, then probes
    assert gate.stats.trips == 1
    assert gate.stats.reopened == 1
    assert len(answered) == 64
    assert answered[-1] - answered[0] < 0.5  # resumed together


def test_quiet_says_an_answer_would_change_nothing(sleep: RecordingSleep) -> None:
    """`quiet` is `is_open` with no failure since the last answer: what lets a client skip
    telling the gate of an answer (see ApiClient._get)."""
    gate = gate_on(sleep, trip_after=2)

    def check() -> None:
        assert gate.quiet == (gate.is_open and not gate._failing)

    check()
    fail(gate)
    check()
    gate.answered(gate.closures)
    check()
    fail(gate)
    fail(gate)  # closes it
    check()
    fail(gate)  # an echo
    check()
    gate.answered(gate.closures - 1)  # an answer from before it closed
    check()
    fail(gate, probe=True)
    check()
    gate.answered(gate.closures)  # reopens it
    check()
    assert gate.quiet
