"""Where did a series' level move? Penalised change points (PELT, as `ruptures` runs it).

Two kinds of series, one penalty:

- **levels** (a batch metric's value per batch): the values are standardised by a robust
  noise scale and segmented with the least-squares (``l2``) cost, which is -2 log
  likelihood of Gaussian noise of known scale around each segment's mean;
- **rates** (an experience's failed jobs out of its counted jobs per batch): segmented
  with the binomial -2 log likelihood of each segment's failure share.

On both, a change point is kept only when it lowers that cost by more than the penalty
``factor x ln(n) + PENALTY_CONSTANT`` (n: the batches in the series). ``factor x ln(n)``
is the BIC's price of a change (its position and the new level, ``2 ln n``) raised to 3;
the constant pays for what short series get wrong: a noise scale estimated from the
series itself (levels), a chi-square approximation that small job counts do not meet
(rates). With the defaults, fewer than 5 % of pure-noise series of 6 to 60 batches show
a change point (tests/sdk/aggregations/report/test_change_point_quality.py simulates it).
Across many series at once (every experience of a report), ``2 ln K`` more for K series
keeps the chance of any false alarm near that of one series (Bonferroni on the
likelihood-ratio scale).

The noise scale of levels comes from successive differences (a step moves one
difference, not the spread of all of them), and the largest tenth of the differences is
left out: ``sigma = mean(|d| without the largest) / E[that mean under N(0, 2)]``, at least
2 % of the series' median, as in the regression check, so that a perfectly flat series
does not flag a change of a thousandth.
"""

from __future__ import annotations

import functools
import itertools
import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from stook.sdk._pelt import search
from stook.sdk.aggregations.report._regression import RELATIVE_FLOOR

if TYPE_CHECKING:
    import numpy as np

#: the default multiplier of ln(n) in the penalty (the BIC's is 2)
DEFAULT_PENALTY = 3.0
#: added to every penalty: the price of estimating the noise scale from the series itself
PENALTY_CONSTANT = 8.0
#: fewer batches than this: no change-point search
MIN_POINTS = 6
#: each level lasts at least this many batches: one, so that a move in the latest batch is
#: placed there, and a single odd batch shows as a move there and back
MIN_SEGMENT = 1


@dataclass(frozen=True, slots=True)
class Shift:
    """One change point: from position `index` of the series on, the level is `after`."""

    index: int
    before: float
    after: float

    @property
    def change(self) -> float:
        return self.after - self.before

    @property
    def relative_change(self) -> float | None:
        return None if self.before == 0 else self.change / abs(self.before)


def penalty(n: int, factor: float = DEFAULT_PENALTY, *, series: int = 1) -> float:
    """The cost a change point must save in a series of `n` batches, one of `series`."""
    return factor * math.log(n) + PENALTY_CONSTANT + 2.0 * math.log(max(series, 1))


def _trimmed_count(m: int) -> int:
    return max(1, m // 10) if m >= 2 else 0


@functools.lru_cache(maxsize=256)
def _expected_trimmed_mean(m: int) -> float:
    """E[mean of m values |d| without their largest `_trimmed_count(m)`], d ~ N(0, 2).

    The expected sum of all m is m E|d| = 2m / sqrt(pi); the expected sum of the top k
    order statistics is an integral over the half-normal's order-statistic densities,
    taken numerically on a fine grid (deterministic, no random draws).
    """
    import numpy as np

    k = _trimmed_count(m)
    x, pdf, log_cdf, log_sf = _half_normal_grid()
    top = 0.0
    for j in range(m - k + 1, m + 1):  # the j-th smallest of m, 1-based
        log_c = math.lgamma(m + 1) - math.lgamma(j) - math.lgamma(m - j + 1)
        with np.errstate(invalid="ignore"):
            log_density = log_c + (j - 1) * log_cdf + (m - j) * log_sf
        density = np.where(np.isfinite(log_density), np.exp(log_density), 0.0) * pdf
        top += float(np.trapezoid(x * density, x))
    total = m * 2.0 / math.sqrt(math.pi)
    return (total - top) / (m - k)


@functools.cache
def _half_normal_grid() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The grid of `_expected_trimmed_mean` for |d|, d ~ N(0, 2): x, the density, and the
    logs of the distribution function and its complement (the same for every m, so
    taken once: a report judges series of many lengths)."""
    import numpy as np

    sigma = math.sqrt(2.0)
    x = np.linspace(0.0, 14.0 * sigma, 28_001)
    # math.erf of each point (no vector erf without scipy), divided as one array: the
    # same values as dividing numpy scalars one by one, in a third of the time.
    cdf = np.array(list(map(math.erf, (x / (sigma * math.sqrt(2.0))).tolist())))
    pdf = np.sqrt(2.0 / math.pi) / sigma * np.exp(-(x**2) / (2.0 * sigma**2))
    with np.errstate(divide="ignore"):
        return x, pdf, np.log(cdf), np.log1p(-np.minimum(cdf, 1.0))


def noise_scale(values: Sequence[float]) -> float:
    """A robust estimate of the batch-to-batch noise (a standard deviation) of `values`.

    From successive differences with the largest tenth (at least one) left out, so that a
    few steps or odd batches barely move it; 0.0 with fewer than three values.
    """
    diffs = sorted(abs(b - a) for a, b in itertools.pairwise(values))
    m = len(diffs)
    if m < 2:
        return 0.0
    kept = diffs[: m - _trimmed_count(m)]
    try:
        mean = statistics.fmean(kept)
    except OverflowError:
        # Differences near the float maximum overflow fsum's partials; scaled first, the
        # mean is still right to the last bits that matter here (or inf, past the maximum).
        mean = sum(d / len(kept) for d in kept)
    return mean / _expected_trimmed_mean(m)


def level_shifts(
    values: Sequence[float], *, factor: float = DEFAULT_PENALTY, series: int = 1
) -> list[Shift]:
    """Where the level of `values` moved; non-finite values are left out of the search
    (the shifts' indices are positions in `values` all the same)."""
    positions = [i for i, v in enumerate(values) if math.isfinite(v)]
    finite = [values[i] + 0.0 for i in positions]
    n = len(finite)
    if n < MIN_POINTS:
        return []
    median = statistics.median(finite)
    scale = max(noise_scale(finite), RELATIVE_FLOOR * abs(median))
    if scale == 0.0:
        return []  # a constant series, or noise too small to tell from rounding
    import numpy as np

    signal = ((np.asarray(finite) - median) / scale).reshape(-1, 1)
    cuts = search("l2", signal, penalty(n, factor, series=series), MIN_SEGMENT)
    return _shifts(cuts, positions, [statistics.fmean(s) for s in _segments(finite, cuts)])


def rate_shifts(
    failed: Sequence[int],
    counted: Sequence[int],
    *,
    factor: float = DEFAULT_PENALTY,
    series: int = 1,
) -> list[Shift]:
    """Where the failure share `failed / counted` moved; batches with nothing counted are
    left out of the search. Levels are shares (0..1) of each segment's jobs."""
    positions = [i for i, c in enumerate(counted) if c > 0]
    n = len(positions)
    if n < MIN_POINTS:
        return []
    f = [float(failed[i]) for i in positions]
    c = [float(counted[i]) for i in positions]
    if sum(f) == 0.0 or sum(f) == sum(c):
        return []  # never failed, or always: nothing moved
    import numpy as np

    signal = np.column_stack([f, c])
    cuts = search("binomial", signal, penalty(n, factor, series=series), MIN_SEGMENT)
    levels = [
        sum(fs) / sum(cs) for fs, cs in zip(_segments(f, cuts), _segments(c, cuts), strict=True)
    ]
    return _shifts(cuts, positions, levels)


def fitted_levels(length: int, shifts: Sequence[Shift]) -> list[float]:
    """The level of every position of a series of `length` given its shifts."""
    if not shifts:
        return []
    out, current = [], shifts[0].before
    pending = list(shifts)
    for i in range(length):
        while pending and pending[0].index <= i:
            current = pending.pop(0).after
        out.append(current)
    return out


def _segments(values: Sequence[float], cuts: Sequence[int]) -> list[Sequence[float]]:
    bounds = [0, *cuts, len(values)]
    return [values[a:b] for a, b in itertools.pairwise(bounds)]


def _shifts(cuts: Sequence[int], positions: Sequence[int], levels: Sequence[float]) -> list[Shift]:
    return [Shift(positions[cut], levels[i], levels[i + 1]) for i, cut in enumerate(cuts)]
