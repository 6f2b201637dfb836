"""A batch compared with its baseline: `BaselineComparison` and what it finds (docs/statistics.md).

A module of its own, beside `stook.sdk.aggregations` rather than in it, so that a batch run
without ``[batch.baseline]`` does not import the comparison and its statistics.
"""

from stook.sdk.aggregations._baseline import (
    BaselineComparison,
    BaselineInfo,
    ComparisonResult,
    MetricComparison,
    PassRateComparison,
)

__all__ = [
    "BaselineComparison",
    "BaselineInfo",
    "ComparisonResult",
    "MetricComparison",
    "PassRateComparison",
]
