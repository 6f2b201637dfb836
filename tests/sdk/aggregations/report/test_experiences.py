"""MostFailedExperiences and FlakyExperiences: experiences ranked across batches.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`. Batches
are fed out of creation order on purpose: the aggregations sort by creation time
themselves.
"""

from __future__ import annotations

import dataclasses
import uuid

from stook.sdk import BarChartMetric, MetricStatus
from stook.sdk.aggregations.report import FlakyExperiences, MostFailedExperiences
from tests.sdk.aggregations.report.support import Output, batch, fold, scrambled

# ---------------------------------------------------------------- MostFailedExperiences


EXPERIENCE_BATCHES = [
    batch(0, 0.0, jobs=[("alpha", "BLOCKER"), ("beta", "PASSED"), ("gamma", "ERROR")]),
    batch(
        1,
        1.0,
        jobs=[("alpha", "ERROR"), ("beta", "WARNING"), ("gamma", "PASSED"), ("delta", "CANCELLED")],
    ),
    batch(
        2,
        2.0,
        jobs=[
            ("alpha", "PASSED"),
            ("beta", "BLOCKER"),
            ("gamma", "BLOCKER"),
            ("delta", "ERROR"),
            ("epsilon", "QUEUED"),
        ],
    ),
    batch(3, 3.0, jobs=[("gamma", "RUNNING"), ("alpha", "ERROR"), ("alpha", "ERROR")]),
]


def test_most_failed_experiences_ranks_failed_jobs_with_ties_by_name() -> None:
    # alpha 4 (twice in b3), gamma 2, beta 1, delta 1; epsilon never failed
    out = Output(fold(MostFailedExperiences(), scrambled(EXPERIENCE_BATCHES)))
    assert out.bars("Most failed experiences") == {
        "alpha": 4.0,
        "gamma": 2.0,
        "beta": 1.0,
        "delta": 1.0,
    }
    assert list(out.bars("Most failed experiences")) == ["alpha", "gamma", "beta", "delta"]
    m = out.by_name["Most failed experiences"]
    assert m.status is MetricStatus.FAIL_WARN
    assert m.description == (
        "Failed jobs (BLOCKER or ERROR) per experience over 4 batches; top 4 of 4 that failed."
    )
    bv = out.view.metric(m.name, BarChartMetric)
    assert (bv.x_axis_name, bv.y_axis_name) == ("Experience", "Failed jobs")


def test_most_failed_experiences_keeps_the_top_n() -> None:
    out = Output(fold(MostFailedExperiences(name="Worst", top_n=3), EXPERIENCE_BATCHES))
    assert out.bars("Worst") == {"alpha": 4.0, "gamma": 2.0, "beta": 1.0}  # delta cut by name
    assert out.by_name["Worst"].description == (
        "Failed jobs (BLOCKER or ERROR) per experience over 4 batches; top 3 of 4 that failed."
    )
    out = Output(fold(MostFailedExperiences(top_n=1), EXPERIENCE_BATCHES))
    assert out.bars("Most failed experiences") == {"alpha": 4.0}


def test_most_failed_experiences_without_failures_says_so() -> None:
    records = [
        batch(0, 0.0, jobs=[("a", "PASSED"), ("b", "WARNING")]),
        batch(1, 1.0, jobs=[("a", "CANCELLED")]),
        batch(2, 2.0),
    ]
    out = Output(fold(MostFailedExperiences(), records))
    assert out.text("Most failed experiences") == (
        "No job failed (BLOCKER or ERROR) in the report's 3 batches.",
        MetricStatus.PASSED,
    )
    assert Output(MostFailedExperiences()).names == []


# ---------------------------------------------------------------- FlakyExperiences


# In creation order; "-" marks a batch where the experience has no outcome.
#   A: F P F P F           -> 4 flips
#   B: P - P F -           -> 1 flip (absent from b1, only CANCELLED in b4)
#   C: P P P P P           -> 0 flips
#   D: F F F P -           -> 1 flip (b1: one failed job among passing ones fails it;
#                                     b3: WARNING and PASSED pass it)
#   E: - - P - F           -> 1 flip (QUEUED; PASSED with RUNNING; no job in b3)
FLAKY_BATCHES = [
    batch(
        0,
        0.0,
        jobs=[("A", "ERROR"), ("B", "PASSED"), ("C", "PASSED"), ("D", "BLOCKER"), ("E", "QUEUED")],
    ),
    batch(
        1,
        1.0,
        jobs=[
            ("A", "PASSED"),
            ("C", "PASSED"),
            ("D", "PASSED"),
            ("D", "ERROR"),
            ("E", "PASSED"),
            ("E", "RUNNING"),
        ],
    ),
    batch(
        2,
        2.0,
        jobs=[("A", "BLOCKER"), ("B", "WARNING"), ("C", "PASSED"), ("D", "ERROR"), ("E", "PASSED")],
    ),
    batch(
        3,
        3.0,
        jobs=[
            ("A", "WARNING"),
            ("B", "BLOCKER"),
            ("C", "PASSED"),
            ("D", "WARNING"),
            ("D", "PASSED"),
        ],
    ),
    batch(
        4,
        4.0,
        jobs=[("A", "ERROR"), ("B", "CANCELLED"), ("C", "WARNING"), ("E", "BLOCKER")],
    ),
]


def test_flaky_experiences_counts_flips_between_consecutive_outcomes() -> None:
    agg = fold(FlakyExperiences(), scrambled(FLAKY_BATCHES))
    assert isinstance(agg, FlakyExperiences)
    assert agg.flips() == {"A": 4, "B": 1, "C": 0, "D": 1, "E": 1}
    out = Output(agg)
    bars = out.bars("Flaky experiences")
    assert list(bars.items()) == [("A", 4.0), ("B", 1.0), ("D", 1.0), ("E", 1.0)]
    m = out.by_name["Flaky experiences"]
    assert m.status is MetricStatus.FAIL_WARN
    assert m.description == (
        "Times each experience's outcome changed between consecutive batches "
        "(failed: any job BLOCKER or ERROR; passed: all jobs PASSED or WARNING)."
    )
    bv = out.view.metric(m.name, BarChartMetric)
    assert (bv.x_axis_name, bv.y_axis_name) == ("Experience", "Pass/fail flips")


def test_flaky_experiences_keeps_the_top_n() -> None:
    out = Output(fold(FlakyExperiences(name="Flaky", top_n=2), FLAKY_BATCHES))
    assert out.bars("Flaky") == {"A": 4.0, "B": 1.0}


def test_flaky_experiences_orders_by_creation_time_not_arrival_or_id() -> None:
    # By creation P F P: 2 flips. By arrival [b1, b0, b2] or by batch ID (b1 < b0 < b2
    # here) the outcomes would read F P P: 1 flip.
    records = [
        dataclasses.replace(batch(0, 0.0, jobs=[("x", "PASSED")]), batch_id=uuid.UUID(int=2)),
        dataclasses.replace(batch(1, 1.0, jobs=[("x", "ERROR")]), batch_id=uuid.UUID(int=1)),
        dataclasses.replace(batch(2, 2.0, jobs=[("x", "PASSED")]), batch_id=uuid.UUID(int=3)),
    ]
    for order in (records, [records[1], records[0], records[2]], records[::-1]):
        agg = fold(FlakyExperiences(), order)
        assert isinstance(agg, FlakyExperiences)
        assert agg.flips() == {"x": 2}


def test_flaky_experiences_without_flips_says_so() -> None:
    records = [batch(i, float(i), jobs=[("x", "PASSED"), ("y", "ERROR")]) for i in range(3)]
    out = Output(fold(FlakyExperiences(), records))
    assert out.text("Flaky experiences") == (
        "No experience flipped between passing and failing across consecutive batches.",
        MetricStatus.PASSED,
    )


def test_flaky_experiences_cancelled_only_batches_give_no_outcome() -> None:
    records = [batch(i, float(i), jobs=[("x", "CANCELLED")]) for i in range(3)]
    agg = fold(FlakyExperiences(), records)
    assert isinstance(agg, FlakyExperiences)
    assert agg.outcomes == {}
    assert Output(agg).names == []
    # Cancelled batches between a pass and a fail do not hide the flip.
    records += [batch(5, 5.0, jobs=[("x", "PASSED")]), batch(6, 6.0, jobs=[("x", "ERROR")])]
    agg = fold(FlakyExperiences(), scrambled(records))
    assert isinstance(agg, FlakyExperiences)
    assert agg.flips() == {"x": 1}
