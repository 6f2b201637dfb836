"""The laws every mergeable aggregation obeys, checked the same way for batch and report ones.

The laws and their check live in the public `stook.sdk.testing` (`MergeLaws`); here
hypothesis chooses the splits and orders, so that it can shrink a failing case. An
aggregation's output must not depend on how the records were split into partials, nor on
the order they arrived or were merged in.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from hypothesis import strategies as st

from stook.sdk.testing import MergeLaws

Factories = Mapping[str, Callable[[], Any]]
Written = Callable[[Any], bytes]


def fold_all(factory: Callable[[], Any], records: Sequence[Any], written: Written) -> bytes:
    """The bytes of one partial that saw every record, in the given order."""
    whole = factory()
    for record in records:
        whole.update(record)
    return written(whole)


def _each(
    factories: Factories, records: Sequence[Any], check: Callable[[MergeLaws[Any]], None]
) -> None:
    for kind, factory in factories.items():
        try:
            check(MergeLaws(factory, records))
        except AssertionError as exc:
            raise AssertionError(f"[{kind}] {exc}") from None


def assert_split_merge_equals_whole(
    factories: Factories, records: Sequence[Any], data: st.DataObject, *, max_partials: int
) -> None:
    """Records cut into k consecutive runs, folded into k partials and merged == one fold."""
    k = data.draw(st.integers(1, max_partials), label="partials")
    cuts = sorted(data.draw(st.lists(st.integers(0, len(records)), min_size=k - 1, max_size=k - 1)))
    bounds = [0, *cuts, len(records)]
    groups = [list(range(lo, hi)) for lo, hi in itertools.pairwise(bounds)]
    _each(factories, records, lambda laws: laws.check_split(groups))


def assert_arrival_order_free(
    factories: Factories, records: Sequence[Any], data: st.DataObject
) -> None:
    """Folding the records in any order gives the same bytes."""
    order = data.draw(st.permutations(range(len(records))), label="arrival order")
    _each(factories, records, lambda laws: laws.check_order(order))


def assert_merge_order_free(
    factories: Factories, records: Sequence[Any], data: st.DataObject
) -> None:
    """One partial per record, merged into an empty one in any order == one fold."""
    order = data.draw(st.permutations(range(len(records))), label="merge order")
    groups = [[], *([i] for i in range(len(records)))]
    _each(factories, records, lambda laws: laws.check_split(groups, [0, *(i + 1 for i in order)]))


def assert_fresh_is_empty(factories: Factories, records: Sequence[Any]) -> None:
    """fresh() of a used partial is empty and shares no state with it."""
    _each(factories, records, lambda laws: laws.check_fresh())
