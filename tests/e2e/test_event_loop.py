"""The event loop a run runs on: uvloop where installed, asyncio's by ``STOOK_EVENT_LOOP``.

Either loop gives the same bytes; a choice that cannot be honoured is exit 2, said once,
before the first request.
"""

from __future__ import annotations

import asyncio
import inspect
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import uvloop

from stook.emulator import Emulator
from stook.service.cli import run_cli
from stook.service.modes import ConfigError, event_loop_factory, run_on_event_loop
from tests.e2e.support import (
    BATCH_TOML,
    OUTPUT_NAME,
    EmulatorThread,
    config,
    outputs_left,
    write_batch_inputs,
)
from tests.failures import failure_lines

# No ./stook.toml and no STOOK_* settings from the environment (tests/e2e/conftest.py).
pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=30, seed=17)) as emulator:
        yield emulator


async def _loop_type() -> type[asyncio.AbstractEventLoop]:
    return type(asyncio.get_running_loop())


@pytest.mark.parametrize(
    ("choice", "loop_type"),
    [
        (None, uvloop.Loop),
        ("auto", uvloop.Loop),
        (" UVLOOP ", uvloop.Loop),
        ("asyncio", asyncio.SelectorEventLoop),
    ],
)
def test_a_run_runs_on_the_loop_chosen(
    monkeypatch: pytest.MonkeyPatch, choice: str | None, loop_type: type[object]
) -> None:
    if choice is None:
        monkeypatch.delenv("STOOK_EVENT_LOOP", raising=False)
    else:
        monkeypatch.setenv("STOOK_EVENT_LOOP", choice)
    assert run_on_event_loop(_loop_type()) is loop_type


def test_without_uvloop_auto_is_asyncio_and_uvloop_is_refused(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "uvloop", None)  # `import uvloop` raises ImportError
    monkeypatch.setenv("STOOK_EVENT_LOOP", "auto")
    assert event_loop_factory() is None
    assert run_on_event_loop(_loop_type()) is asyncio.SelectorEventLoop
    monkeypatch.setenv("STOOK_EVENT_LOOP", "uvloop")
    with pytest.raises(ConfigError, match="STOOK_EVENT_LOOP=uvloop, but uvloop is not installed"):
        event_loop_factory()


def test_a_refused_choice_leaves_no_coroutine_unawaited(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STOOK_EVENT_LOOP", "trio")
    main = _loop_type()
    with pytest.raises(ConfigError, match="STOOK_EVENT_LOOP must be auto, uvloop or asyncio"):
        run_on_event_loop(main)
    # Closed, so never reported as "never awaited".
    assert inspect.getcoroutinestate(main) == inspect.CORO_CLOSED


def _run(tmp_path: Path, emu: Emulator, name: str) -> tuple[int, Path]:
    inputs = tmp_path / name / "inputs"
    write_batch_inputs(inputs, emu)
    toml = tmp_path / name / "stook.toml"
    toml.write_text(BATCH_TOML)
    outputs = tmp_path / name / "outputs"
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--config", str(toml)]
    return run_cli([*argv, "--log-format", "json"]), outputs


def test_both_loops_write_the_same_bytes(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, emu: Emulator
) -> None:
    written = {}
    for choice in ("uvloop", "asyncio"):
        monkeypatch.setenv("STOOK_EVENT_LOOP", choice)
        code, outputs = _run(tmp_path, emu, choice)
        assert code == 0
        written[choice] = (outputs / OUTPUT_NAME).read_bytes()
    assert written["uvloop"] == written["asyncio"]


def test_a_bad_choice_is_exit_2_before_the_first_request(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    emu: Emulator,
) -> None:
    monkeypatch.setenv("STOOK_EVENT_LOOP", "tokio")
    before = emu.stats.requests["api"]
    code, outputs = _run(tmp_path, emu, "bad")
    err = capsys.readouterr().err
    assert code == 2, err
    lines = failure_lines(err)
    assert len(lines) == 1, err
    assert "STOOK_EVENT_LOOP must be auto, uvloop or asyncio, got 'tokio'" in lines[0]
    assert "Traceback" not in err
    assert emu.stats.requests["api"] == before
    assert outputs_left(outputs) == []
