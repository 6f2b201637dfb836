"""Student's t interval for one batch's mean of a metric (the bars of a comparison chart)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from stook.sdk.stats._proportions import Interval

__all__ = ["mean_interval"]


def mean_interval(values: Sequence[float], confidence: float = 0.95) -> Interval:
    """The mean with its t interval; a single value gives an interval of just that value."""
    if not values:
        raise ValueError("no values")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence}")
    mean = math.fsum(values) / len(values)
    if len(values) < 2:
        return Interval(mean, mean, mean)
    from scipy.special import stdtrit  # Student's t quantile, as scipy.stats.t.ppf

    half = float(stdtrit(len(values) - 1, 0.5 + confidence / 2.0)) * (
        math.sqrt(math.fsum((v - mean) ** 2 for v in values) / (len(values) - 1))
        / math.sqrt(len(values))
    )
    return Interval(mean, mean - half, mean + half)
