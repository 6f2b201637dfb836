"""The change-point worker process: the same breakpoints as a search here, bit for bit; the
search here whenever the worker cannot answer, said once; and a worker that ends with its
stdin, quietly, whatever signals it gets."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from stook.sdk._pelt import search
from stook.sdk.aggregations.report import ChangePointWorker
from stook.sdk.aggregations.report import _change_point_worker as worker_module
from stook.sdk.aggregations.report._change_point_worker import _breakpoints, searched_in_worker
from stook.sdk.aggregations.report._change_points import (
    MIN_POINTS,
    MIN_SEGMENT,
    level_shifts,
    penalty,
    rate_shifts,
)


@pytest.fixture
def allowed(monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker may start although this process has imported ruptures (the tests have)."""
    monkeypatch.setattr(worker_module, "_ruptures_imported", lambda: False)


@pytest.fixture(scope="class")
def worker() -> Iterator[ChangePointWorker]:
    """One worker for the comparisons (each start imports ruptures: a second of CPU);
    closed after them, since one runs at a time."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(worker_module, "_ruptures_imported", lambda: False)
        failures: list[str] = []
        with ChangePointWorker(on_failure=failures.append) as started:
            assert started.start(batches=MIN_POINTS)
            yield started
            assert failures == []


def _signals(seed: int) -> list[tuple[str, np.ndarray]]:
    rng = random.Random(seed)
    n = rng.choice([MIN_POINTS, 7, 12, 30, 60])
    level, values = 0.0, []
    for _ in range(n):
        if rng.random() < 0.1:
            level += rng.choice([-1, 1]) * rng.uniform(0.5, 6)
        values.append(level + rng.gauss(0, 1))
    counted = [rng.randint(1, 30) for _ in range(n)]
    share = rng.uniform(0, 0.4)
    failed = [sum(rng.random() < share for _ in range(c)) for c in counted]
    scale = rng.choice([1e-300, 1e-3, 1.0, 1e6, 1e150])
    return [
        ("l2", np.asarray(values).reshape(-1, 1)),
        ("l2", np.asarray([float(round(v)) for v in values]).reshape(-1, 1)),  # exact ties
        ("l2", np.asarray(values).reshape(-1, 1) * scale),
        ("l2", np.full((n, 1), 2.5)),  # constant
        ("l2", np.asarray([0.0, 1.0] * (n // 2) + [0.0] * (n % 2)).reshape(-1, 1)),
        ("binomial", np.column_stack([np.asarray(failed, float), np.asarray(counted, float)])),
        ("binomial", np.column_stack([np.zeros(n), np.asarray(counted, float)])),
        ("binomial", np.column_stack([np.asarray(counted, float)] * 2)),  # always failed
    ]


class TestTheSameBreakpoints:
    """Searches through one worker, against searches here."""

    @pytest.mark.parametrize("seed", range(8))
    def test_the_worker_finds_the_same_breakpoints_as_a_search_here(
        self, worker: ChangePointWorker, seed: int
    ) -> None:
        for kind, signal_ in _signals(seed):
            for pen in (0.5, penalty(len(signal_)), penalty(len(signal_), series=40), 1e9):
                there = searched_in_worker(kind, signal_, pen, MIN_SEGMENT)
                assert there == search(kind, signal_, pen, MIN_SEGMENT), (kind, seed, pen)
        assert worker.running

    def test_level_and_rate_shifts_are_the_same_through_the_worker(
        self, worker: ChangePointWorker
    ) -> None:
        rng = random.Random(3)
        values = [rng.gauss(0, 1) + (4.0 if i >= 20 else 0.0) for i in range(50)]
        counted = [rng.randint(5, 20) for _ in range(50)]
        failed = [
            rng.randint(0, c // 4) + (c // 2 if i >= 30 else 0) for i, c in enumerate(counted)
        ]
        through_worker = (level_shifts(values), rate_shifts(failed, counted))
        assert through_worker[0]
        assert through_worker[1]
        worker_module._active = None  # the same calls, searched here
        try:
            assert (level_shifts(values), rate_shifts(failed, counted)) == through_worker
        finally:
            worker_module._active = worker._worker


def test_a_worker_ignores_ctrl_c_and_ends_with_its_stdin(allowed: None) -> None:
    signal_ = np.arange(10.0).reshape(-1, 1)
    with ChangePointWorker() as started:
        assert started.start(batches=10)
        process = _process(started)
        # In a session of its own, a terminal's Ctrl-C does not reach it; one sent to it
        # once it serves is ignored.
        assert os.getsid(process.pid) == process.pid
        assert searched_in_worker("l2", signal_, 1.0, 1) == search("l2", signal_, 1.0, 1)
        os.kill(process.pid, signal.SIGINT)
        assert searched_in_worker("l2", signal_, 2.0, 1) == search("l2", signal_, 2.0, 1)
    assert process.returncode == 0  # ended at the end of its stdin, and reaped
    assert not started.running
    assert searched_in_worker("l2", signal_, 1.0, 1) is None  # no worker: searched here


def test_a_worker_that_died_is_said_once_and_the_searches_run_here(allowed: None) -> None:
    failures: list[str] = []
    signal_ = np.asarray([0.0] * 8 + [9.0] * 8).reshape(-1, 1)
    with ChangePointWorker(on_failure=failures.append) as started:
        assert started.start(batches=16)
        process = _process(started)
        process.kill()
        process.wait()
        assert level_shifts(signal_[:, 0].tolist())[0].index == 8  # searched here
        assert searched_in_worker("l2", signal_, 1.0, 1) is None
        assert len(failures) == 1
        assert not started.running
    assert process.returncode == -signal.SIGKILL


def test_a_worker_that_answers_garbage_is_killed_and_reaped(
    allowed: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    # `python -m this` prints the Zen of Python: not a message.
    monkeypatch.setattr(worker_module, "_MODULE", "this")
    failures: list[str] = []
    with ChangePointWorker(on_failure=failures.append) as started:
        assert started.start(batches=MIN_POINTS)
        process = _process(started)
        assert searched_in_worker("l2", np.zeros((MIN_POINTS, 1)), 1.0, 1) is None
    assert len(failures) == 1
    assert process.returncode is not None


def test_a_worker_that_does_not_answer_in_time_is_killed(
    allowed: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    # json.tool reads its stdin to the end before it says anything.
    monkeypatch.setattr(worker_module, "_MODULE", "json.tool")
    monkeypatch.setattr(worker_module, "_REPLY_TIMEOUT_S", 0.05)
    failures: list[str] = []
    with ChangePointWorker(on_failure=failures.append) as started:
        assert started.start(batches=MIN_POINTS)
        process = _process(started)
        assert searched_in_worker("l2", np.zeros((MIN_POINTS, 1)), 1.0, 1) is None
        assert process.returncode == -signal.SIGKILL
    assert failures == ["no answer in 0.05 s"]


def test_a_worker_that_cannot_start_is_said_once(
    allowed: None, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(sys, "executable", str(tmp_path / "no-python"))
    failures: list[str] = []
    with ChangePointWorker(on_failure=failures.append) as started:
        assert not started.start(batches=MIN_POINTS)
        assert not started.running
    assert len(failures) == 1
    assert failures[0].startswith("it could not start (FileNotFoundError")


def test_no_worker_for_short_reports_nor_where_ruptures_is_imported(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with ChangePointWorker() as unneeded:
        assert "ruptures" in sys.modules  # this test process searches here more cheaply
        assert not unneeded.start(batches=100)
        monkeypatch.setattr(worker_module, "_ruptures_imported", lambda: False)
        assert not unneeded.start(batches=MIN_POINTS - 1)  # no series long enough
        assert not unneeded.running


def test_one_worker_at_a_time(allowed: None) -> None:
    with ChangePointWorker() as first, ChangePointWorker() as second:
        assert first.start(batches=MIN_POINTS)
        assert not first.start(batches=MIN_POINTS)
        assert not second.start(batches=MIN_POINTS)
        assert first.running
        assert not second.running


def test_a_worker_ends_when_its_parent_dies(tmp_path: Path) -> None:
    parent = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from stook.sdk.aggregations.report import ChangePointWorker as W\n"
            "import sys\n"
            "w = W()\n"
            "assert w.start(batches=10)\n"
            "print(w._worker._process.pid, flush=True)\n"
            "sys.stdin.read()\n",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert parent.stdout is not None
    pid = int(parent.stdout.readline())
    parent.kill()
    parent.wait()
    # Its stdin ends with its parent: it ends by itself (reaped by whoever adopted it).
    deadline = time.monotonic() + 120
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(pid)


@pytest.mark.parametrize(
    ("cuts", "ok"),
    [
        ([], True),
        ([3], True),
        ([1, 5, 9], True),
        ([0, 3], False),
        ([3, 3], False),
        ([5, 3], False),
        ([10], False),
        ([3.0], False),
        ([True], False),
        ((3,), False),
        (None, False),
    ],
)
def test_what_counts_as_breakpoints(cuts: object, ok: bool) -> None:
    assert _breakpoints(cuts, 10) is ok


def _process(started: ChangePointWorker) -> subprocess.Popen[bytes]:
    assert started._worker is not None
    return started._worker._process


def _alive(pid: int) -> bool:
    """Whether `pid` runs (a zombie left to its adopter does not count)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except FileNotFoundError:
        return False
    return "State:\tZ" not in status
