"""stook's validator: the rules of each metric type's values, and their messages.

Every case also runs ReSim's validator, so that a message here can never claim
a decision ReSim would not make.
"""

from __future__ import annotations

import math

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import InvalidMetricsError, find_problems, validate_job_metrics
from tests.sdk.valid_output import (
    Job,
    Mutation,
    batch_values,
    drop_data,
    hist_values,
    resim_accepts,
    set_fields,
    states_values,
    uid,
)

HIST = f"metric 'Speed histogram' (id {uid('Speed histogram')})"


REFUSED: list[tuple[str, Mutation, str]] = [
    (
        "bucket gap",
        lambda j: set_fields(hist_values(j).buckets[2], lower=3.0),
        f"{HIST}: histogram buckets must be contiguous (bucket 2 starts at 3.0, "
        "previous ended at 2.5)",
    ),
    (
        "no buckets",
        lambda j: hist_values(j).ClearField("buckets"),
        f"{HIST}: a histogram needs at least one bucket",
    ),
    (
        "first bucket",
        lambda j: set_fields(hist_values(j), lower_bound=-1.0),
        f"{HIST}: histogram bucket 0 starts at 0.0, but lower_bound is -1.0",
    ),
    (
        "last bucket",
        lambda j: set_fields(hist_values(j), upper_bound=5.0),
        f"{HIST}: the last histogram bucket ends at 4.0, but upper_bound is 5.0",
    ),
    (
        "empty bucket",
        lambda j: set_fields(hist_values(j).buckets[0], upper=0.0),
        f"{HIST}: histogram bucket 0 must end after it starts (0.0 to 0.0)",
    ),
    (
        "missing data",
        drop_data("value statuses"),
        f"{HIST}: values status data {uid('value statuses')} is not in the output",
    ),
    (
        "wrong value type",
        lambda j: set_fields(j.data("values"), data_type=pb.STRING_SERIES_DATA_TYPE),
        f"{HIST}: values data 'values' is STRING_SERIES_DATA_TYPE, "
        "but must be DOUBLE_SERIES_DATA_TYPE or INDEXED_DOUBLE_SERIES_DATA_TYPE",
    ),
    (
        "wrong status type",
        lambda j: set_fields(j.data("speed statuses"), data_type=pb.METRIC_STATUS_SERIES_DATA_TYPE),
        "doubles status data 'speed statuses' is METRIC_STATUS_SERIES_DATA_TYPE, "
        "but must be INDEXED_METRIC_STATUS_SERIES_DATA_TYPE",
    ),
    (
        "different index",
        lambda j: set_fields(j.data("speed statuses").index_data_id.id, data=uid("names")),
        "status data 'speed statuses' must have the same index as doubles data 'speeds'",
    ),
    (
        "index type not allowed",
        lambda j: set_fields(j.data("bar values"), index_data_type=pb.UUID_SERIES_DATA_TYPE),
        "the index of 'bar values' is UUID_SERIES_DATA_TYPE, but must be "
        "INDEXED_STRING_SERIES_DATA_TYPE or STRING_SERIES_DATA_TYPE",
    ),
    (
        "bad project id",
        lambda j: batch_values(j).ClearField("project_id"),
        "project id is missing",
    ),
    (
        "bad colour",
        lambda j: batch_values(j).colors.append("red"),
        "colour 2 ('red') is not a hex colour like '#1f77b4'",
    ),
    (
        "colour with two newlines",
        lambda j: batch_values(j).colors.append("#aabbcc\n\n"),
        "is not a hex colour",
    ),
    (
        "batch lengths",
        lambda j: batch_values(j).categories.append("extra"),
        "the lists of data must have the same length (got 1 values, 1 times, 1 statuses, "
        "2 categories)",
    ),
    (
        "NaN scalar",
        lambda j: set_fields(
            j.metric("Max speed").metric_values.scalar_metric_values, value=math.nan
        ),
        "a scalar metric value cannot be NaN",
    ),
    (
        "scalar without value",
        lambda j: j.metric("Max speed").metric_values.scalar_metric_values.ClearField("value"),
        "a scalar metric needs a value",
    ),
    (
        "reference spelt differently",
        lambda j: set_fields(
            j.metric("Image").metric_values.image_metric_values.image_data_id.id,
            data=uid("picture").upper(),
        ),
        f"image data {uid('picture').upper()} is not in the output",
    ),
    (
        "category of the status data differs",
        lambda j: (
            j.data("grouped statuses")
            .series_per_category.category_to_series["car"]
            .statuses.series.append(pb.PASSED_METRIC_STATUS)
        ),
        "'grouped' and its status data 'grouped statuses' must have the same length "
        "in category 'car' (1 and 2)",
    ),
    (
        "state outside the set",
        lambda j: j.data("states").series.strings.series.__setitem__(0, "flying"),
        "states ['flying'] of 'states' are not in the states set",
    ),
    (
        "failure state outside the set",
        lambda j: states_values(j).failure_states.append("crashed"),
        "failure states ['crashed'] are not in the states set",
    ),
    (
        "image of a series",
        lambda j: set_fields(
            j.metric("Image").metric_values.image_metric_values.image_data_id.id,
            data=uid("values"),
        ),
        "image data 'values' must be EXTERNAL_FILE_DATA_TYPE, not DOUBLE_SERIES_DATA_TYPE",
    ),
    (
        "empty image list",
        lambda j: j.metric("Images").metric_values.image_list_metric_values.ClearField(
            "image_data_ids"
        ),
        "an image list metric needs at least one image",
    ),
    (
        "empty text",
        lambda j: set_fields(j.metric("Text").metric_values.text_metric_values, text=""),
        "a text metric needs non-empty text",
    ),
    (
        "plotly without JSON",
        lambda j: j.metric("Plot").metric_values.plotly_metric_values.ClearField("json"),
        "a plotly metric needs its JSON",
    ),
    (
        "no values",
        lambda j: j.metric("Text").ClearField("metric_values"),
        "the metric has no values",
    ),
    (
        "double-over-time lists differ",
        lambda j: j.metric(
            "Speed"
        ).metric_values.double_over_time_metric_values.failure_definition.add(),
        "the lists of data must have the same length (got 1 doubles, 1 statuses, "
        "2 failure definitions)",
    ),
    (
        "summary index needs indexed data",
        lambda j: set_fields(
            j.metric("Summary").metric_values.double_metric_values, string_index="car"
        ),
        "value data 'grouped' is DOUBLE_SERIES_DATA_TYPE, but must be "
        "INDEXED_DOUBLE_SERIES_DATA_TYPE",
    ),
]


@pytest.mark.parametrize(
    ("mutate", "expected"), [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED]
)
def test_rule(mutate: Mutation, expected: str) -> None:
    job = Job()
    mutate(job)
    assert not resim_accepts(job.msg), "the case must be one ReSim refuses"
    problems = [str(p) for p in find_problems(job.msg)]
    assert any(expected in p for p in problems), "\n".join(problems)
    with pytest.raises(InvalidMetricsError) as info:
        validate_job_metrics(job.msg)
    assert info.value.problems
    assert str(info.value).startswith(problems[0])
