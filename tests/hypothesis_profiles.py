"""Hypothesis profiles, defined once for the whole suite (loaded by tests/conftest.py).

Tests state only how many examples they want, with `examples(N)`; deadlines and health
checks come from the profile. `HYPOTHESIS_PROFILE=thorough` runs every property with ten
times the examples, for a long run before a release; `quick` (what `make test` runs) with
a quarter of them, at least ten, while `make test-all` and CI run the full count.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

# No deadlines: a shared 2-core machine makes single examples slow at random, and a
# deadline would turn that into a flaky failure. Large generated outputs are the point of
# several strategies, so their health checks are off too.
settings.register_profile(
    "default",
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.register_profile("thorough", settings.get_profile("default"), max_examples=1_000)
settings.register_profile("quick", settings.get_profile("default"), max_examples=25)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

_SCALE = {"thorough": 10.0, "quick": 0.25}


def examples(count: int) -> settings:
    """`count` examples under the default profile, scaled under `thorough` and `quick`."""
    scale = _SCALE.get(settings.get_current_profile_name(), 1.0)
    return settings(max_examples=max(round(count * scale), min(count, 10)))
