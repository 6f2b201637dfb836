"""`[engine]`: where one run's fetch and fold happens: here, in local processes, or on Ray.

[engine]
kind = "local"         # "local" (one process), "processes" or "ray"
workers = 8            # processes: worker processes (default: CPU count); ray: CPUs of
                       #   the local instance started when no address is given
shards = 8             # pieces the job (or batch) list is split into (default: processes,
                       #   = workers; ray, 2 x workers or the cluster's CPUs)
address = "auto"       # ray: the cluster to join ("auto", "ray://head:10001"); absent:
                       #   start a local instance

Everything here is checked before the first request (exit 2), including that Ray is
installed when `kind = "ray"` (without importing it: `stook --help` stays light).
"""

from __future__ import annotations

import importlib.util
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

from stook.sdk import StookError

__all__ = ["ENGINE_KINDS", "EngineConfigError", "EngineSettings", "parse_engine", "require_engine"]

ENGINE_KINDS: Final = ("local", "processes", "ray")
_KEYS: Final = {"kind", "workers", "shards", "address"}
RAY_INSTALL_HINT: Final = 'pip install "stook[ray]"'


class EngineConfigError(StookError):
    """An unusable `[engine]` setting (turned into ConfigError, exit code 2)."""


@dataclass(frozen=True, slots=True)
class EngineSettings:
    kind: str = "local"
    workers: int | None = None  # None: the engine's default (see the module docstring)
    shards: int | None = None
    address: str | None = None


def parse_engine(table: Mapping[str, Any]) -> EngineSettings:
    """The `[engine]` table's settings; raises EngineConfigError naming the key at fault."""
    extra = set(table) - _KEYS
    if extra:
        raise EngineConfigError(
            f"unknown key {sorted(extra)[0]!r} in [engine] (known: {', '.join(sorted(_KEYS))})"
        )
    kind = table.get("kind", "local")
    if kind not in ENGINE_KINDS:
        raise EngineConfigError(
            f"[engine] kind must be one of {', '.join(map(repr, ENGINE_KINDS))}, got {kind!r}"
        )
    address = table.get("address")
    if address is not None:
        if not isinstance(address, str) or not address.strip():
            raise EngineConfigError(
                '[engine] address must be a Ray address ("auto", "ray://head:10001")'
            )
        if kind != "ray":
            raise EngineConfigError(f'[engine] address is for kind = "ray", not {kind!r}')
    return EngineSettings(
        kind=kind,
        workers=_count(table, "workers"),
        shards=_count(table, "shards"),
        address=address,
    )


def _count(table: Mapping[str, Any], key: str) -> int | None:
    value = table.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise EngineConfigError(
            f"[engine] {key} must be a whole number of at least 1, got {value!r}"
        )
    return value


def require_engine(settings: EngineSettings) -> None:
    """Refuse an engine that cannot run here: Ray not installed (checked without importing it)."""
    if settings.kind == "ray" and not _installed("ray"):
        raise EngineConfigError(
            f'[engine] kind = "ray" needs Ray, which is not installed: {RAY_INSTALL_HINT}'
        )


def _installed(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):  # ValueError: a module in sys.modules without a spec
        return False
