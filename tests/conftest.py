"""Suite-wide set-up: the Hypothesis profiles load before any test module is collected."""

from collections.abc import Iterator

import pytest

import tests.hypothesis_profiles  # noqa: F401  (registers and loads the profiles)


@pytest.fixture(autouse=True)
def _change_points_searched_here() -> Iterator[None]:
    """Report runs in the test process search their change points here, as a process that
    has imported ruptures does (the whole suite imports it when collecting the change-point
    tests): a worker process per run would import it again, a second of CPU each. Tests of
    the worker allow it (tests/sdk/aggregations/report/test_change_point_worker.py)."""
    from stook.sdk.aggregations.report import _change_point_worker

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_change_point_worker, "_ruptures_imported", lambda: True)
        yield
