"""Start-up: the engine's libraries (polars, DuckDB, sqlglot, PyYAML, python-liquid,
pyarrow) are imported only by the runs that evaluate a config."""

from __future__ import annotations

import subprocess
import sys

import pytest

HEAVY = ("duckdb", "sqlglot", "yaml", "liquid", "pyarrow", "polars")


@pytest.mark.parametrize(
    "script",
    [
        "import stook.service.cli._run, stook.service.modes, stook.service.metrics_config",
        "from stook.service.cli._run import exit_code_for; exit_code_for(ValueError())",
        "from stook.service.modes import parse; parse({'metrics_config': {'paths': ['a.yml']}})",
    ],
)
def test_the_engine_is_not_imported_before_it_runs(script: str) -> None:
    probe = f"{script}\nimport sys\nprint(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == "[]\n"
