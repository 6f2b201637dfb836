"""stook.sdk.testing.check_merge_laws: passes every built-in aggregation, and catches
aggregations that break the update/merge/finish laws, naming the case that differed."""

from __future__ import annotations

import subprocess
import sys
import uuid
from dataclasses import dataclass, field

import pytest

from stook.sdk import MetricsWriter
from stook.sdk.aggregations import BatchAggregation, JobRecord, Scalar
from stook.sdk.testing import MergeLaws, check_merge_laws
from tests import merge_laws
from tests.sdk.aggregations import test_merge as batch_merge

RECORDS = [
    JobRecord(
        uuid.UUID(int=i + 1),
        ["PASSED", "ERROR", "PASSED", "FAILED"][i % 4],
        scalars={"a": Scalar(float(i * i) - 3.5, "m"), "w": Scalar(float(i % 3))},
        metric_statuses=["PASSED", "FAIL_WARN"][: i % 3],
    )
    for i in range(7)
]


@pytest.mark.parametrize("kind", sorted(batch_merge.FACTORIES))
def test_every_built_in_batch_aggregation_obeys_the_laws(kind: str) -> None:
    check_merge_laws(batch_merge.FACTORIES[kind], RECORDS, rounds=4)


def test_fresh_is_empty_for_every_built_in() -> None:
    merge_laws.assert_fresh_is_empty(batch_merge.FACTORIES, RECORDS)


# ---------------------------------------------------------------- deliberately broken ones


@dataclass
class Total(BatchAggregation):
    """The sum of scalar 'a' over the jobs: a correct aggregation, then broken one way each."""

    name: str = "Total"
    total: float = field(default=0.0, init=False)
    seen: list[float] = field(default_factory=list, init=False)

    def update(self, record: JobRecord) -> None:
        self.seen.append(record.scalars["a"].value)

    def merge(self, other: Total) -> None:
        self.seen.extend(other.seen)

    def finish(self, writer: MetricsWriter) -> None:
        # Summed in sorted order, so that the float sum does not depend on arrival order.
        writer.scalar(self.name, sum(sorted(self.seen)))


@dataclass
class MergeDropsTheOther(Total):
    def merge(self, other: Total) -> None:
        pass


@dataclass
class LastOneWins(Total):
    def finish(self, writer: MetricsWriter) -> None:
        writer.scalar(self.name, self.seen[-1] if self.seen else 0.0)


@dataclass
class FreshSharesState(Total):
    def fresh(self) -> FreshSharesState:
        copy = FreshSharesState(self.name)
        copy.seen = self.seen
        return copy


@dataclass
class FreshKeepsState(Total):
    def fresh(self) -> FreshKeepsState:
        copy = FreshKeepsState(self.name)
        copy.seen = list(self.seen)
        return copy


@dataclass
class FailsOnFewJobs(Total):
    def finish(self, writer: MetricsWriter) -> None:
        if 0 < len(self.seen) < 3:
            raise ValueError("too few jobs")
        super().finish(writer)


def test_a_correct_aggregation_passes() -> None:
    check_merge_laws(Total, RECORDS)
    check_merge_laws(Total, [])


def test_a_merge_that_drops_the_other_partial_is_caught() -> None:
    with pytest.raises(AssertionError) as caught:
        check_merge_laws(MergeDropsTheOther, RECORDS)
    first, *diff = str(caught.value).splitlines()
    assert first == (
        "MergeDropsTheOther 'Total' broke a merge law: records split into partials "
        "[[0, 1, 2, 3, 4, 5, 6], []], merged in the order 1, 0 wrote other output than "
        "folding every record into one partial in order"
    )
    assert diff[:2] == ["--- expected", "+++ got"]
    assert "-        value: 66.5" in diff
    assert "+        value: 0.0" in diff


def test_an_order_dependent_aggregation_is_caught() -> None:
    with pytest.raises(AssertionError, match=r"records folded in the order 6, 5, 4, 3, 2, 1, 0"):
        check_merge_laws(LastOneWins, RECORDS)


def test_a_fresh_that_shares_or_keeps_state_is_caught() -> None:
    with pytest.raises(
        AssertionError, match=r"fresh\(\) of a used partial wrote other output than a new one"
    ):
        check_merge_laws(FreshKeepsState, RECORDS)
    with pytest.raises(AssertionError, match=r"a new partial after its fresh\(\) copy was fed"):
        MergeLaws(FreshSharesState, RECORDS[:1]).check_fresh()


@dataclass
class DropsAndFails(MergeDropsTheOther):
    def finish(self, writer: MetricsWriter) -> None:
        if len(self.seen) < 3:
            raise ValueError("too few jobs")
        super().finish(writer)


def test_a_finish_that_raises_is_shown_as_such() -> None:
    MergeLaws(DropsAndFails, RECORDS).check_split([[0, 1, 2, 3, 4, 5, 6]])
    with pytest.raises(AssertionError) as caught:
        MergeLaws(DropsAndFails, RECORDS).check_split([[0, 1, 2, 3], [4, 5, 6]])
    assert "+finish raised ValueError: too few jobs" not in str(caught.value)
    with pytest.raises(AssertionError) as caught:
        MergeLaws(DropsAndFails, RECORDS).check_split([[0], [1, 2, 3, 4, 5, 6]])
    assert str(caught.value).splitlines()[-1] == "+finish raised ValueError: too few jobs"


def test_single_checks_refuse_indexes_that_are_not_the_records() -> None:
    laws = MergeLaws(Total, RECORDS[:3])
    with pytest.raises(ValueError, match="must name every one of the 3 records once"):
        laws.check_order([0, 1])
    with pytest.raises(ValueError, match="must name every one of the 3 records once"):
        laws.check_split([[0, 1], [1, 2]])
    with pytest.raises(ValueError, match="is not an order of the 2 partials"):
        laws.check_split([[0, 1], [2]], [0, 0])
    with pytest.raises(ValueError, match="at least one partial"):
        laws.check_split([])


def test_the_module_needs_no_pytest() -> None:
    code = (
        "import sys, stook.sdk.testing; "
        "assert 'pytest' not in sys.modules and 'hypothesis' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


@dataclass
class FreshOfAnotherClass(Total):
    def fresh(self) -> Total:  # type: ignore[override]
        return Total(self.name)


def test_a_fresh_of_another_class_is_caught() -> None:
    with pytest.raises(
        AssertionError, match=r"fresh\(\) returned a Total, not a FreshOfAnotherClass"
    ):
        check_merge_laws(FreshOfAnotherClass, RECORDS)
