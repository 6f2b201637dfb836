"""A comparison's verdict: REGRESSED, IMPROVED, CHANGED, NO CHANGE or INCONCLUSIVE.

Significance alone is not the verdict: a change smaller than `min_effect` (relative to
the baseline's level) is NO CHANGE even when significant, and a non-significant result
whose interval still reaches changes of that size is INCONCLUSIVE: the data cannot tell.
Without a direction (no `better`, no failure definition) a significant change is CHANGED.
"""

from __future__ import annotations

import enum
import math
from typing import Literal

__all__ = ["Better", "ComparisonVerdict", "comparison_verdict"]

Better = Literal["lower", "higher"]


class ComparisonVerdict(enum.StrEnum):
    REGRESSED = "REGRESSED"
    IMPROVED = "IMPROVED"
    CHANGED = "CHANGED"
    NO_CHANGE = "NO CHANGE"
    INCONCLUSIVE = "INCONCLUSIVE"

    @property
    def is_alarm(self) -> bool:
        """Whether the verdict reports a change (a false alarm when nothing changed)."""
        alarms = (
            ComparisonVerdict.REGRESSED,
            ComparisonVerdict.IMPROVED,
            ComparisonVerdict.CHANGED,
        )
        return self in alarms


def comparison_verdict(
    *,
    estimate: float,
    low: float,
    high: float,
    significant: bool,
    level: float,
    better: Better | None,
    min_effect: float,
) -> ComparisonVerdict:
    """The verdict on a difference (candidate - baseline) around a baseline `level`."""
    threshold = min_effect * abs(level)
    if significant:
        if abs(estimate) < threshold or (threshold == 0.0 and estimate == 0.0):
            return ComparisonVerdict.NO_CHANGE
        if better is None:
            return ComparisonVerdict.CHANGED
        worse = estimate > 0.0 if better == "lower" else estimate < 0.0
        return ComparisonVerdict.REGRESSED if worse else ComparisonVerdict.IMPROVED
    if not (math.isfinite(low) and math.isfinite(high)):
        return ComparisonVerdict.INCONCLUSIVE
    if min_effect > 0.0 and (low <= -threshold or high >= threshold):
        return ComparisonVerdict.INCONCLUSIVE
    return ComparisonVerdict.NO_CHANGE
