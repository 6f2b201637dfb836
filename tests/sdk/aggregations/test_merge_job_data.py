"""The merge laws for the built-ins that read job metrics, data, events, parameters and tags:
folding jobs into partials and merging them writes the bytes that folding them all into one
writes, whatever the order the jobs arrive or the partials merge in."""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable

from hypothesis import given
from hypothesis import strategies as st

from stook.sdk import MetricsWriter
from stook.sdk.aggregations import (
    BatchAggregation,
    ByExperienceTag,
    CategoryTotals,
    EventCounts,
    JobRecord,
    MergedHistogram,
    ParameterSweep,
    Scalar,
)
from stook.sdk.testing import check_merge_laws
from tests import merge_laws
from tests.hypothesis_profiles import examples
from tests.sdk.aggregations.job_outputs import job_with

BATCH_ID = uuid.UUID("0d0d0d0d-1111-4222-8333-444444444444")
BUCKETS = [(-4.0, -1.0), (-1.0, 0.0), (0.0, 0.5), (0.5, 4.0)]

FACTORIES: dict[str, Callable[[], BatchAggregation]] = {
    "histogram_metric": lambda: MergedHistogram(name="H", metric="Speed histogram"),
    "histogram_metric_counts": lambda: MergedHistogram(
        name="HC", metric="Speed histogram", max_values=3
    ),
    "category_totals_data": lambda: CategoryTotals(data="per class"),
    "category_totals_metric": lambda: CategoryTotals(metric="Detections"),
    "events": EventCounts,
    "sweep": lambda: ParameterSweep(parameters=["speed", "map"], metrics=["a", "b"]),
    "by_tag": lambda: ByExperienceTag(metrics=["a", "b"]),
}

AWKWARD = [0.0, -0.0, math.inf, -math.inf, math.nan]
values = st.one_of(st.floats(min_value=-6, max_value=6), st.sampled_from([0.5, -1.0, *AWKWARD]))
labels = st.sampled_from(["car", "bus", "truck"])


@st.composite
def job_records(draw: st.DrawFn) -> JobRecord:
    histogram = None
    if draw(st.booleans()):
        histogram = ("Speed histogram", draw(st.lists(values, min_size=1, max_size=4)), BUCKETS)
    per_category = None
    by_label = draw(st.dictionaries(labels, st.lists(values, min_size=1, max_size=3)))
    if by_label:
        per_category = ("per class", by_label)
    bars = None
    if draw(st.booleans()):
        legends = draw(
            st.dictionaries(st.sampled_from(["found", "missed"]), st.just(0), min_size=1)
        )
        bars = (
            "Detections",
            {legend: draw(st.dictionaries(labels, values, min_size=1)) for legend in legends},
        )
    scalars = {
        name: Scalar(draw(values), draw(st.sampled_from(["", "m", "km"])))
        for name in draw(st.sets(st.sampled_from(["a", "b"])))
    }
    parameters = {
        name: draw(st.sampled_from(["1", "1.0", "2", "10", "x"]))
        for name in draw(st.sets(st.sampled_from(["speed", "map"])))
    }
    events = draw(
        st.lists(
            st.tuples(st.sampled_from(["Collision", "Brake"]), st.sampled_from(["PASSED", "ODD"])),
            max_size=3,
        )
    )
    return job_with(
        draw(st.sampled_from(["PASSED", "ERROR"])),
        histogram=histogram,
        per_category=per_category,
        bars=bars,
        scalars=scalars,
        parameters=parameters,
        events=events,
        tags=draw(st.lists(st.sampled_from(["night", "rain"]), max_size=2, unique=True)),
        job_id=uuid.UUID(int=draw(st.integers(0, 2**64))),
    )


def written(aggregation: BatchAggregation) -> bytes:
    writer = MetricsWriter(BATCH_ID, deterministic=True)
    aggregation.finish(writer)
    return writer.serialize()


@examples(40)
@given(records=st.lists(job_records(), max_size=8), data=st.data())
def test_merging_partials_equals_folding_everything(
    records: list[JobRecord], data: st.DataObject
) -> None:
    merge_laws.assert_split_merge_equals_whole(FACTORIES, records, data, max_partials=4)


@examples(40)
@given(records=st.lists(job_records(), max_size=8), data=st.data())
def test_job_order_does_not_change_the_output(
    records: list[JobRecord], data: st.DataObject
) -> None:
    merge_laws.assert_arrival_order_free(FACTORIES, records, data)


@examples(30)
@given(records=st.lists(job_records(), max_size=6), data=st.data())
def test_merge_order_does_not_change_the_output(
    records: list[JobRecord], data: st.DataObject
) -> None:
    merge_laws.assert_merge_order_free(FACTORIES, records, data)


def test_the_properties_are_not_vacuous() -> None:
    # Different jobs give different bytes for every aggregation tested above.
    one = job_with(
        histogram=("Speed histogram", [1.0], BUCKETS),
        per_category=("per class", {"car": [1.0]}),
        bars=("Detections", {"found": {"car": 1.0}}),
        scalars={"a": 1.0},
        parameters={"speed": "1"},
        events=[("Brake", "PASSED")],
        tags=["night"],
    )
    two = job_with(
        "ERROR",
        histogram=("Speed histogram", [2.0, 3.0], BUCKETS),
        per_category=("per class", {"bus": [2.0]}),
        bars=("Detections", {"found": {"bus": 2.0}}),
        scalars={"a": 2.0},
        parameters={"speed": "2"},
        events=[("Collision", "PASSED")],
        tags=["rain"],
    )
    for kind, factory in FACTORIES.items():
        assert merge_laws.fold_all(factory, [one], written) != merge_laws.fold_all(
            factory, [two], written
        ), kind


def test_the_public_one_line_check_passes_for_every_built_in() -> None:
    records = [
        job_with(
            histogram=("Speed histogram", [float(i), -1.0], BUCKETS),
            per_category=("per class", {"car": [1.0 * i], "bus": [0.5]}),
            bars=("Detections", {"found": {"car": float(i)}}),
            scalars={"a": float(i), "b": Scalar(2.0 * i, "m")},
            parameters={"speed": str(i % 3), "map": "x" if i % 2 else "y"},
            events=[("Brake", "PASSED")] * i,
            tags=["night"] if i % 2 else [],
        )
        for i in range(6)
    ]
    for factory in FACTORIES.values():
        check_merge_laws(factory, records)
