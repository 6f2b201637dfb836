"""Which fetch-and-fold step a run uses: `[engine]` (or `--engine`) checked and chosen.

Apart from modes/_engine.py, whose sharded runs (pickling, worker processes, Ray) a local
run, the default, never imports: it is the first thing a run reads, before its first
request, and the shards' machinery would be imported for nothing.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from stook.service.modes._config import ConfigError, StookConfig
from stook.service.modes._engine_config import EngineConfigError, EngineSettings, require_engine
from stook.service.modes._pipeline import FetchStep, fetch_here

if TYPE_CHECKING:
    from pathlib import Path

__all__ = ["engine_for", "fetch_step_for"]


def engine_for(config: StookConfig, kind: str | None = None) -> EngineSettings:
    """`[engine]`, its kind replaced by `--engine` when given; refuses one that cannot run
    here (Ray not installed) before the first request (ConfigError, exit 2)."""
    engine = config.engine
    if kind is not None and kind != engine.kind:
        # The table's address is Ray's: it says nothing to another kind.
        address = engine.address if kind == "ray" else None
        engine = dataclasses.replace(engine, kind=kind, address=address)
    try:
        require_engine(engine)
    except EngineConfigError as exc:
        source = "--engine" if kind is not None else config.source
        raise ConfigError(f"{source}: {exc}") from None
    return engine


def fetch_step_for(engine: EngineSettings, config_file: Path | None) -> FetchStep:
    """The pipeline's fetch-and-fold step for `[engine]`."""
    if engine.kind == "local":
        return fetch_here
    from stook.service.modes._engine import ShardedFetch
    from stook.service.modes._user_code import import_folders

    return ShardedFetch(engine, tuple(str(f) for f in import_folders(config_file)))
