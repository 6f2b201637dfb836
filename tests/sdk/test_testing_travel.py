"""check_merge_laws pickles every partial before merging it, as the processes and Ray engines
do: an aggregation whose state does not pickle, or loses something on the way, is caught
and named."""

from __future__ import annotations

import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import pytest

from stook.sdk.aggregations import JobRecord
from stook.sdk.testing import MergeLaws, check_merge_laws
from tests.sdk.test_testing import RECORDS, Total


@dataclass
class HoldsALambda(Total):
    """Keeps how to read a job as a lambda: fine in one process, not across two."""

    read: Callable[[JobRecord], float] = field(
        default_factory=lambda: lambda record: record.scalars["a"].value, init=False
    )

    def update(self, record: JobRecord) -> None:
        self.seen.append(self.read(record))


@dataclass
class HoldsALock(Total):
    lock: Any = field(default_factory=threading.Lock, init=False)

    def update(self, record: JobRecord) -> None:
        with self.lock:
            super().update(record)


@dataclass
class ForgetsOnTheWay(Total):
    """Pickles its configuration but not its values: every merge law holds in one process."""

    def __getstate__(self) -> dict[str, object]:
        return {"name": self.name, "total": self.total, "seen": []}


@dataclass
class BreaksOnArrival(Total):
    def __setstate__(self, state: dict[str, object]) -> None:
        raise ValueError("state from another version")


@dataclass
class ArrivesAsAnother(Total):
    def __reduce__(self) -> tuple[type, tuple[str]]:
        return (Total, (self.name,))


@pytest.mark.parametrize(
    ("cls", "why"),
    [
        (HoldsALambda, r"raised (PicklingError|AttributeError): .*lambda"),
        (HoldsALock, r"raised TypeError: cannot pickle '_thread.lock' object"),
    ],
)
def test_a_state_that_does_not_pickle_is_named_with_the_reason(cls: type[Total], why: str) -> None:
    with pytest.raises(AssertionError) as caught:
        check_merge_laws(lambda: cls(name="Unpicklable"), RECORDS, rounds=1)
    message = str(caught.value)
    assert message.startswith(f"{cls.__name__} 'Unpicklable' cannot travel between processes")
    assert re.search(why, message), message
    assert "__getstate__/__setstate__" in message
    # The same aggregation obeys every law in one process: the round trip is what fails.
    check_merge_laws(lambda: cls(name="Unpicklable"), RECORDS, rounds=1, travel=False)


def test_a_state_that_loses_values_on_the_way_breaks_a_merge_law() -> None:
    check_merge_laws(ForgetsOnTheWay, RECORDS, rounds=2, travel=False)  # fine locally
    with pytest.raises(AssertionError, match=r"ForgetsOnTheWay 'Total' broke a merge law: the "):
        check_merge_laws(ForgetsOnTheWay, RECORDS, rounds=2)
    # Each check that merges sends its partials through pickle too.
    laws = MergeLaws(ForgetsOnTheWay, RECORDS)
    with pytest.raises(AssertionError, match=r"records split into partials"):
        laws.check_split([[0, 1, 2], [3, 4, 5, 6]])
    with pytest.raises(AssertionError, match=r"one partial per record, merged pairwise"):
        laws.check_tree()


def test_a_state_that_cannot_be_unpickled_is_named() -> None:
    with pytest.raises(
        AssertionError,
        match=r"BreaksOnArrival 'Total' cannot travel between processes: unpickling a pickled "
        r"partial state raised ValueError: state from another version",
    ):
        check_merge_laws(BreaksOnArrival, RECORDS, rounds=1)


def test_a_state_that_unpickles_as_another_class_is_named() -> None:
    with pytest.raises(AssertionError, match=r"a pickled ArrivesAsAnother unpickled as a Total"):
        MergeLaws(ArrivesAsAnother, RECORDS).check_travel()


def test_without_travel_the_round_trip_is_skipped() -> None:
    laws = MergeLaws(HoldsALambda, RECORDS, travel=False)
    laws.check_travel()  # nothing to check
    laws.check_split([[0, 1], [2, 3, 4, 5, 6]])
    laws.check_tree()


def test_a_class_defined_in_a_function_is_named_with_the_fix() -> None:
    @dataclass
    class Local(Total):
        pass

    with pytest.raises(AssertionError, match=r"Local 'Total' cannot travel .* define the class at"):
        check_merge_laws(Local, RECORDS, rounds=1)
