"""Start-up: which heavy libraries a module pulls in when imported (how long start-up
takes is measured in `stook bench`, not here)."""

from __future__ import annotations

import subprocess
import sys

import pytest

# What `stook run` imports before its first request, without polars or numpy: those come
# with the first series decoded. `stook show` and `validate` import stook.sdk alone.
MODULES = ["stook.sdk", "stook.sdk.aggregations", "stook.service.modes", "stook.service.fetch"]


@pytest.mark.parametrize("module", MODULES)
def test_importing_does_not_import_polars_or_numpy(module: str) -> None:
    script = (
        f"import sys, {module}\nprint(sorted(m for m in ('polars', 'numpy') if m in sys.modules))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == "[]\n"
