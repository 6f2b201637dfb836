"""Report mode with its change points searched in a worker process: the bytes of a run
that searches in its own process, locally and on the processes engine, and the same
bytes when the worker dies before the search."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import Emulator
from stook.sdk.aggregations.report import _change_point_worker as worker_module
from tests.e2e.engines import run_engine
from tests.e2e.support import EmulatorThread, config

pytestmark = pytest.mark.slow

PROCESSES = '[engine]\nkind = "processes"\nworkers = 2\nshards = 3\n'


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    # A step change, so that the searches find something.
    emulator_config = config(
        seed=5, report_batches=9, report_jobs_per_batch=4, report_step_change_batch=5
    )
    with EmulatorThread(emulator_config) as emulator:
        yield emulator


@pytest.fixture
def searched(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Where each search ran ("worker" or "here"), with the worker allowed to start
    (this test process has imported ruptures)."""
    monkeypatch.setattr(worker_module, "_ruptures_imported", lambda: False)
    where: list[str] = []
    real = worker_module.searched_in_worker

    def spy(*args: object) -> list[int] | None:
        cuts = real(*args)  # type: ignore[arg-type]
        where.append("here" if cuts is None else "worker")
        return cuts

    monkeypatch.setattr("stook.sdk.aggregations.report._change_points.searched_in_worker", spy)
    return where


@pytest.fixture(scope="module")
def here(emu: Emulator, tmp_path_factory: pytest.TempPathFactory) -> bytes:
    """The report searched in this process (ruptures imported here: no worker starts)."""
    return run_engine(emu, tmp_path_factory.mktemp("here"), toml="", report=True).output


@pytest.mark.parametrize("engine", ["", PROCESSES])
def test_the_worker_writes_the_bytes_of_a_search_here(
    emu: Emulator, here: bytes, searched: list[str], tmp_path: Path, engine: str
) -> None:
    assert run_engine(emu, tmp_path, toml=engine, report=True).output == here
    assert searched
    assert set(searched) == {"worker"}
    assert worker_module._active is None  # closed with the run


def test_a_worker_killed_before_the_search_changes_nothing(
    emu: Emulator,
    here: bytes,
    searched: list[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    started = worker_module._Worker.start

    def start_and_kill(on_failure: object) -> worker_module._Worker | None:
        worker = started(on_failure)  # type: ignore[arg-type]
        assert worker is not None
        worker._process.kill()
        return worker

    monkeypatch.setattr(worker_module._Worker, "start", staticmethod(start_and_kill))
    run = run_engine(emu, tmp_path, "--log-level", "debug", toml="", report=True)
    assert run.output == here
    assert searched
    assert set(searched) == {"here"}
    said = [line for line in run.err.splitlines() if "change-point worker failed" in line]
    assert len(said) == 1, run.err
