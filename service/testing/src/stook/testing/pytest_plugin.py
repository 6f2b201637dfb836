"""pytest fixtures for testing metrics builds against an emulated ReSim.

Enable with ``-p stook.testing.pytest_plugin`` or ``pytest_plugins =
["stook.testing.pytest_plugin"]``. Fixtures: ``stook_emulator_config`` (override it to
change the data or faults), ``stook_emulator`` (a running `Emulator`) and
``stook_batch_inputs`` / ``stook_report_inputs`` (an inputs folder holding the platform's
config file). They need pytest-asyncio; the pytest-free helpers are in :mod:`stook.testing`.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest
import pytest_asyncio

from stook.emulator import Emulator, EmulatorConfig
from stook.testing import emulator_config

__all__ = [
    "stook_batch_inputs",
    "stook_emulator",
    "stook_emulator_config",
    "stook_report_inputs",
]


@pytest.fixture
def stook_emulator_config() -> EmulatorConfig:
    """The emulator's settings; override this fixture to change data, faults or paging."""
    return emulator_config()


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
