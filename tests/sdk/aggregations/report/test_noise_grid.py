"""The grid of the noise scale's expected trimmed mean: the same numbers, bit for bit, as
dividing and taking `math.erf` one point at a time (the noise scale, and so every change
point, depends on them)."""

from __future__ import annotations

import math

import numpy as np

from stook.sdk.aggregations.report._change_points import _half_normal_grid


def test_the_grid_is_the_pointwise_erf_bit_for_bit() -> None:
    x, _, log_cdf, log_sf = _half_normal_grid()
    sigma = math.sqrt(2.0)
    cdf = np.array([math.erf(v / (sigma * math.sqrt(2.0))) for v in x])
    with np.errstate(divide="ignore"):
        expected_log_cdf = np.log(cdf)
        expected_log_sf = np.log1p(-np.minimum(cdf, 1.0))
    assert expected_log_cdf.tobytes() == log_cdf.tobytes()
    assert expected_log_sf.tobytes() == log_sf.tobytes()
