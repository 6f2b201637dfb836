"""Order-independent sums for aggregations: math.fsum, without its overflow error.

fsum is exact and correctly rounded, so a result does not depend on the order jobs
arrived in; it raises OverflowError where the exact sum leaves the double range even
when the quantity wanted (a mean, a ratio) does not.
"""

from __future__ import annotations

import math
from collections.abc import Sequence


def exact_sum(values: Sequence[float]) -> float:
    """fsum, or ±inf where the exact sum is beyond the largest double."""
    try:
        return math.fsum(values)
    except OverflowError:
        # The scaled sum is exact in sign; its magnitude is what overflowed.
        return math.copysign(math.inf, math.fsum(v / 2.0**64 for v in values))


def exact_mean(values: Sequence[float]) -> float:
    """The mean of finite values; sums first, or divides first when the sum would overflow."""
    try:
        return math.fsum(values) / len(values)
    except OverflowError:
        return math.fsum(v / len(values) for v in values)
