"""The change-point search's PELT over numpy arrays: ruptures' own `Pelt` partitions,
penalised totals and breakpoints, bit for bit, on both costs; and the search as stook
runs it, the same breakpoints without importing ruptures."""

from __future__ import annotations

import random
import subprocess
import sys

import numpy as np
import pytest
import ruptures

from stook.sdk.aggregations.report._change_points import (
    _partition,
    penalty,
    ruptures_cost,
    search,
)


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
    cost = ruptures_cost("l2" if kind == 0 else "binomial")()
    pen = rng.choice([penalty(n), 0.5, 2.0, 30.0])
    theirs = ruptures.Pelt(custom_cost=cost, min_size=1, jump=1).fit(signal)._seg(pen)
    ours = _partition(cost.fit(signal), n, pen)
    assert list(ours.items()) == sorted(theirs.items())


def test_a_constant_series_ties_everywhere_and_still_agrees() -> None:
    signal = np.zeros((30, 1))
    cost = ruptures_cost("l2")()
    theirs = ruptures.Pelt(custom_cost=cost, min_size=1, jump=1).fit(signal).predict(pen=0.0)
    assert search("l2", signal, 0.0, 1) == theirs[:-1]


@pytest.mark.parametrize("seed", range(60))
def test_the_search_finds_ruptures_own_breakpoints(seed: int) -> None:
    rng = random.Random(seed)
    n = rng.choice([6, 7, 12, 40, 150])
    kind = ("l2", "binomial")[seed % 2]
    signal = _levels(rng, n) if kind == "l2" else _rates(rng, n)
    pen = rng.choice([penalty(n), 0.5, 2.0, 30.0])
    pelt = ruptures.Pelt(custom_cost=ruptures_cost(kind)(), min_size=1, jump=1)
    assert search(kind, signal, pen, 1) == pelt.fit(signal).predict(pen=pen)[:-1]


def test_a_longer_least_segment_takes_ruptures_own_search() -> None:
    signal = _levels(random.Random(3), 60)
    pelt = ruptures.Pelt(custom_cost=ruptures_cost("l2")(), min_size=3, jump=1)
    assert search("l2", signal, 4.0, 3) == pelt.fit(signal).predict(pen=4.0)[:-1]


def test_registered_costs_are_rupturess_base_cost() -> None:
    # ruptures' Pelt searches with its own "l2" when a custom cost is not a BaseCost.
    for kind in ("l2", "binomial"):
        assert isinstance(ruptures_cost(kind)(), ruptures.base.BaseCost)


def test_the_search_imports_neither_ruptures_nor_scipy() -> None:
    script = (
        "import sys\n"
        "import numpy as np\n"
        "from stook.sdk.aggregations.report._change_points import search\n"
        "levels = np.asarray([0.0] * 10 + [5.0] * 10).reshape(-1, 1)\n"
        "rates = np.column_stack([[0.0] * 10 + [9.0] * 10, [10.0] * 20])\n"
        "print(search('l2', levels, 10.0, 1), search('binomial', rates, 10.0, 1))\n"
        "print(sorted(m for m in ('ruptures', 'scipy') if m in sys.modules))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == "[10] [10]\n[]\n"
