"""Did the latest batch move? A robust baseline (median and MAD) of the batches before it.

The median and the median absolute deviation ignore a few wild batches in the
baseline, where a mean and a standard deviation would be dragged along by them.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field

# 1.4826 * MAD estimates the standard deviation of normally distributed values.
MAD_TO_SIGMA = 1.4826
# Without this floor a perfectly flat baseline (MAD 0) would flag any change at all.
RELATIVE_FLOOR = 0.02
MIN_BASELINE = 3


@dataclass(frozen=True, slots=True)
class Verdict:
    """The regression check of one series: `regressed` is None when no verdict is possible."""

    regressed: bool | None
    latest: float
    baseline_median: float = 0.0
    baseline_mad: float = 0.0
    deviations: float = 0.0
    baseline_size: int = 0
    reason: str = ""
    #: positions in the checked values of the baseline's first and last value; where a
    #: baseline sits says nothing about the verdict, so equal verdicts may differ here
    baseline_span: tuple[int, int] = field(default=(0, 0), compare=False)

    @property
    def change(self) -> float:
        return self.latest - self.baseline_median

    @property
    def relative_change(self) -> float | None:
        if self.baseline_median == 0:
            return None
        return self.change / abs(self.baseline_median)


def check(values: Sequence[float], *, window: int, threshold: float) -> Verdict:
    """Compare the last value with the `window` values before it.

    `threshold` is in robust standard deviations (1.4826 x MAD, floored at 2% of the
    baseline's median): past it, the series regressed.
    """
    if not values:
        raise ValueError("no values to check")
    latest = values[-1]
    if not math.isfinite(latest):
        return Verdict(None, latest, reason="the latest value is not a finite number")
    # Infinite or NaN batches say nothing about the usual level; they are left out.
    start = max(len(values) - 1 - window, 0)
    positions = [i for i in range(start, len(values) - 1) if math.isfinite(values[i])]
    baseline = [values[i] for i in positions]
    if len(baseline) < MIN_BASELINE:
        return Verdict(
            None,
            latest,
            baseline_size=len(baseline),
            reason=f"{len(baseline)} earlier batches; at least {MIN_BASELINE} are needed",
        )
    median = statistics.median(baseline)
    mad = statistics.median(abs(v - median) for v in baseline)
    scale = max(MAD_TO_SIGMA * mad, RELATIVE_FLOOR * abs(median), 1e-12)
    deviations = abs(latest - median) / scale
    return Verdict(
        deviations > threshold,
        latest,
        baseline_median=median,
        baseline_mad=mad,
        deviations=deviations,
        baseline_size=len(baseline),
        baseline_span=(positions[0], positions[-1]),
    )
