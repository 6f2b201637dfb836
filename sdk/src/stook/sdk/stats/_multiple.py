"""Holm's step-down adjustment of p-values for a family of tests.

Holm (1979) controls the family-wise error rate (the chance of any false alarm across
all the metrics compared) at the nominal level, under any dependence between the tests,
and is uniformly more powerful than Bonferroni. scipy has Benjamini-Hochberg
(`false_discovery_control`) but not Holm, which is a few lines.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["holm_adjusted"]


def holm_adjusted(p_values: Sequence[float]) -> list[float]:
    """Holm-adjusted p-values, in the order given: reject where adjusted < alpha."""
    m = len(p_values)
    order = sorted(range(m), key=lambda i: (p_values[i], i))
    adjusted = [0.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted
