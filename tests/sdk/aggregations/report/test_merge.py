"""Report partial states merge: folding batches into k partials and merging them writes the
same bytes as folding every batch into one, and the order the batches arrive in does not
change the bytes (report aggregations sort by creation time themselves)."""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable
from datetime import UTC, datetime, timedelta

from hypothesis import given
from hypothesis import strategies as st

from stook.sdk import MetricsWriter
from stook.sdk.aggregations import (
    JOB_STATUSES,
    METRIC_STATUSES,
    BatchRecord,
    JobSummary,
    ReportAggregation,
    Scalar,
)
from stook.sdk.aggregations.report import (
    BatchMetricStatusCounts,
    ChangePoints,
    FlakyExperiences,
    JobMetricStatusCounts,
    JobScalarDistributions,
    MostFailedExperiences,
    ScalarLines,
    TestStatusOverTime,
    UnstableExperiences,
)
from tests import merge_laws
from tests.hypothesis_profiles import examples

REPORT_ID = uuid.UUID("0e0e0e0e-1111-4222-8333-444444444444")
PROJECT_ID = "5e5e5e5e-1111-4222-8333-444444444444"
T0 = datetime(2024, 3, 1, 12, 0, tzinfo=UTC)

FACTORIES: dict[str, Callable[[], ReportAggregation]] = {
    "scalar_lines": ScalarLines,
    # a short window and a low threshold, so that verdicts (and regressions) are common
    "scalar_lines_tight": lambda: ScalarLines(name="Tight", window=3, threshold=1.0),
    "most_failed": MostFailedExperiences,
    "most_failed_top_2": lambda: MostFailedExperiences(name="Top 2", top_n=2),
    "flaky": FlakyExperiences,
    "flaky_top_1": lambda: FlakyExperiences(name="Flakiest", top_n=1),
    "test_status_over_time": lambda: TestStatusOverTime(project_id=PROJECT_ID),
    "job_metric_status_counts": JobMetricStatusCounts,
    "batch_metric_status_counts": BatchMetricStatusCounts,
    "job_scalar_distributions": JobScalarDistributions,
    "job_scalar_distributions_s": lambda: JobScalarDistributions(metrics=["s"]),
    # a small penalty, so that change points are common in 6 to 8 batches
    "change_points": lambda: ChangePoints(penalty=0.1, top_n=2),
    "change_points_lines_only": lambda: ChangePoints(name="Lines", experiences=False),
    "scalar_lines_changes": lambda: ScalarLines(name="Changes", change_penalty=0.1),
    "unstable": UnstableExperiences,
    "unstable_s_top_1": lambda: UnstableExperiences(name="Top unstable", top_n=1, metrics=["s"]),
}

# Awkward values on purpose: -0.0 sorts equal to 0.0; job values that are not finite are
# left out of the distributions.
AWKWARD = [0.0, -0.0, math.inf, -math.inf]
scalar_values = st.one_of(
    st.floats(min_value=-1e6, max_value=1e6, allow_nan=False),
    st.sampled_from([*AWKWARD, 1.0, 2.0]),
)
job_values = st.one_of(scalar_values, st.just(math.nan))
units = st.sampled_from(["", "m", "km"])
api_statuses = st.sampled_from([*METRIC_STATUSES, "ODD"])


@st.composite
def batch_records(draw: st.DrawFn, batch_id: uuid.UUID) -> BatchRecord:
    scalars = {
        name: Scalar(draw(scalar_values), draw(units), draw(api_statuses))
        # "a" in most batches, so that its line often gets a regression verdict
        for name in draw(st.sampled_from(["a", "ab", "ac", "abc", "b", ""]))
    }
    job_scalars = {
        name: draw(st.lists(job_values, max_size=5))
        for name in draw(st.sets(st.sampled_from(["s", "t"])))
    }
    jobs = [
        JobSummary(
            uuid.UUID(int=draw(st.integers(0, 2**64))),
            draw(st.sampled_from(["e1", "e2", "e3", ""])),
            draw(st.sampled_from([*JOB_STATUSES, "ODD"])),
            scalars={name: draw(job_values) for name in draw(st.sets(st.sampled_from(["s", "t"])))},
        )
        for _ in range(draw(st.integers(0, 5)))
    ]
    return BatchRecord(
        batch_id=batch_id,
        name=draw(st.sampled_from(["nightly", "pr-1", "pr-2"])),
        # Few distinct times: ties in creation time are broken by batch ID.
        created=T0 + timedelta(hours=draw(st.integers(0, 12)) * 6),
        scalars=scalars,
        metric_statuses=draw(st.lists(api_statuses, max_size=3)),
        jobs=jobs,
        job_scalars=job_scalars,
        job_scalar_units={name: draw(units) for name in job_scalars},
        job_metric_statuses=draw(st.lists(api_statuses, max_size=4)),
        build_id=draw(st.sampled_from([None, uuid.UUID(int=7), uuid.UUID(int=8)])),
    )


@st.composite
def reports(draw: st.DrawFn) -> list[BatchRecord]:
    n = draw(st.integers(0, 9))
    ids = draw(st.lists(st.integers(1, 2**32), unique=True, min_size=n, max_size=n))
    return [draw(batch_records(uuid.UUID(int=i))) for i in ids]


def written(aggregation: ReportAggregation) -> bytes:
    writer = MetricsWriter(REPORT_ID, deterministic=True)
    aggregation.finish(writer)
    return writer.serialize()


def fold_all(factory: Callable[[], ReportAggregation], records: list[BatchRecord]) -> bytes:
    return merge_laws.fold_all(factory, records, written)


@examples(40)
@given(records=reports(), data=st.data())
def test_merging_partials_equals_folding_everything(
    records: list[BatchRecord], data: st.DataObject
) -> None:
    merge_laws.assert_split_merge_equals_whole(FACTORIES, records, data, max_partials=4)


@examples(40)
@given(records=reports(), data=st.data())
def test_batch_order_does_not_change_the_output(
    records: list[BatchRecord], data: st.DataObject
) -> None:
    merge_laws.assert_arrival_order_free(FACTORIES, records, data)


@examples(40)
@given(records=reports(), data=st.data())
def test_merge_order_does_not_change_the_output(
    records: list[BatchRecord], data: st.DataObject
) -> None:
    merge_laws.assert_merge_order_free(FACTORIES, records, data)


def test_fresh_keeps_the_configuration_and_drops_the_state() -> None:
    record = BatchRecord(
        uuid.UUID(int=1),
        "b",
        T0,
        scalars={"a": Scalar(1.0)},
        jobs=[JobSummary(uuid.UUID(int=2), "e1", "ERROR")],
    )
    for kind, factory in FACTORIES.items():
        used = factory()
        used.update(record)
        fresh = used.fresh()
        assert type(fresh) is type(used), kind
        assert written(fresh) == written(factory()), kind
        assert fresh.name == used.name, kind
    tight = FACTORIES["scalar_lines_tight"]().fresh()
    assert isinstance(tight, ScalarLines)
    assert (tight.window, tight.threshold) == (3, 1.0)


def test_the_properties_are_not_vacuous() -> None:
    # Different batches do give different bytes, and the order in time does matter.
    def record(n: int, hours: int, value: float, status: str) -> BatchRecord:
        return BatchRecord(
            uuid.UUID(int=n),
            f"b{n}",
            T0 + timedelta(hours=hours),
            scalars={"a": Scalar(value, "m", "PASSED")},
            metric_statuses=[status],
            jobs=[JobSummary(uuid.UUID(int=100 + n), "e1", "ERROR" if value > 1 else "PASSED")],
            job_scalars={"s": [value, value * 2]},
            job_metric_statuses=[status],
        )

    one = [record(1, 0, 1.0, "PASSED"), record(2, 6, 2.0, "FAIL_WARN")]
    swapped_times = [record(1, 6, 1.0, "PASSED"), record(2, 0, 2.0, "FAIL_WARN")]
    # Change points need 6 batches and spreads 4: their own tests show them non-vacuous
    # (test_change_report.py, test_unstable.py).
    needs_more = ("change_points", "unstable")
    for kind in FACTORIES:
        if kind.startswith(needs_more):
            continue
        if kind.startswith("most_failed") or kind.endswith("counts"):
            continue  # order-free by nature
        if kind.startswith("flaky"):
            continue  # 1 flip either way
        assert fold_all(FACTORIES[kind], one) != fold_all(FACTORIES[kind], swapped_times), kind
    other = [record(1, 0, 3.0, "FAIL_BLOCK"), record(2, 6, 4.0, "PASSED")]
    for kind, factory in FACTORIES.items():
        if kind.startswith(needs_more):
            continue
        assert fold_all(factory, one) != fold_all(factory, other), kind
    assert fold_all(FACTORIES["flaky"], one) != fold_all(FACTORIES["flaky"], one[:1])
