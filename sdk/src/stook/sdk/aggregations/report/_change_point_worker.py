"""`ChangePointWorker`: the report's change-point searches in a worker process.

A report's change points are searched once every batch is in, and the first search imports
ruptures, which imports scipy's sparse, spatial, optimize, stats and signal packages:
about a second of CPU, after the fetch, in a process that a fast API keeps busy from its
first request to its last. A worker process (`stook.sdk._pelt_worker`) started when the
report's batches are known imports it on another core while the fetch goes on; the
searches then run there, the same code on the same float64 arrays, so the breakpoints
are the same bit for bit.

Whatever goes wrong with the worker (it cannot start, dies, takes longer than
`_REPLY_TIMEOUT_S` for an answer, or answers something that is not breakpoints), the
search runs in this process instead, and so does every later one: it is said once (the
`on_failure` callback), and the report is the same.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import os
import subprocess
import sys
import threading
from collections.abc import Callable
from concurrent.futures import Future, InvalidStateError
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

from stook.sdk._pelt_worker import read_message, write_message

if TYPE_CHECKING:
    import numpy as np

__all__ = ["ChangePointWorker", "searched_in_worker"]

# How long a search waits for its answer, the worker's import of ruptures included when
# the fetch ended first (about a second; far more on a loaded machine, where searching
# here would first import it all the same).
_REPLY_TIMEOUT_S = 60.0
# How long closing waits for the worker to end at the end of its stdin (a few ms when it
# waits for a request; it reads its stdin only once ruptures is imported) before killing it.
_EXIT_WAIT_S = 0.5
_MODULE = "stook.sdk._pelt_worker"

_log = logging.getLogger("stook.sdk.change_points")

# The worker this process's searches go to: one at a time, that of the first running
# `ChangePointWorker`.
_active: _Worker | None = None
_active_lock = threading.Lock()


def searched_in_worker(
    kind: str, signal: np.ndarray, pen: float, min_size: int
) -> list[int] | None:
    """The breakpoints from the running worker; None without one, or when it failed."""
    worker = _active
    return None if worker is None else worker.search(kind, signal, pen, min_size)


class ChangePointWorker:
    """Runs this process's report change-point searches in a worker process, from `start`
    to `close` (or the end of a ``with`` block).

    `start` when the report's batches are known; it starts nothing when no series is long
    enough for a search, when ruptures is already imported here (searching here is then
    cheaper), or when another `ChangePointWorker` of this process is running. A worker
    that fails is said once to `on_failure` (default: a debug line on the
    ``stook.sdk.change_points`` logger), and the searches run in this process.
    """

    def __init__(self, on_failure: Callable[[str], None] | None = None) -> None:
        self._on_failure = on_failure or _log_failure
        self._worker: _Worker | None = None

    def start(self, *, batches: int) -> bool:
        """Start the worker for a report of `batches` batches; whether it started."""
        global _active
        from stook.sdk.aggregations.report._change_points import MIN_POINTS

        if self._worker is not None or batches < MIN_POINTS or _ruptures_imported():
            return False
        with _active_lock:
            if _active is not None:
                return False
            worker = _Worker.start(self._on_failure)
            if worker is None:
                return False
            _active = self._worker = worker
        return True

    @property
    def running(self) -> bool:
        """Whether searches go to this worker (started, not closed, not failed)."""
        return self._worker is not None and not self._worker.failed

    def close(self) -> None:
        """End the worker (its stdin closed; it exits at its end) and wait for it."""
        global _active
        worker, self._worker = self._worker, None
        if worker is None:
            return
        with _active_lock:
            if _active is worker:
                _active = None
        worker.close()

    def __enter__(self) -> ChangePointWorker:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()


def _ruptures_imported() -> bool:
    return "ruptures" in sys.modules


def _log_failure(reason: str) -> None:
    _log.debug("change-point worker failed, searching in this process: %s", reason)


class _Worker:
    """One worker process: requests written under a lock, answers read by a thread and
    handed to the waiting search by request id (no lock is held while waiting)."""

    def __init__(self, process: subprocess.Popen[bytes], on_failure: Callable[[str], None]):
        self._process = process
        self._on_failure = on_failure
        self._pending: dict[int, Future[Any]] = {}
        self._ids = itertools.count()
        self._send_lock = threading.Lock()
        self._state_lock = threading.Lock()
        self.failed = False
        self._closing = False
        self._ended = False  # the answers' stream ended
        self._reader = threading.Thread(
            target=self._read_answers, name="stook-change-point-answers", daemon=True
        )
        self._reader.start()

    @classmethod
    def start(cls, on_failure: Callable[[str], None]) -> _Worker | None:
        try:
            process = subprocess.Popen(
                # -P: the working directory is no place to import from
                [sys.executable, "-P", "-m", _MODULE],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                env=_environment(),
                # Out of the terminal's process group: Ctrl-C is for the parent, which
                # ends the run and closes the worker's stdin.
                start_new_session=True,
            )
        except (OSError, ValueError, subprocess.SubprocessError) as exc:
            on_failure(f"it could not start ({type(exc).__name__}: {exc})")
            return None
        return cls(process, on_failure)

    def search(self, kind: str, signal: np.ndarray, pen: float, min_size: int) -> list[int] | None:
        if self.failed:
            return None
        ident = next(self._ids)
        answer: Future[Any] = Future()
        self._pending[ident] = answer
        try:
            if self._ended:
                raise EOFError("it had ended")
            stdin = self._process.stdin
            assert stdin is not None
            with self._send_lock:
                write_message(stdin, (ident, kind, signal, pen, min_size))
            cuts = answer.result(timeout=_REPLY_TIMEOUT_S)
        except TimeoutError:
            self._fail(f"no answer in {_REPLY_TIMEOUT_S:g} s")
            return None
        except Exception as exc:
            self._fail(f"{type(exc).__name__}: {exc}")
            return None
        finally:
            self._pending.pop(ident, None)
        if cuts is None:
            return None  # the search raised there: here it raises the same, in its caller
        if not _breakpoints(cuts, len(signal)):
            self._fail("it answered something other than breakpoints")
            return None
        return list(cuts)

    def _read_answers(self) -> None:
        stdout = self._process.stdout
        assert stdout is not None
        error: BaseException = EOFError("it ended")
        try:
            while (message := read_message(stdout)) is not None:
                ident, cuts = message
                answer = self._pending.pop(ident, None)
                if answer is not None:
                    answer.set_result(cuts)
        except Exception as exc:  # a broken message: the searches waiting say so
            error = exc
        finally:
            self._ended = True
            for answer in list(self._pending.values()):
                with contextlib.suppress(InvalidStateError):
                    answer.set_exception(error)

    def _fail(self, reason: str) -> None:
        with self._state_lock:
            said = self.failed or self._closing
            self.failed = True
        if not said:
            self._on_failure(reason)
        self._process.kill()  # a no-op once it has exited
        self._process.wait()

    def close(self) -> None:
        with self._state_lock:
            self._closing = True
        with contextlib.suppress(OSError):
            if self._process.stdin is not None:
                self._process.stdin.close()
        try:
            self._process.wait(timeout=_EXIT_WAIT_S)
        except subprocess.TimeoutExpired:  # still importing: nothing of it is needed now
            self._process.kill()
            self._process.wait()
        self._reader.join()
        if self._process.stdout is not None:
            self._process.stdout.close()


def _breakpoints(cuts: Any, n: int) -> bool:
    """Whether `cuts` can be a search's answer for a series of `n`: increasing positions
    inside it."""
    if not isinstance(cuts, list) or not all(type(c) is int for c in cuts):
        return False
    return all(a < b for a, b in itertools.pairwise([0, *cuts, n]))


def _environment() -> dict[str, str]:
    """This environment, with the SDK's source root first on PYTHONPATH: the worker
    imports `stook.sdk` from where this process did, however this process found it."""
    root = str(Path(__file__).resolve().parents[4])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH")) if p)
    return env
