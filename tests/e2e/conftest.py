from collections.abc import Iterator

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
