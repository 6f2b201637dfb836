"""Histogram buckets: the (lower, upper) pairs a histogram metric bins its values into.

`histogram_buckets` is the one place that turns "N buckets between lower and upper" or
a list of explicit pairs into checked, contiguous buckets. The writer's ``histogram``
method calls it, and so do the aggregations: `MergedHistogram` bins its values on the
same edges the histogram metric will carry, and `ScalarDefaults` asks it which bucket
counts floating point can tell apart.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

from stook.sdk._errors import WriterError

Bucket = tuple[float, float]


def histogram_buckets(
    name: str, buckets: int | Sequence[Bucket], lower: float | None, upper: float | None
) -> list[Bucket]:
    """Equal-width buckets from a count and bounds, or explicit ones checked for contiguity."""
    if isinstance(buckets, int):
        if lower is None or upper is None or not lower < upper or buckets < 1:
            raise WriterError(
                f"metric {name!r}: {buckets} buckets need lower < upper and a count of at least 1"
            )
        width = (upper - lower) / buckets
        # The first and last edges are the bounds themselves (0 * inf would be NaN).
        edges = [lower, *(lower + i * width for i in range(1, buckets)), upper]
        if not all(math.isfinite(e) for e in edges) or any(
            a >= b for a, b in itertools.pairwise(edges)
        ):
            raise WriterError(
                f"metric {name!r}: {buckets} buckets between {lower} and {upper} cannot be told "
                "apart in floating point; use fewer buckets or wider bounds"
            )
        return list(itertools.pairwise(edges))
    pairs = [(float(lo), float(hi)) for lo, hi in buckets]
    if not pairs:
        raise WriterError(f"metric {name!r}: a histogram needs at least one bucket")
    for i, (lo, hi) in enumerate(pairs):
        if not lo < hi:
            raise WriterError(f"metric {name!r}: bucket {i} has lower {lo} >= upper {hi}")
        if i and pairs[i - 1][1] != lo:
            raise WriterError(
                f"metric {name!r}: bucket {i} starts at {lo} but bucket {i - 1} ends at "
                f"{pairs[i - 1][1]}"
            )
    if (lower is not None and lower != pairs[0][0]) or (
        upper is not None and upper != pairs[-1][1]
    ):
        raise WriterError(f"metric {name!r}: lower/upper must match the first and last bucket")
    return pairs
