"""The PELT search of report change points (`_change_points`): a series' breakpoints
under a cost kind and a penalty, as ruptures' `Pelt` finds them, bit for bit.

With the settings stook searches with (`jump=1`, `min_size=1`), `Pelt` runs nothing of
its own but the cost's `fit`, a check that the signal is not empty and a sort: the search
itself (`_partition`) and the costs are this module's, over numpy arrays. So that search
runs without importing ruptures, which imports scipy's sparse, spatial, optimize, stats
and signal packages (about 1.5 s of CPU, more than a report's whole search). Other
settings go through ruptures' own `Pelt`, imported then.
"""

from __future__ import annotations

import functools
import math
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
    algo = _vector_pelt()(custom_cost=cost, min_size=min_size, jump=1).fit(signal)
    return [int(b) for b in algo.predict(pen=pen)[:-1]]


def ruptures_cost(kind: str) -> Any:
    """The cost class of `kind`, registered as ruptures' `BaseCost`: `Pelt` takes a custom
    cost only when it is one (and else silently searches with its own "l2")."""
    from ruptures.base import BaseCost

    cost = _cost(kind)
    BaseCost.register(cost)
    return cost


def _cost(kind: str) -> Any:
    if kind == "l2":
        return _l2_cost()
    if kind == "binomial":
        return _binomial_cost()
    raise ValueError(f"unknown cost kind {kind!r}")


def _search_without_ruptures(cost: Any, signal: np.ndarray, pen: float) -> list[int]:
    """What `_vector_pelt()(custom_cost=cost, min_size=1, jump=1).fit(signal).predict(pen)`
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


@functools.cache
def _vector_pelt() -> Any:
    """ruptures' `Pelt` with `_partition` as its search for `jump=1`, `min_size=1` (what
    stook runs), and its own for other settings; the costs are registered as ruptures'
    `BaseCost`, which `Pelt` requires of a custom cost."""
    import ruptures

    for kind in COSTS:
        ruptures_cost(kind)

    class VectorPelt(ruptures.Pelt):  # type: ignore[misc]
        def _seg(self, pen: float) -> dict[tuple[int, int], float]:
            cost = self.cost
            if self.jump != 1 or self.min_size != 1 or not hasattr(cost, "errors"):
                return super()._seg(pen)  # type: ignore[no-any-return]
            return _partition(cost, int(self.n_samples), pen)

    return VectorPelt


def _binomial_deviance(failed: float, counted: float) -> float:
    """-2 log likelihood of `failed` of `counted` at their own share (0 log 0 = 0)."""
    out = 0.0
    for k in (failed, counted - failed):
        if k > 0:
            out -= 2.0 * k * math.log(k / counted)
    return out


@functools.cache
def _l2_cost() -> Any:
    """ruptures' L2 cost (a segment's squared deviations from its mean) from running sums:
    O(1) per segment where `CostL2` takes a variance over it, which made the search
    cubic-ish in the batches (tens of seconds for a report of a thousand batches)."""
    import numpy as np

    class SummedL2Cost:
        model = "l2"
        min_size = 1  # Pelt takes the larger of this and its own min_size

        def fit(self, signal: np.ndarray) -> SummedL2Cost:
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
            total = self.sums[end] - self.sums_array[starts]
            squares = self.squares[end] - self.squares_array[starts]
            out: np.ndarray = np.maximum(0.0, squares - total * total / (end - starts))
            return out

    return SummedL2Cost


@functools.cache
def _binomial_cost() -> Any:
    """A ruptures cost: the binomial deviance of a segment's failed and counted jobs
    (made on first use, so that ruptures is imported only when a report needs it)."""
    import numpy as np

    class BinomialCost:
        model = "binomial"
        min_size = 1  # Pelt takes the larger of this and its own min_size

        def fit(self, signal: np.ndarray) -> BinomialCost:
            self.signal = signal
            self.cumulative = np.vstack([np.zeros((1, 2)), np.cumsum(signal, axis=0)])
            return self

        def error(self, start: int, end: int) -> float:
            failed, counted = self.cumulative[end] - self.cumulative[start]
            return _binomial_deviance(float(failed), float(counted))

        def errors(self, starts: np.ndarray, end: int) -> np.ndarray:
            """`error(start, end)` for every start at once (to rounding: numpy's log)."""
            failed = self.cumulative[end, 0] - self.cumulative[starts, 0]
            counted = self.cumulative[end, 1] - self.cumulative[starts, 1]
            out = np.zeros(len(starts))
            for k in (failed, counted - failed):
                some = k > 0
                out[some] -= 2.0 * k[some] * np.log(k[some] / counted[some])
            return out

    return BinomialCost
