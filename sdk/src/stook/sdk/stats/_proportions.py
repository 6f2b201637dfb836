"""Intervals for pass rates: Wilson's score interval, and Newcombe's for a difference.

Wilson (1927) is the interval recommended over the textbook Wald interval: it stays
inside [0, 1] and keeps its coverage near 0 and 1 and for small n. Newcombe (1998,
method 10) combines two Wilson intervals into one for the difference of two independent
proportions. scipy supplies the normal quantile (imported on first use).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Interval", "newcombe_difference", "normal_quantile", "wilson_interval"]


@dataclass(frozen=True, slots=True)
class Interval:
    """An estimate with the bounds of its confidence interval."""

    estimate: float
    low: float
    high: float

    def excludes_zero(self) -> bool:
        return self.low > 0.0 or self.high < 0.0


def normal_quantile(confidence: float) -> float:
    """z such that a two-sided interval of the standard normal holds `confidence`."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence}")
    # scipy.special's ufunc, not scipy.stats.norm: the same function at a hundredth of the
    # cost per call, and a lighter import.
    from scipy.special import ndtri

    return float(ndtri(0.5 + confidence / 2.0))


def wilson_interval(successes: int, trials: int, confidence: float = 0.95) -> Interval:
    """Wilson's score interval for `successes` out of `trials` (no continuity correction)."""
    if trials < 1 or not 0 <= successes <= trials:
        raise ValueError(f"need 0 <= successes <= trials and trials >= 1, got {successes}/{trials}")
    z = normal_quantile(confidence)
    p = successes / trials
    z2n = z * z / trials
    centre = (p + z2n / 2.0) / (1.0 + z2n)
    half = z / (1.0 + z2n) * math.sqrt(p * (1.0 - p) / trials + z2n / (4.0 * trials))
    # Exact bounds at the edges: rounding must not push 0/n above 0 or n/n below 1.
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == trials else min(1.0, centre + half)
    return Interval(p, low, high)


def newcombe_difference(
    successes_a: int,
    trials_a: int,
    successes_b: int,
    trials_b: int,
    confidence: float = 0.95,
) -> Interval:
    """Newcombe's hybrid score interval (method 10) for p_a - p_b, independent samples."""
    a = wilson_interval(successes_a, trials_a, confidence)
    b = wilson_interval(successes_b, trials_b, confidence)
    delta = a.estimate - b.estimate
    low = delta - math.sqrt((a.estimate - a.low) ** 2 + (b.high - b.estimate) ** 2)
    high = delta + math.sqrt((a.high - a.estimate) ** 2 + (b.estimate - b.low) ** 2)
    return Interval(delta, low, high)
