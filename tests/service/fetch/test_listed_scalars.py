"""A job's metric listing read from its JSON items gives what reading them as `ApiMetric`s
gives, and leaves every item it does not take (malformed, or a null scalar) to the model."""

from __future__ import annotations

from collections import Counter
from typing import Any

import pytest

from stook.service.api._errors import ApiResponseError
from stook.service.api._models import ApiMetric, MetricOwner
from stook.service.fetch._listed_scalars import ListedScalars, read_listed_scalars
from stook.service.fetch._scalars import is_scalar
from tests.service.api.test_listing_items import IDS, METRIC, METRIC_VARIANTS

MALFORMED: list[dict[str, Any]] = [
    {"metricID": "1234"},
    {"metricID": ""},
    {"metricID": None},
    {"metricID": 3},
    {"value": True},
    {"value": "1.5"},
    {"value": [1.5]},
    {"dataIDs": ["nope"]},
    {"dataIDs": [3]},
    # Not strings: checked by are_ids with the other IDs.
    {"dataIDs": [None]},
    {"dataIDs": [IDS[1], [IDS[2]]]},
    {"metricID": [IDS[0]]},
    {"dataIDs": "nope"},
    {"dataIDs": {}},
    {"dataIDs": 0},
    {"eventMetric": "yes"},
    {"eventMetric": 0},
    {"status": 3},
    {"status": False},
    {"type": 3},
    {"type": ["SCALAR"]},
    {"name": 3},
    {"unit": 3},
    {"metricURL": 3},
    {"jobID": "x"},
    {"jobID": 3},
    {"jobID": 0},
    {"jobID": []},
    {"batchID": {"a": 1}},
    {"batchID": "x"},
    {"creationTimestamp": "yesterday"},
    {"creationTimestamp": "2025-01-01T00:00:00"},
    {"creationTimestamp": 3},
    {"creationTimestamp": 0},
    {"creationTimestamp": []},
]


def as_models(items: list[dict[str, Any]]) -> ListedScalars:
    """What the listing gives read as `ApiMetric`s (every scalar listed with its value)."""
    metrics = [ApiMetric.from_json(item, owner=MetricOwner.JOB) for item in items]
    scalars = [m for m in metrics if is_scalar(m)]
    assert all(m.value is not None for m in scalars)
    return ListedScalars(
        {m.name: (m.value, m.unit or "") for m in scalars if m.value is not None},
        [m.name for m in scalars],
        [str(m.status) for m in metrics],
        {m.name: str(m.status) for m in scalars},
        [m.name for m in metrics if m.name],
    )


def agrees(items: list[dict[str, Any]]) -> bool:
    """Whether the listing took the fast path; if it did, it read what the model reads."""
    listed = read_listed_scalars(items)
    if listed is None:
        return False
    expected = as_models(items)
    assert listed.values == expected.values
    assert [type(v) for pair in listed.values.values() for v in pair] == [
        type(v) for pair in expected.values.values() for v in pair
    ]
    assert Counter(listed.names) == Counter(expected.names)
    assert listed.statuses == expected.statuses
    # What batch mode reads besides (see _batch_fetch): each scalar's status, and every
    # named metric's name.
    assert listed.scalar_statuses == expected.scalar_statuses
    assert all(type(status) is str for status in listed.scalar_statuses.values())
    assert listed.metric_names == expected.metric_names
    return True


@pytest.mark.parametrize("change", METRIC_VARIANTS)
def test_items_read_as_the_model_reads_them(change: dict[str, Any]) -> None:
    item = METRIC | change
    other = METRIC | {"metricID": IDS[5], "name": "Other", "status": "FAIL_WARN"}
    # Whether an item goes the fast way or not, it never reads differently.
    agrees([item, other])


@pytest.mark.parametrize(
    "change",
    [
        {},
        {"name": ""},
        {"name": None},
        {"type": "COMPOSITE", "value": None},
        {"type": "NEW_KIND"},
        {"type": None},
        {"status": ""},
        {"status": None},
        {"status": "SOMETHING_NEW"},
        {"unit": ""},
        {"unit": None},
        {"metricURL": None},
        {"dataIDs": []},
        {"dataIDs": None},
        {"eventMetric": None},
        {"eventMetric": True, "value": None},
        {"creationTimestamp": ""},
        {"creationTimestamp": None},
        {"jobID": ""},
        {"batchID": None},
        {"jobID": IDS[3].upper(), "batchID": IDS[4]},
        {"projectID": None, "orgID": 3},  # fields the model does not read
    ],
)
def test_the_spec_allowed_variants_take_the_fast_path(change: dict[str, Any]) -> None:
    assert agrees([METRIC | change, METRIC | {"metricID": IDS[5]}])


def test_the_last_scalar_of_a_name_wins_and_every_name_counts() -> None:
    items = [
        METRIC | {"value": 1.0},
        METRIC | {"type": "COMPOSITE", "value": None, "name": "Plot"},
        METRIC | {"value": 2.0, "unit": "km", "status": "FAIL_BLOCK"},
        METRIC | {"name": "Other", "value": 3.0, "unit": None},
        METRIC | {"name": "Event one", "eventMetric": True},
    ]
    assert agrees(items)
    listed = read_listed_scalars(items)
    assert listed is not None
    assert listed.values == {"Localization error": (2.0, "km"), "Other": (3.0, "")}
    assert listed.names == ["Localization error", "Localization error", "Other"]
    assert listed.statuses == ["PASSED", "PASSED", "FAIL_BLOCK", "PASSED", "PASSED"]
    assert listed.scalar_statuses == {"Localization error": "FAIL_BLOCK", "Other": "PASSED"}
    assert listed.metric_names == [
        "Localization error",
        "Plot",
        "Localization error",
        "Other",
        "Event one",
    ]


def test_fields_left_out_read_as_null() -> None:
    bare = {"metricID": IDS[0], "name": "Speed", "type": "SCALAR", "value": 2.0}
    assert agrees([bare, {"metricID": IDS[5]}])
    listed = read_listed_scalars([bare, {"metricID": IDS[5]}])
    assert listed is not None
    assert listed.values == {"Speed": (2.0, "")}
    assert listed.statuses == ["NO_STATUS_REPORTED"] * 2


def test_an_empty_listing_reads_as_nothing() -> None:
    assert read_listed_scalars([]) == ListedScalars({}, [], [])


@pytest.mark.parametrize("change", [{"value": None}, {"value": 3}])
def test_a_scalar_the_model_must_read_goes_its_way(change: dict[str, Any]) -> None:
    # A null value is in the metric's message; an integer, the model converts.
    assert read_listed_scalars([METRIC, METRIC | change]) is None


@pytest.mark.parametrize("change", MALFORMED)
def test_a_malformed_item_goes_to_the_model_which_words_the_error(
    change: dict[str, Any],
) -> None:
    item = METRIC | change
    assert read_listed_scalars([METRIC, item]) is None
    with pytest.raises(ApiResponseError):
        ApiMetric.from_json(item, owner=MetricOwner.JOB)


@pytest.mark.parametrize(
    "change",
    [
        {"metricID": "{" + IDS[0] + "}"},
        {"metricID": IDS[0].replace("-", "")},
        {"dataIDs": ["urn:uuid:" + IDS[1]]},
        # Owner IDs are checked with the listing's other IDs (see is_owner_id).
        {"jobID": "{" + IDS[0] + "}"},
        {"batchID": IDS[0].replace("-", "")},
    ],
)
def test_ids_the_model_accepts_besides_go_its_way(change: dict[str, Any]) -> None:
    item = METRIC | change
    assert read_listed_scalars([item]) is None
    ApiMetric.from_json(item, owner=MetricOwner.JOB)  # read, not refused


@pytest.mark.parametrize(
    "created",
    [
        "2025-01-18t14:03:00z",
        "2025-01-18T14:03:00.1234567890123Z",
        "2025-01-18T14:03:00.123456789-07:00",
    ],
)
def test_timestamps_are_taken_as_the_model_takes_them(created: str) -> None:
    assert agrees([METRIC | {"creationTimestamp": created}])


def test_a_non_object_item_goes_to_the_model() -> None:
    assert read_listed_scalars([METRIC, [METRIC]]) is None


def test_a_repeated_timestamp_is_checked_once_and_a_bad_one_still_refused() -> None:
    good = METRIC | {"creationTimestamp": "2025-02-01T00:00:00Z"}
    assert read_listed_scalars([good, good]) is not None
    bad = METRIC | {"creationTimestamp": "2025-02-01T00:00:00"}
    assert read_listed_scalars([good, bad]) is None
    assert read_listed_scalars([bad]) is None


def test_a_job_id_checked_once_per_listing_and_another_still_checked() -> None:
    assert read_listed_scalars([METRIC, METRIC | {"metricID": IDS[5]}]) is not None
    assert read_listed_scalars([METRIC, METRIC | {"jobID": "not an ID"}]) is None
    other = METRIC | {"metricID": IDS[5], "jobID": IDS[2], "batchID": IDS[1]}
    assert read_listed_scalars([METRIC, other, METRIC]) is not None
    bads: list[dict[str, Any]] = [
        {"jobID": "not an ID"},
        {"batchID": "x"},
        {"batchID": 3},
        {"jobID": []},
    ]
    for bad in bads:
        assert read_listed_scalars([METRIC, other, METRIC | bad]) is None
        assert read_listed_scalars([METRIC | bad, other, METRIC]) is None


@pytest.mark.parametrize(
    "ids",
    [
        [IDS[0] + "\n" + IDS[1], ""],
        [IDS[0] + "\n" + IDS[1]],
        [IDS[0][:-1], IDS[1] + "0"],
        ["", IDS[0]],
    ],
)
def test_ids_checked_together_are_each_checked(ids: list[str]) -> None:
    items = [METRIC | {"metricID": ids[0], "dataIDs": ids[1:]}]
    assert read_listed_scalars(items) is None
