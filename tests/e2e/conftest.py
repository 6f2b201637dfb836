import os
from collections.abc import Iterator
from pathlib import Path

import pytest
import structlog

# The shared checks in support.py assert; let pytest explain their failures.
pytest.register_assert_rewrite("tests.e2e.support")


@pytest.fixture(autouse=True)
def _fresh_structlog() -> Iterator[None]:
    # run_cli points structlog at the stderr of the moment (capsys's, in these tests);
    # later tests must not write to a stream that is gone.
    structlog.reset_defaults()
    yield
    structlog.reset_defaults()


@pytest.fixture
def isolated(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """No ./stook.toml and no STOOK_* settings from the environment: the test's own folder
    is the working directory."""
    monkeypatch.chdir(tmp_path)
    for name in list(os.environ):
        if name.startswith("STOOK_"):
            monkeypatch.delenv(name)
