"""The start-up section of `stook bench`: its targets and table (no timing here)."""

from __future__ import annotations

from typing import Any

from stook.bench._startup import startup_table, startup_targets


def _startup(**medians: float) -> dict[str, Any]:
    return {name: {"median_s": s, "runs_s": [s]} for name, s in medians.items()}


MEASURED = {"--help": 0.03, "--version": 0.05, "show": 0.09, "validate": 0.2, "run": 0.3}


def test_the_slowest_command_decides() -> None:
    targets = startup_targets(_startup(**MEASURED))
    commands = targets["startup_commands"]
    assert commands["measured"] == 0.2
    assert "slowest: validate" in commands["at"]
    assert commands["met"] is False
    assert targets["startup_first_request"]["measured"] == 0.3
    assert targets["startup_first_request"]["met"] is True


def test_met_at_the_targets() -> None:
    targets = startup_targets(_startup(**{**MEASURED, "validate": 0.15, "run": 0.35}))
    assert targets["startup_commands"]["met"] is True
    assert targets["startup_first_request"]["met"] is True
    assert targets["startup_first_request"]["target"] == "<= 0.35 s"


def test_table_has_a_row_per_command() -> None:
    table = startup_table(_startup(**MEASURED))
    assert "| `stook validate` | 0.200 | <= 0.15 |" in table
    assert "| `stook run`, to its first request | 0.300 | <= 0.35 |" in table


def test_the_commands_are_timed_with_stooks_modules_byte_compiled() -> None:
    # As pip leaves an installed wheel: without it, an editable checkout run under
    # PYTHONDONTWRITEBYTECODE compiles every module from source at every start-up.
    import importlib.util
    from pathlib import Path

    import stook.sdk._enums as module
    from stook.bench._startup import byte_compile_stook

    cached = Path(importlib.util.cache_from_source(module.__file__))
    cached.unlink(missing_ok=True)
    byte_compile_stook()
    assert cached.is_file()
