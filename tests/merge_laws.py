"""The laws every mergeable aggregation obeys, checked the same way for batch and report ones.

An aggregation is a partial state with ``update`` (fold one record in), ``merge`` (fold
another partial in), ``fresh`` (an empty partial with the same configuration) and
``finish`` (write the metrics). Its output must not depend on how the records were split
into partials, nor on the order they arrived or were merged in. ``written`` turns a
finished aggregation into the bytes compared.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from hypothesis import strategies as st

Factories = Mapping[str, Callable[[], Any]]
Written = Callable[[Any], bytes]


def fold_all(factory: Callable[[], Any], records: Sequence[Any], written: Written) -> bytes:
    """The bytes of one partial that saw every record, in the given order."""
    whole = factory()
    for record in records:
        whole.update(record)
    return written(whole)


def assert_split_merge_equals_whole(
    factories: Factories,
    records: Sequence[Any],
    data: st.DataObject,
    written: Written,
    *,
    max_partials: int,
) -> None:
    """Records cut into k consecutive runs, folded into k partials and merged == one fold."""
    k = data.draw(st.integers(1, max_partials), label="partials")
    cuts = sorted(data.draw(st.lists(st.integers(0, len(records)), min_size=k - 1, max_size=k - 1)))
    bounds = [0, *cuts, len(records)]
    for kind, factory in factories.items():
        template = factory()
        partials = [template.fresh() for _ in range(k)]
        for partial, lo, hi in zip(partials, bounds, bounds[1:], strict=False):
            for record in records[lo:hi]:
                partial.update(record)
        first, *rest = partials
        for other in rest:
            first.merge(other)
        assert written(first) == fold_all(factory, records, written), kind


def assert_arrival_order_free(
    factories: Factories, records: Sequence[Any], data: st.DataObject, written: Written
) -> None:
    """Folding the records in any order gives the same bytes."""
    shuffled = data.draw(st.permutations(records), label="shuffled")
    for kind, factory in factories.items():
        assert fold_all(factory, shuffled, written) == fold_all(factory, records, written), kind


def assert_merge_order_free(
    factories: Factories, records: Sequence[Any], data: st.DataObject, written: Written
) -> None:
    """One partial per record, merged into a fresh state in any order == one fold."""
    order = data.draw(st.permutations(range(len(records))), label="merge order")
    for kind, factory in factories.items():
        merged = factory()
        for i in order:
            partial = merged.fresh()
            partial.update(records[i])
            merged.merge(partial)
        assert written(merged) == fold_all(factory, records, written), kind
