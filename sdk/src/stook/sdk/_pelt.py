"""The PELT search of report change points (`_change_points`), with ruptures: a series'
breakpoints under a cost kind and a penalty.

Apart from the report aggregations, and importing nothing of stook, so that the
change-point worker process (`_pelt_worker`) runs this very code on the same float64
arrays with only numpy and ruptures imported. ruptures is imported on first use: it
imports scipy's sparse, spatial, optimize, stats and signal packages (about a second of
CPU).
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
    algo = _vector_pelt()(custom_cost=cost, min_size=min_size, jump=1).fit(signal)
    return [int(b) for b in algo.predict(pen=pen)[:-1]]


def prepare() -> None:
    """Import ruptures and build the search's classes (a worker does it before any search)."""
    _vector_pelt()
    for kind in COSTS:
        _cost(kind)


def _cost(kind: str) -> Any:
    if kind == "l2":
        return _l2_cost()
    if kind == "binomial":
        return _binomial_cost()
    raise ValueError(f"unknown cost kind {kind!r}")


@functools.cache
def _vector_pelt() -> Any:
    """ruptures' `Pelt` with its search loop over numpy arrays: the same partitions,
    penalised totals and breakpoints, bit for bit.

    ruptures keeps one dict per candidate start and sums it for every (start, end) pair;
    without change points nothing is pruned, so a series of a thousand batches costs
    half a million Python-level cost calls and dict sums (about a third of a second
    each series). Here a cost's `errors` gives every admissible start's cost at once.
    Those may differ from `error`'s by rounding (numpy's log against math.log; a sum
    taken in another order), so every start within a hair of a decision — the minimum,
    or the pruning bound — is settled with ruptures' own arithmetic: `error(start, end)
    + pen` appended to the start's partition values and summed with Python's `sum`, as
    `Pelt._seg` does. Only `jump=1`, `min_size=1` (what stook runs) take this path.
    """
    import numpy as np
    import ruptures

    class VectorPelt(ruptures.Pelt):  # type: ignore[misc]
        def _seg(self, pen: float) -> dict[tuple[int, int], float]:
            cost = self.cost
            if self.jump != 1 or self.min_size != 1 or not hasattr(cost, "errors"):
                return super()._seg(pen)  # type: ignore[no-any-return]
            n = int(self.n_samples)
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
    from ruptures.base import BaseCost

    class SummedL2Cost(BaseCost):  # type: ignore[misc]
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
    from ruptures.base import BaseCost

    class BinomialCost(BaseCost):  # type: ignore[misc]
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
