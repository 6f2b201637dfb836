"""A job's metrics-data listing read from its JSON items gives what reading them as
`ApiMetricsData`s gives, and leaves every listing with an item it does not take to the
model."""

from __future__ import annotations

from typing import Any

import pytest

from stook.service.api._client import ApiClient
from stook.service.api._errors import ApiResponseError
from stook.service.api._models import ApiMetricsData, MetricOwner
from stook.service.fetch._listed_data import ListedData, read_listed_data
from tests.service.api.test_listing_items import DATA, DATA_VARIANTS, IDS, same

WANTED = frozenset({"speeds", "accelerations"})

MALFORMED: list[dict[str, Any]] = [
    {"dataID": "1234"},
    {"dataID": ""},
    {"dataID": None},
    {"dataID": 3},
    {"dataID": [IDS[0]]},
    {"name": 3},
    {"name": ["speeds"]},
    {"metricsDataType": 3},
    {"metricsDataType": False},
    {"metricsDataURL": 3},
    {"filename": 3},
    {"jobID": "x"},
    {"jobID": 3},
    {"jobID": 0},
    {"creationTimestamp": "soon"},
    {"creationTimestamp": "2025-01-01T00:00:00"},
    {"creationTimestamp": 3},
    {"creationTimestamp": 0},
]


def agrees(items: list[dict[str, Any]], wanted: frozenset[str] = WANTED) -> bool:
    """Whether the listing took the fast path; if it did, it read what the model reads."""
    listed = read_listed_data(items, wanted)
    if listed is None:
        return False
    models = [ApiMetricsData.from_json(item, owner=MetricOwner.JOB) for item in items]
    assert listed.names == [d.name for d in models if d.name]
    assert listed.unnamed == sum(not d.name for d in models)
    # What JobBlobs downloads of a plan of data by name.
    expected = [d for d in models if d.name in wanted and d.is_standard]
    read = [ApiClient.read_job_metrics_data(item) for item in listed.wanted]
    assert len(read) == len(expected)
    for ours, theirs in zip(read, expected, strict=True):
        same(ours, theirs)
    return True


@pytest.mark.parametrize("change", DATA_VARIANTS)
def test_items_read_as_the_model_reads_them(change: dict[str, Any]) -> None:
    other = DATA | {"dataID": IDS[5], "name": "accelerations"}
    agrees([DATA | change, other])


@pytest.mark.parametrize(
    "change",
    [
        {},
        {"name": ""},
        {"name": None},
        {"metricsDataType": "VIDEO", "filename": "run.mp4"},
        {"metricsDataType": ""},
        {"metricsDataType": None},
        {"metricsDataType": "HOLOGRAM"},
        {"metricsDataURL": ""},
        {"metricsDataURL": None},
        {"filename": ""},
        {"creationTimestamp": None},
        {"creationTimestamp": ""},
        {"jobID": ""},
        {"jobID": None},
        {"batchID": 3, "orgID": []},  # fields the model does not read of a job's data
    ],
)
def test_the_spec_allowed_variants_take_the_fast_path(change: dict[str, Any]) -> None:
    assert agrees([DATA | change, DATA | {"dataID": IDS[5]}])


def test_fields_left_out_read_as_null() -> None:
    bare = {"dataID": IDS[1], "name": "speeds"}
    assert agrees([bare, {"dataID": IDS[2]}])
    listed = read_listed_data([bare, {"dataID": IDS[2]}], WANTED)
    assert listed == ListedData(["speeds"], 1, [bare])


def test_every_wanted_standard_item_is_kept_in_listing_order() -> None:
    items = [
        DATA | {"dataID": IDS[0], "name": "accelerations"},
        DATA | {"dataID": IDS[1], "name": "timestamps"},
        DATA | {"dataID": IDS[2]},
        DATA | {"dataID": IDS[3], "metricsDataType": "VIDEO"},
        DATA | {"dataID": IDS[4], "name": None},
        DATA | {"dataID": IDS[5]},  # a second "speeds": both are downloaded, as before
    ]
    assert agrees(items)
    listed = read_listed_data(items, WANTED)
    assert listed is not None
    assert listed.names == ["accelerations", "timestamps", "speeds", "speeds", "speeds"]
    assert listed.unnamed == 1
    assert listed.wanted == [items[0], items[2], items[5]]


def test_an_empty_listing_reads_as_nothing() -> None:
    assert read_listed_data([], WANTED) == ListedData([], 0, [])


@pytest.mark.parametrize("change", MALFORMED)
def test_a_malformed_item_goes_to_the_model_which_words_the_error(
    change: dict[str, Any],
) -> None:
    # Whether or not the plan wants the item: the model refuses the whole listing.
    for name in ("speeds", "unwanted"):
        item = DATA | {"name": name} | change
        assert read_listed_data([DATA, item], WANTED) is None
        with pytest.raises(ApiResponseError):
            ApiMetricsData.from_json(item, owner=MetricOwner.JOB)


@pytest.mark.parametrize(
    "change",
    [
        {"dataID": "{" + IDS[0] + "}"},
        {"dataID": IDS[0].replace("-", "")},
        {"jobID": IDS[3].upper()},
    ],
)
def test_ids_the_model_accepts_go_its_way_or_read_alike(change: dict[str, Any]) -> None:
    item = DATA | change
    ApiMetricsData.from_json(item, owner=MetricOwner.JOB)  # read, not refused
    agrees([item])


@pytest.mark.parametrize(
    "created",
    [
        "2025-01-18t14:03:00z",
        "2025-01-18T14:03:00.1234567890123Z",
        "2025-01-18T14:03:00.123456789-07:00",
    ],
)
def test_timestamps_are_taken_as_the_model_takes_them(created: str) -> None:
    assert agrees([DATA | {"creationTimestamp": created}])


def test_a_non_object_item_goes_to_the_model() -> None:
    assert read_listed_data([DATA, [DATA]], WANTED) is None


def test_a_repeated_timestamp_is_checked_once_and_a_bad_one_still_refused() -> None:
    good = DATA | {"creationTimestamp": "2025-02-01T00:00:00Z"}
    assert read_listed_data([good, good | {"dataID": IDS[5]}], WANTED) is not None
    bad = DATA | {"creationTimestamp": "2025-02-01T00:00:00"}
    assert read_listed_data([good, bad], WANTED) is None
    assert read_listed_data([bad], WANTED) is None


def test_a_job_id_checked_once_per_listing_and_another_still_checked() -> None:
    assert read_listed_data([DATA, DATA | {"dataID": IDS[5]}], WANTED) is not None
    assert read_listed_data([DATA, DATA | {"jobID": "not an ID"}], WANTED) is None
    other = DATA | {"dataID": IDS[5], "jobID": IDS[2]}
    assert read_listed_data([DATA, other, DATA], WANTED) is not None
    bads: list[dict[str, Any]] = [{"jobID": "not an ID"}, {"jobID": 3}, {"jobID": []}]
    for bad in bads:
        assert read_listed_data([DATA, other, DATA | bad], WANTED) is None
        assert read_listed_data([DATA | bad, other, DATA], WANTED) is None
