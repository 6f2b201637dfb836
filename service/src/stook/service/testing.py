"""Helpers for testing metrics builds against an emulated ReSim, like structlog.testing.

In any async test::

    from stook.service.testing import emulated_batch

    async def test_my_batch_metrics(tmp_path):
        async with emulated_batch(tmp_path / "inputs", jobs_per_batch=50) as emu:
            ...  # run the batch metrics build with inputs at tmp_path / "inputs"
            assert emu.stats.leaked_tokens == 0

As a pytest plugin (``-p stook.service.testing``, or listed in ``pytest_plugins``) it
adds fixtures: ``stook_emulator_config`` (override it to change the data or faults),
``stook_emulator`` (a running `Emulator`) and ``stook_batch_inputs`` /
``stook_report_inputs`` (an inputs folder holding the platform's config file). The
fixtures need pytest-asyncio.
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
import pytest_asyncio

from stook.service.emulator import Emulator, EmulatorConfig

__all__ = [
    "emulated_batch",
    "emulated_report",
    "stook_batch_inputs",
    "stook_emulator",
    "stook_emulator_config",
    "stook_report_inputs",
]

# Small pages make every list take several requests, so paging bugs show up in tests.
TEST_DEFAULTS: dict[str, Any] = {"default_page_size": 7, "max_page_size": 10}


def _config(config: EmulatorConfig | None, overrides: dict[str, Any]) -> EmulatorConfig:
    if config is not None:
        return config.replace(**overrides) if overrides else config
    return EmulatorConfig(**{**TEST_DEFAULTS, **overrides})


@contextlib.asynccontextmanager
async def emulated_batch(
    inputs_dir: str | Path, config: EmulatorConfig | None = None, **overrides: Any
) -> AsyncIterator[Emulator]:
    """A running emulator and `inputs_dir/batch_metrics_config.json` pointing at it."""
    async with Emulator(_config(config, overrides)) as emu:
        emu.write_batch_config(inputs_dir)
        yield emu


@contextlib.asynccontextmanager
async def emulated_report(
    inputs_dir: str | Path, config: EmulatorConfig | None = None, **overrides: Any
) -> AsyncIterator[Emulator]:
    """A running emulator and `inputs_dir/report_config.json` pointing at its report."""
    async with Emulator(_config(config, overrides)) as emu:
        emu.write_report_config(inputs_dir)
        yield emu


@pytest.fixture
def stook_emulator_config() -> EmulatorConfig:
    """The emulator's settings; override this fixture to change data, faults or paging."""
    return EmulatorConfig(**TEST_DEFAULTS)


@pytest_asyncio.fixture
async def stook_emulator(stook_emulator_config: EmulatorConfig) -> AsyncIterator[Emulator]:
    async with Emulator(stook_emulator_config) as emu:
        yield emu


@pytest.fixture
def stook_batch_inputs(stook_emulator: Emulator, tmp_path: Path) -> Path:
    """An inputs folder with batch_metrics_config.json for the emulator's main batch."""
    inputs = tmp_path / "inputs"
    stook_emulator.write_batch_config(inputs)
    return inputs


@pytest.fixture
def stook_report_inputs(stook_emulator: Emulator, tmp_path: Path) -> Path:
    """An inputs folder with report_config.json for the emulator's report."""
    inputs = tmp_path / "inputs"
    stook_emulator.write_report_config(inputs)
    return inputs
