"""Suite-wide set-up: the Hypothesis profiles load before any test module is collected."""

import tests.hypothesis_profiles  # noqa: F401  (registers and loads the profiles)
