"""The change-point search's PELT over numpy arrays: ruptures' own `Pelt` partitions,
penalised totals and breakpoints, bit for bit, on both costs."""

from __future__ import annotations

import random

import numpy as np
import pytest
import ruptures

from stook.sdk._pelt import _binomial_cost, _l2_cost, _vector_pelt
from stook.sdk.aggregations.report._change_points import penalty


def _levels(rng: random.Random, n: int) -> np.ndarray:
    level, values, rate = 0.0, [], rng.choice([0.0, 0.01, 0.05, 0.3])
    for _ in range(n):
        if rng.random() < rate:
            level += rng.choice([-1, 1]) * rng.uniform(0.5, 6)
        values.append(level + rng.gauss(0, 1))
    if rng.random() < 0.3:  # whole numbers: exact ties between partitions
        values = [float(round(v)) for v in values]
    return np.asarray(values).reshape(-1, 1)


def _rates(rng: random.Random, n: int) -> np.ndarray:
    counted = [rng.randint(1, 30) for _ in range(n)]
    share, failed = rng.uniform(0, 0.3), []
    for c in counted:
        if rng.random() < 0.03:
            share = rng.uniform(0, 0.6)
        failed.append(sum(rng.random() < share for _ in range(c)))
    return np.column_stack([np.asarray(failed, float), np.asarray(counted, float)])


@pytest.mark.parametrize("seed", range(40))
def test_same_partition_as_ruptures_pelt(seed: int) -> None:
    rng = random.Random(seed)
    n = rng.choice([6, 7, 12, 40, 150])
    kind = seed % 2
    signal = _levels(rng, n) if kind == 0 else _rates(rng, n)
    cost = (_l2_cost() if kind == 0 else _binomial_cost())()
    pen = rng.choice([penalty(n), 0.5, 2.0, 30.0])
    theirs = ruptures.Pelt(custom_cost=cost, min_size=1, jump=1).fit(signal)._seg(pen)
    ours = _vector_pelt()(custom_cost=cost, min_size=1, jump=1).fit(signal)._seg(pen)
    assert list(ours.items()) == sorted(theirs.items())


def test_a_constant_series_ties_everywhere_and_still_agrees() -> None:
    signal = np.zeros((30, 1))
    cost = _l2_cost()()
    theirs = ruptures.Pelt(custom_cost=cost, min_size=1, jump=1).fit(signal).predict(pen=0.0)
    ours = _vector_pelt()(custom_cost=cost, min_size=1, jump=1).fit(signal).predict(pen=0.0)
    assert ours == theirs


def test_other_settings_take_ruptures_own_search() -> None:
    signal = _levels(random.Random(1), 60)
    for jump, min_size in ((5, 1), (1, 3)):
        cost = _l2_cost()()
        theirs = ruptures.Pelt(custom_cost=cost, min_size=min_size, jump=jump).fit(signal)
        ours = _vector_pelt()(custom_cost=cost, min_size=min_size, jump=jump).fit(signal)
        assert ours.predict(pen=4.0) == theirs.predict(pen=4.0)
