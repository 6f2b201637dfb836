"""Statistics for comparing a batch with a baseline: pure functions, no I/O.

Wilson intervals for pass rates and Newcombe's for their difference; a seeded bootstrap
interval of a difference in means (paired or unpaired); Holm's adjustment across the
metrics compared; and the verdict that combines them with a minimum effect size.
docs/statistics.md explains the choices.
"""

from stook.sdk.stats._bootstrap import MeanDifference, bootstrap_mean_difference, seed_from
from stook.sdk.stats._means import mean_interval
from stook.sdk.stats._multiple import holm_adjusted
from stook.sdk.stats._proportions import (
    Interval,
    newcombe_difference,
    normal_quantile,
    wilson_interval,
)
from stook.sdk.stats._verdict import Better, ComparisonVerdict, comparison_verdict

__all__ = [
    "Better",
    "ComparisonVerdict",
    "Interval",
    "MeanDifference",
    "bootstrap_mean_difference",
    "comparison_verdict",
    "holm_adjusted",
    "mean_interval",
    "newcombe_difference",
    "normal_quantile",
    "seed_from",
    "wilson_interval",
]
