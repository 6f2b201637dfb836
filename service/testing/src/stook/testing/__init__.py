"""Helpers for testing metrics builds against an emulated ReSim, like structlog.testing.

Nothing here needs pytest. In any async test::

    from stook.testing import emulated_batch

    async def test_my_batch_metrics(tmp_path):
        async with emulated_batch(tmp_path / "inputs", jobs_per_batch=50) as emu:
            ...  # run the batch metrics build with inputs at tmp_path / "inputs"
            assert emu.stats.leaked_tokens == 0

The pytest fixtures live in :mod:`stook.testing.pytest_plugin` (``-p
stook.testing.pytest_plugin``, or listed in ``pytest_plugins``); they need pytest and
pytest-asyncio, which the ``pytest`` extra of stook-testing installs.
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from stook.emulator import Emulator, EmulatorConfig

__all__ = ["TEST_DEFAULTS", "emulated_batch", "emulated_report", "emulator_config"]

# Small pages make every list take several requests, so paging bugs show up in tests.
TEST_DEFAULTS: dict[str, Any] = {"default_page_size": 7, "max_page_size": 10}


def emulator_config(config: EmulatorConfig | None = None, **overrides: Any) -> EmulatorConfig:
    """`config` with `overrides`, or the testing defaults (small pages) with `overrides`."""
    if config is not None:
        return config.replace(**overrides) if overrides else config
    return EmulatorConfig(**{**TEST_DEFAULTS, **overrides})


@contextlib.asynccontextmanager
async def emulated_batch(
    inputs_dir: str | Path, config: EmulatorConfig | None = None, **overrides: Any
) -> AsyncIterator[Emulator]:
    """A running emulator and `inputs_dir/batch_metrics_config.json` pointing at it."""
    async with Emulator(emulator_config(config, **overrides)) as emu:
        emu.write_batch_config(inputs_dir)
        yield emu


@contextlib.asynccontextmanager
async def emulated_report(
    inputs_dir: str | Path, config: EmulatorConfig | None = None, **overrides: Any
) -> AsyncIterator[Emulator]:
    """A running emulator and `inputs_dir/report_config.json` pointing at its report."""
    async with Emulator(emulator_config(config, **overrides)) as emu:
        emu.write_report_config(inputs_dir)
        yield emu
