"""The running-sums L2 cost of the change-point search: the costs and the breakpoints of
ruptures' own CostL2, without its variance per segment."""

from __future__ import annotations

import random

import numpy as np
import pytest
import ruptures

from stook.sdk.aggregations.report._change_points import MIN_SEGMENT, SummedL2Cost, ruptures_cost


@pytest.mark.parametrize("seed", range(6))
def test_same_costs_and_breakpoints_as_ruptures_l2(seed: int) -> None:
    rng = random.Random(seed)
    n = rng.randint(12, 120)
    level = 0.0
    values = []
    for _ in range(n):
        if rng.random() < 0.05:
            level += rng.choice([-1, 1]) * rng.uniform(2, 6)
        values.append(level + rng.gauss(0, 1))
    signal = np.asarray(values).reshape(-1, 1)
    ours, theirs = SummedL2Cost().fit(signal), ruptures.costs.CostL2().fit(signal)
    for start, end in [(0, n), (0, 2), (3, n - 1), (n // 2, n)]:
        assert ours.error(start, end) == pytest.approx(theirs.error(start, end), abs=1e-9)
    pen = 3.0 * np.log(n) + 8
    found = [
        ruptures.Pelt(custom_cost=cost, min_size=MIN_SEGMENT, jump=1).fit(signal).predict(pen=pen)
        for cost in (ruptures_cost("l2")(), ruptures.costs.CostL2())
    ]
    assert found[0] == found[1]
