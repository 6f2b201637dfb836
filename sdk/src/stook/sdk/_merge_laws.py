"""The laws every aggregation obeys, checked on the bytes it writes.

An aggregation is a partial state: ``update`` folds one record in, ``merge`` folds another
partial in, ``fresh`` makes an empty partial of the same configuration, ``finish`` writes
the metrics. stook folds records into several partials (one per worker, one per page of
jobs) and merges them in whatever order they finish, so what ``finish`` writes must not
depend on how the records were split, in which order they arrived, or in which order the
partials were merged. Outputs are compared as the bytes of a deterministic `MetricsWriter`:
equal bytes, not merely close numbers, because stook's outputs are byte-identical for the
same inputs.

Partials travel: the processes and Ray engines fold each shard of records in another
process and send its partial back, pickled, to be merged. So every partial the checks
merge first goes through a pickle round trip, and an aggregation whose state does not
pickle (a lambda, a lock, an open file) fails with a message naming it.
"""

from __future__ import annotations

import difflib
import pickle
import random
import uuid
from collections.abc import Callable, Sequence
from typing import Any, Generic, TypeVar

from stook.proto import metrics_pb2 as pb
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation

R = TypeVar("R")

CHECK_JOB_ID = uuid.UUID("5ab1e5ab-1e5a-4b1e-8ab1-e5ab1e5ab1e5")
"""The job ID the checked outputs are written under (any fixed ID would do)."""

_MAX_DIFF_LINES = 40


class MergeLaws(Generic[R]):
    """Checks one aggregation's laws on one list of records; each ``check_*`` method raises
    AssertionError naming the case that broke a law.

    `factory` makes a new, empty aggregation (the same configuration each call); the
    reference output is that of one partial that folded every record in the given order.
    ``check_merge_laws`` runs them all; these methods let a property-based test choose the
    orders and splits itself. With `travel` (the default), every partial is pickled and
    unpickled before it is merged, as it is between processes; ``travel=False`` checks an
    aggregation meant only for the local engine.
    """

    def __init__(
        self,
        factory: Callable[[], Aggregation[R]],
        records: Sequence[R],
        *,
        job_id: uuid.UUID = CHECK_JOB_ID,
        travel: bool = True,
    ) -> None:
        self.factory = factory
        self.records = list(records)
        self.job_id = job_id
        self.travel = travel
        self._label = _label(factory())
        self._expected: bytes | str | None = None

    # ---- the laws

    def check_fresh(self) -> None:
        """``fresh()`` is an empty partial of the same class that shares no state with the
        one it was made from: feeding it leaves the original's output alone, ``fresh()`` of
        a partial that saw every record writes what a new aggregation writes, and feeding
        it every record writes the reference."""
        new = self._written(self.factory())
        template = self.factory()
        copy = template.fresh()
        if type(copy) is not type(template):
            raise AssertionError(
                f"{self._label}: fresh() returned a {type(copy).__name__}, "
                f"not a {type(template).__name__}"
            )
        for record in self.records:
            copy.update(record)
        self._compare(template, new, "a new partial after its fresh() copy was fed", "a new one")
        used = self._fold(range(len(self.records)))
        fresh = used.fresh()
        self._compare(fresh, new, "fresh() of a used partial", "a new one")
        for record in self.records:
            fresh.update(record)
        self._compare(fresh, self.expected(), "fresh() of a used partial, fed every record")

    def check_order(self, order: Sequence[int]) -> None:
        """Folding the records in `order` (indexes into the records) writes the same."""
        self._check_indexes(order)
        self._compare(
            self._fold(order), self.expected(), f"records folded in the order {_ids(order)}"
        )

    def check_split(
        self, groups: Sequence[Sequence[int]], merge_order: Sequence[int] | None = None
    ) -> None:
        """Folding each group of records (indexes, in order) into its own partial, then
        merging the partials into the one at ``merge_order[0]`` in `merge_order` (default:
        0, 1, 2, ...), writes the same. Groups may be empty."""
        if not groups:
            raise ValueError("give at least one partial (a group may be empty)")
        self._check_indexes([i for g in groups for i in g])
        order = list(merge_order) if merge_order is not None else list(range(len(groups)))
        if sorted(order) != list(range(len(groups))):
            raise ValueError(f"merge order {order} is not an order of the {len(groups)} partials")
        partials = [self._travelled(self._fold(group)) for group in groups]
        first, *rest = (partials[i] for i in order)
        for other in rest:
            first.merge(other)
        case = f"records split into partials {[list(g) for g in groups]}"
        if merge_order is not None:
            case += f", merged in the order {_ids(order)}"
        self._compare(first, self.expected(), case)

    def check_tree(self) -> None:
        """One partial per record, merged pairwise, then the merged pairs pairwise, and so
        on: merging partials that are themselves merged writes the same."""
        level = [self._travelled(self._fold([i])) for i in range(len(self.records))] or [
            self.factory()
        ]
        while len(level) > 1:
            merged = []
            for left, right in zip(level[::2], level[1::2], strict=False):
                left.merge(right)
                merged.append(self._travelled(left))
            if len(level) % 2:
                merged.append(level[-1])
            level = merged
        self._compare(level[0], self.expected(), "one partial per record, merged pairwise")

    def check_travel(self) -> None:
        """A partial survives a pickle round trip (skipped without `travel`): a new one
        unpickles to one that writes what a new one writes, and one that folded the first
        half of the records unpickles to one that, fed the rest, writes the reference."""
        if not self.travel:
            return
        new = self._written(self.factory())
        self._compare(self._travelled(self.factory()), new, "a new partial, pickled", "a new one")
        half = len(self.records) // 2
        partial = self._travelled(self._fold(range(half)))
        for record in self.records[half:]:
            partial.update(record)
        self._compare(
            partial, self.expected(), f"the first {half} records, pickled, then the rest folded in"
        )

    def check_all(self, *, seed: int = 0, rounds: int = 10, max_partials: int = 4) -> None:
        """Every law: a pickle round trip (`check_travel`), `fresh`, reversed and `rounds`
        shuffled arrival orders, every record in one partial merged with an empty one (both
        ways), one partial per record merged in order, reversed and as a tree, and `rounds`
        random splits into up to `max_partials` partials (records dealt out at random,
        merged in a random order). The same `seed` checks the same cases."""
        rng = random.Random(seed)
        n = len(self.records)
        everything = list(range(n))
        self.check_travel()
        self.check_fresh()
        self.check_order(everything[::-1])
        self.check_split([everything, []])
        self.check_split([everything, []], [1, 0])
        singles = [[i] for i in everything] or [[]]
        self.check_split(singles)
        self.check_split(singles, list(range(len(singles)))[::-1])
        self.check_tree()
        for _ in range(rounds):
            self.check_order(rng.sample(everything, n))
            k = rng.randint(1, max(1, max_partials))
            groups: list[list[int]] = [[] for _ in range(k)]
            for i in rng.sample(everything, n):
                groups[rng.randrange(k)].append(i)
            self.check_split(groups, rng.sample(range(k), k))

    # ---- the reference and the comparison

    def expected(self) -> bytes | str:
        """What one partial that folded every record in order writes (or how it failed)."""
        if self._expected is None:
            self._expected = self._written(self._fold(range(len(self.records))))
        return self._expected

    def _fold(self, indexes: Sequence[int]) -> Aggregation[R]:
        partial = self.factory()
        for i in indexes:
            partial.update(self.records[i])
        return partial

    def _travelled(self, partial: Aggregation[R]) -> Aggregation[R]:
        """The partial after a pickle round trip, as it reaches another process; itself
        without `travel`. A partial that cannot make the trip fails naming the aggregation."""
        if not self.travel:
            return partial
        try:
            payload = pickle.dumps(partial, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # pickling raises whatever the state's objects raise
            raise AssertionError(
                f"{self._label} cannot travel between processes: pickling a partial state "
                f"raised {type(exc).__name__}: {exc}. The processes and ray engines send "
                "partials between processes by pickle: define the class at the top level "
                "of a module, keep its state to picklable values (no lambdas, locks, open "
                "files or generators), or define __getstate__/__setstate__ (see Aggregation)"
            ) from None
        try:
            travelled = pickle.loads(payload)
        except Exception as exc:
            raise AssertionError(
                f"{self._label} cannot travel between processes: unpickling a pickled "
                f"partial state raised {type(exc).__name__}: {exc}"
            ) from None
        if type(travelled) is not type(partial):
            raise AssertionError(
                f"{self._label} cannot travel between processes: a pickled "
                f"{type(partial).__name__} unpickled as a {type(travelled).__name__}"
            )
        result: Aggregation[R] = travelled
        return result

    def _written(self, aggregation: Aggregation[R]) -> bytes | str:
        """The bytes `finish` writes; if it raises, the text of the error (so that two
        cases failing alike compare equal, and differently, not)."""
        writer = MetricsWriter(self.job_id, deterministic=True)
        try:
            aggregation.finish(writer)
            return writer.serialize()
        except Exception as exc:  # a law is about what finish does, raising included
            return f"finish raised {type(exc).__name__}: {exc}"

    def _compare(
        self,
        aggregation: Aggregation[R],
        expected: bytes | str,
        case: str,
        reference: str = "folding every record into one partial in order",
    ) -> None:
        got = self._written(aggregation)
        if got == expected:
            return
        raise AssertionError(
            f"{self._label} broke a merge law: {case} wrote other output than {reference}\n"
            + _diff(expected, got)
        )

    def _check_indexes(self, indexes: Sequence[int]) -> None:
        if sorted(indexes) != list(range(len(self.records))):
            raise ValueError(
                f"{_ids(indexes)} must name every one of the {len(self.records)} records once"
            )


def check_merge_laws(
    factory: Callable[[], Aggregation[R]],
    records: Sequence[R],
    *,
    seed: int = 0,
    rounds: int = 10,
    max_partials: int = 4,
    job_id: uuid.UUID = CHECK_JOB_ID,
    travel: bool = True,
) -> None:
    """Check that `factory`'s aggregation obeys the update/merge/finish laws on `records`.

    Folding the records into several partials and merging them -- in any split, any
    arrival order, any merge order -- must make ``finish`` write byte for byte what one
    partial that folded every record writes, and ``fresh()`` must be an empty partial of
    the same configuration. Partials are pickled and unpickled before they are merged, as
    between the processes of the processes and ray engines (``travel=False`` skips that,
    for an aggregation only ever run locally). Raises AssertionError naming the split or
    order that differed, with a diff of the two outputs, or naming the aggregation whose
    partial does not pickle. See `MergeLaws.check_all` for the cases tried.

        from stook.sdk.testing import check_merge_laws

        def test_my_aggregation_merges() -> None:
            check_merge_laws(lambda: MyAggregation(name="Mean speed"), records)
    """
    MergeLaws(factory, records, job_id=job_id, travel=travel).check_all(
        seed=seed, rounds=rounds, max_partials=max_partials
    )


def _label(aggregation: Aggregation[Any]) -> str:
    name = getattr(aggregation, "name", None)
    cls = type(aggregation).__name__
    return f"{cls} {name!r}" if isinstance(name, str) and name else cls


def _ids(indexes: Sequence[int]) -> str:
    return ", ".join(map(str, indexes)) or "(none)"


def _diff(expected: bytes | str, got: bytes | str) -> str:
    """A unified diff of the two outputs as protobuf text, first lines only."""
    lines = difflib.unified_diff(
        _as_text(expected), _as_text(got), "expected", "got", lineterm="", n=2
    )
    shown = list(lines)
    more = len(shown) - _MAX_DIFF_LINES
    shown = shown[:_MAX_DIFF_LINES]
    if more > 0:
        shown.append(f"... ({more} more diff lines)")
    return "\n".join(shown)


def _as_text(output: bytes | str) -> list[str]:
    if isinstance(output, str):
        return [output]
    from google.protobuf import text_format

    return text_format.MessageToString(pb.JobMetrics.FromString(output)).splitlines()
