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

The search (`search`) finds a series' breakpoints under a cost kind and a penalty as
ruptures' `Pelt` finds them, bit for bit. With the settings stook searches with
(``jump=1``, ``min_size=1``), `Pelt` runs nothing of its own but the cost's `fit`, a
check that the signal is not empty and a sort: the search itself (`_partition`) and the
costs (`SummedL2Cost`, `BinomialCost`) are this module's, over numpy arrays. So that
search runs without importing ruptures, which imports scipy's sparse, spatial, optimize,
stats and signal packages (about 1.5 s of CPU, more than a report's whole search). Other
settings go through ruptures' own `Pelt`, imported then.

Whether the latest batch moved (`check`, a `Verdict`) is judged against a robust
baseline of the batches before it: the median and the median absolute deviation ignore
a few wild batches, where a mean and a standard deviation would be dragged along.
"""

from __future__ import annotations

import functools
import itertools
import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np


#: the cost kinds: least squares around each segment's mean, and the binomial deviance of
#: each segment's failed of counted jobs
COSTS = ("l2", "binomial")


def search(kind: str, signal: np.ndarray, pen: float, min_size: int) -> list[int]:
    """The breakpoints (segments' starts after the first) of `signal` under cost `kind`."""
    cost = _cost(kind)()
    if min_size <= 1:  # `Pelt` takes the larger of it and the cost's, which is 1
        return [int(b) for b in _search_without_ruptures(cost, signal, pen)[:-1]]
    import ruptures

    algo = ruptures.Pelt(custom_cost=ruptures_cost(kind)(), min_size=min_size, jump=1)
    return [int(b) for b in algo.fit(signal).predict(pen=pen)[:-1]]


def ruptures_cost(kind: str) -> Any:
    """The cost class of `kind`, registered as ruptures' `BaseCost`: `Pelt` takes a custom
    cost only when it is one (and else silently searches with its own "l2")."""
    from ruptures.base import BaseCost

    cost = _cost(kind)
    BaseCost.register(cost)
    return cost


def _cost(kind: str) -> Any:
    if kind == "l2":
        return SummedL2Cost
    if kind == "binomial":
        return BinomialCost
    raise ValueError(f"unknown cost kind {kind!r}")


def _search_without_ruptures(cost: Any, signal: np.ndarray, pen: float) -> list[int]:
    """What ``ruptures.Pelt(custom_cost=cost, min_size=1, jump=1).fit(signal).predict(pen)``
    gives, without ruptures: with those settings `Pelt` runs nothing of its own but
    `fit` (the cost's), a check that the signal is not empty, and the sort of the
    partition's ends."""
    cost.fit(signal)
    n = int(signal.shape[0])
    if n < 1:  # what ruptures' `sanity_check` refuses for these settings
        from ruptures.exceptions import BadSegmentationParameters

        raise BadSegmentationParameters
    return sorted(end for _, end in _partition(cost, n, pen))


def _partition(cost: Any, n: int, pen: float) -> dict[tuple[int, int], float]:
    """ruptures' `Pelt._seg` for `jump=1`, `min_size=1`, over numpy arrays: the same
    partition of `n` samples, penalised values and all, bit for bit.

    ruptures keeps one dict per candidate start and sums it for every (start, end) pair;
    without change points nothing is pruned, so a series of a thousand batches costs
    half a million Python-level cost calls and dict sums (about a third of a second
    each series). Here a cost's `errors` gives every admissible start's cost at once.
    Those may differ from `error`'s by rounding (numpy's log against math.log; a sum
    taken in another order), so every start within a hair of a decision — the minimum,
    or the pruning bound — is settled with ruptures' own arithmetic: `error(start, end)
    + pen` appended to the start's partition values and summed with Python's `sum`, as
    `Pelt._seg` does.
    """
    import numpy as np

    # Per end of a partition of signal[0:end]: its segments' values in ruptures'
    # order (the (0, 0): 0 entry first), their Python sum, the last start.
    values: list[tuple[float, ...]] = [(0,)]
    totals = np.zeros(n + 1)
    previous = [0] * (n + 1)
    admissible = np.zeros(0, dtype=np.int64)

    def settled(t: int, end: int) -> tuple[float, float]:
        value = cost.error(t, end) + pen
        return sum((*values[t], value)), value

    for end in range(1, n + 1):
        admissible = np.append(admissible, end - 1)
        candidates = totals[admissible] + (cost.errors(admissible, end) + pen)
        low = float(candidates.min())
        # Far wider than any rounding: the partitions' totals are sums of a few
        # hundred nonnegative terms.
        slack = 1e-9 * (abs(low) + pen)
        best_t, best_total, best_value = -1, 0.0, 0.0
        for i in np.flatnonzero(candidates <= low + 2 * slack).tolist():
            t = int(admissible[i])
            total, value = settled(t, end)
            if best_t < 0 or total < best_total:  # the first of equals, as min()
                best_t, best_total, best_value = t, total, value
        values.append((*values[best_t], best_value))
        totals[end] = best_total
        previous[end] = best_t
        bound = best_total + pen
        keep = candidates <= bound
        for i in np.flatnonzero(np.abs(candidates - bound) <= 2 * slack).tolist():
            keep[i] = settled(int(admissible[i]), end)[0] <= bound
        admissible = admissible[keep]
    partition: dict[tuple[int, int], float] = {}
    end = n
    while end > 0:
        start = previous[end]
        partition[(start, end)] = values[end][-1]
        end = start
    return dict(sorted(partition.items()))


def _binomial_deviance(failed: float, counted: float) -> float:
    """-2 log likelihood of `failed` of `counted` at their own share (0 log 0 = 0)."""
    out = 0.0
    for k in (failed, counted - failed):
        if k > 0:
            out -= 2.0 * k * math.log(k / counted)
    return out


class SummedL2Cost:
    """ruptures' L2 cost (a segment's squared deviations from its mean) from running sums:
    O(1) per segment where `CostL2` takes a variance over it, which made the search
    cubic-ish in the batches (tens of seconds for a report of a thousand batches)."""

    model = "l2"
    min_size = 1  # Pelt takes the larger of this and its own min_size

    def fit(self, signal: np.ndarray) -> SummedL2Cost:
        import numpy as np

        self.signal = signal
        column = signal[:, 0]
        self.sums: list[float] = np.concatenate([[0.0], np.cumsum(column)]).tolist()
        self.squares: list[float] = np.concatenate([[0.0], np.cumsum(column**2)]).tolist()
        self.sums_array = np.asarray(self.sums)
        self.squares_array = np.asarray(self.squares)
        return self

    def error(self, start: int, end: int) -> float:
        total = self.sums[end] - self.sums[start]
        squares = self.squares[end] - self.squares[start]
        return max(0.0, squares - total * total / (end - start))

    def errors(self, starts: np.ndarray, end: int) -> np.ndarray:
        """`error(start, end)` for every start at once."""
        import numpy as np

        total = self.sums[end] - self.sums_array[starts]
        squares = self.squares[end] - self.squares_array[starts]
        out: np.ndarray = np.maximum(0.0, squares - total * total / (end - starts))
        return out


class BinomialCost:
    """A ruptures cost: the binomial deviance of a segment's failed and counted jobs."""

    model = "binomial"
    min_size = 1  # Pelt takes the larger of this and its own min_size

    def fit(self, signal: np.ndarray) -> BinomialCost:
        import numpy as np

        self.signal = signal
        self.cumulative = np.vstack([np.zeros((1, 2)), np.cumsum(signal, axis=0)])
        return self

    def error(self, start: int, end: int) -> float:
        failed, counted = self.cumulative[end] - self.cumulative[start]
        return _binomial_deviance(float(failed), float(counted))

    def errors(self, starts: np.ndarray, end: int) -> np.ndarray:
        """`error(start, end)` for every start at once (to rounding: numpy's log)."""
        import numpy as np

        failed = self.cumulative[end, 0] - self.cumulative[starts, 0]
        counted = self.cumulative[end, 1] - self.cumulative[starts, 1]
        out = np.zeros(len(starts))
        for k in (failed, counted - failed):
            some = k > 0
            out[some] -= 2.0 * k[some] * np.log(k[some] / counted[some])
        return out


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
