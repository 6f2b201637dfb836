"""The listing items' fast path gives what from_json gives, and leaves every error to it."""

from __future__ import annotations

import dataclasses
import functools
import json
import pickle
import uuid
from collections.abc import Callable
from typing import Any

import orjson
import pytest
from resim.sdk.client.models import JobMetric as ResimJobMetric
from resim.sdk.client.models import JobMetricsData as ResimJobMetricsData
from resim.sdk.client.models.metric_status import MetricStatus as ResimMetricStatus
from resim.sdk.client.models.metric_type import MetricType as ResimMetricType
from resim.sdk.client.models.metrics_data_type import MetricsDataType as ResimMetricsDataType

from stook.service.api._errors import ApiResponseError
from stook.service.api._listing_items import (
    _job,
    _metric,
    _metrics_data,
    metric_parser,
    metrics_data_parser,
    read_job,
)
from stook.service.api._models import ApiMetric, ApiMetricsData, Job, MetricOwner

IDS = [str(uuid.UUID(int=i + 1)) for i in range(6)]
METRIC: dict[str, Any] = {
    "metricID": IDS[0],
    "name": "Localization error",
    "type": "SCALAR",
    "status": "PASSED",
    "value": 0.25,
    "unit": "m",
    "dataIDs": [IDS[1], IDS[2]],
    "eventMetric": False,
    "metricURL": "http://storage.test/m?X-Amz-Signature=abc",
    "creationTimestamp": "2025-01-18T14:03:00.123456789+02:00",
    "jobID": IDS[3],
    "batchID": IDS[4],
    "projectID": IDS[5],
    "orgID": "org",
}
DATA: dict[str, Any] = {
    "dataID": IDS[1],
    "name": "speeds",
    "metricsDataType": "STANDARD",
    "filename": None,
    "metricsDataURL": "http://storage.test/d?X-Amz-Signature=abc",
    "creationTimestamp": "2025-01-18T14:03:00Z",
    "jobID": IDS[3],
    "batchID": IDS[4],
}

# Each a change to a well-formed item: the fast path takes some, gives the rest to from_json.
METRIC_VARIANTS: list[dict[str, Any]] = [
    {},
    {"name": ""},
    {"name": None},
    {"type": "COMPOSITE", "value": None},
    {"type": "NEW_KIND"},
    {"type": ""},
    {"status": ""},
    {"status": None},
    {"status": "SOMETHING_NEW"},
    {"value": 3},
    {"value": ""},
    {"unit": ""},
    {"metricURL": None},
    {"dataIDs": []},
    {"dataIDs": None},
    {"dataIDs": ""},
    {"eventMetric": None},
    {"eventMetric": True},
    {"creationTimestamp": ""},
    {"creationTimestamp": "2025-01-18t14:03:00z"},
    {"jobID": ""},
    {"batchID": None},
]
DATA_VARIANTS: list[dict[str, Any]] = [
    {},
    {"name": ""},
    {"metricsDataType": "VIDEO", "filename": "run.mp4"},
    {"metricsDataType": ""},
    {"metricsDataType": None},
    {"metricsDataType": "HOLOGRAM"},
    {"metricsDataURL": ""},
    {"creationTimestamp": None},
    {"jobID": ""},
    {"batchID": ""},
]


def changed(item: dict[str, Any], change: dict[str, Any]) -> dict[str, Any]:
    return item | change


def same(a: object, b: object) -> None:
    assert a == b
    assert repr(a) == repr(b)
    # Fields kept out of eq or repr (URLs) too, and the exact types (an enum, not its text).
    assert dataclasses.is_dataclass(a)
    for f in dataclasses.fields(a):
        ours, theirs = getattr(a, f.name), getattr(b, f.name)
        assert ours == theirs
        assert type(ours) is type(theirs), f.name


@pytest.mark.parametrize("owner", list(MetricOwner))
@pytest.mark.parametrize("change", METRIC_VARIANTS)
def test_metric_items_read_as_from_json_reads_them(
    owner: MetricOwner, change: dict[str, Any]
) -> None:
    data = changed(METRIC, change)
    same(metric_parser(owner)(data), ApiMetric.from_json(data, owner=owner))


@pytest.mark.parametrize("owner", list(MetricOwner))
@pytest.mark.parametrize("change", DATA_VARIANTS)
def test_data_items_read_as_from_json_reads_them(
    owner: MetricOwner, change: dict[str, Any]
) -> None:
    data = changed(DATA, change)
    same(metrics_data_parser(owner)(data), ApiMetricsData.from_json(data, owner=owner))


def test_well_formed_items_take_the_fast_path() -> None:
    # Not the general path in disguise: a well-formed item is built here.
    assert _metric(METRIC, MetricOwner.JOB) is not None
    assert _metrics_data(DATA, MetricOwner.JOB) is not None
    assert _metric(METRIC | {"value": 3}, MetricOwner.JOB) is None  # converted by from_json


def test_items_as_resim_writes_them() -> None:
    metric = ResimJobMetric(
        metric_id=uuid.UUID(IDS[0]),
        name="m",
        type_=ResimMetricType.SCALAR,
        status=ResimMetricStatus.FAIL_WARN,
        value=1.5,
        data_i_ds=[uuid.UUID(IDS[1])],
        job_id=uuid.UUID(IDS[3]),
    )
    data = ResimJobMetricsData(
        data_id=uuid.UUID(IDS[1]),
        name="d",
        metrics_data_type=ResimMetricsDataType.EXTERNAL_FILE,
        filename="a.png",
    )
    for owner in MetricOwner:
        wire_metric = json.loads(json.dumps(metric.to_dict(), default=str))
        wire_data = json.loads(json.dumps(data.to_dict(), default=str))
        assert _metric(wire_metric, owner) is not None
        same(metric_parser(owner)(wire_metric), ApiMetric.from_json(wire_metric, owner=owner))
        same(
            metrics_data_parser(owner)(wire_data),
            ApiMetricsData.from_json(wire_data, owner=owner),
        )


@pytest.mark.parametrize(
    "change",
    [
        {"metricID": "1234"},
        {"metricID": ""},
        {"metricID": None},
        {"value": True},
        {"value": "1.5"},
        {"dataIDs": ["nope"]},
        {"dataIDs": [3]},
        {"dataIDs": "nope"},
        {"eventMetric": "yes"},
        {"status": 3},
        {"type": 3},
        {"name": 3},
        {"jobID": "x"},
        {"creationTimestamp": "yesterday"},
        {"creationTimestamp": "2025-01-01T00:00:00"},
        {"creationTimestamp": 3},
    ],
)
def test_malformed_metric_items_fail_as_from_json_says(change: dict[str, Any]) -> None:
    data = changed(METRIC, change)
    assert _metric(data, MetricOwner.JOB) is None
    with pytest.raises(ApiResponseError) as expected:
        ApiMetric.from_json(data, owner=MetricOwner.JOB)
    with pytest.raises(ApiResponseError) as caught:
        metric_parser(MetricOwner.JOB)(data)
    assert str(caught.value) == str(expected.value)


@pytest.mark.parametrize(
    "change",
    [
        {"dataID": "1234"},
        {"dataID": None},
        {"metricsDataType": 3},
        {"filename": 3},
        {"jobID": 3},
        {"creationTimestamp": "soon"},
    ],
)
def test_malformed_data_items_fail_as_from_json_says(change: dict[str, Any]) -> None:
    data = changed(DATA, change)
    assert _metrics_data(data, MetricOwner.JOB) is None
    with pytest.raises(ApiResponseError) as expected:
        ApiMetricsData.from_json(data, owner=MetricOwner.JOB)
    with pytest.raises(ApiResponseError) as caught:
        metrics_data_parser(MetricOwner.JOB)(data)
    assert str(caught.value) == str(expected.value)


def test_an_item_that_is_not_an_object_is_refused() -> None:
    with pytest.raises(ApiResponseError, match="expected a JSON object"):
        metric_parser(MetricOwner.JOB)(["not", "an", "object"])  # type: ignore[arg-type]


def test_a_repeated_timestamp_is_read_once_and_still_right() -> None:
    # A listing's items mostly share their creation time: the last one read is reused,
    # never a stale one for a different text, nor one that hides a malformed text.
    times = [
        "2025-01-18T14:03:00Z",
        "2025-01-18T14:03:00Z",
        "2025-01-18T14:03:01+02:00",
        "2025-01-18T14:03:00Z",
        "2025-01-18T14:03:00",  # no zone: worded by from_json
        "2025-01-18T14:03:00Z",
    ]
    parse = metrics_data_parser(MetricOwner.JOB)
    read = []
    for moment in times:
        data = DATA | {"creationTimestamp": moment}
        if moment == "2025-01-18T14:03:00":
            with pytest.raises(ApiResponseError) as fast:
                parse(data)
            with pytest.raises(ApiResponseError) as general:
                ApiMetricsData.from_json(data, owner=MetricOwner.JOB)
            assert str(fast.value) == str(general.value)
            continue
        item = parse(data)
        same(item, ApiMetricsData.from_json(data, owner=MetricOwner.JOB))
        read.append(item.creation_timestamp)
    assert read[0] is read[1]  # the repeat was not parsed again


def test_a_data_id_listed_by_a_metric_is_one_object() -> None:
    # A metric's dataIDs and the data items they name share the ID cache.
    metric = metric_parser(MetricOwner.JOB)(METRIC)
    data = metrics_data_parser(MetricOwner.JOB)(DATA)
    assert data.data_id == metric.data_ids[0]
    assert data.data_id is metric.data_ids[0]


def test_fast_items_are_the_frozen_dataclasses_themselves() -> None:
    # Built as a writable twin, then made the model's class: nothing of the twin remains.
    for parse, data, model in (
        (metric_parser(MetricOwner.JOB), METRIC, ApiMetric),
        (metrics_data_parser(MetricOwner.JOB), DATA, ApiMetricsData),
    ):
        item = parse(data)
        assert type(item) is model
        assert hash(item) == hash(model.from_json(data, owner=MetricOwner.JOB))
        copy = pickle.loads(pickle.dumps(item))
        assert type(copy) is model
        same(copy, item)
        with pytest.raises(dataclasses.FrozenInstanceError):
            item.name = "renamed"  # type: ignore[misc]


JOB: dict[str, Any] = {
    "jobID": IDS[3],
    "projectID": IDS[5],
    "batchID": IDS[4],
    "buildID": IDS[2],
    "experienceID": IDS[1],
    "experienceName": "Highway merge 01",
    "conflatedStatus": "PASSED",
    "jobStatus": "SUCCEEDED",
    "jobMetricsStatus": "FAIL_WARN",
    "statusHistory": [{"status": "SUBMITTED", "updatedAt": "2025-01-18T14:00:00Z"}],
    "creationTimestamp": "2025-01-18T14:00:00Z",
    "parameters": {"max_speed": "10", "planner_mode": "cautious"},
    "orgID": "org",
}
JOB_VARIANTS: list[dict[str, Any]] = [
    {},
    {"conflatedStatus": "NEW_STATUS"},
    {"conflatedStatus": ""},
    {"conflatedStatus": None},
    {"jobStatus": "SOMETHING"},
    {"jobMetricsStatus": None},
    {"batchID": ""},
    {"projectID": None},
    {"experienceID": ""},
    {"experienceName": ""},
    {"experienceName": None},
    {"buildID": None},
    {"creationTimestamp": ""},
    {"creationTimestamp": "2025-01-18t14:00:00z"},
    {"parameters": {}},
    {"parameters": None},
    {"parameters": ""},
]


@pytest.mark.parametrize("change", JOB_VARIANTS)
def test_job_items_read_as_from_json_reads_them(change: dict[str, Any]) -> None:
    data = changed(JOB, change)
    ours = read_job(data)
    same(ours, Job.from_json(data))
    assert type(ours.parameters) is dict
    assert ours.parameters is not data.get("parameters")  # a copy: the page is not kept


def test_a_well_formed_job_takes_the_fast_path() -> None:
    assert _job(JOB) is not None
    item = read_job(JOB)
    assert type(item) is Job
    assert hash(item) == hash(Job.from_json(JOB))
    same(pickle.loads(pickle.dumps(item)), item)
    with pytest.raises(dataclasses.FrozenInstanceError):
        item.experience_name = "renamed"  # type: ignore[misc]


@pytest.mark.parametrize(
    "change",
    [
        {"jobID": "1234"},
        {"jobID": ""},
        {"jobID": None},
        {"conflatedStatus": 3},
        {"jobStatus": True},
        {"batchID": "x"},
        {"experienceID": 3},
        {"experienceName": 3},
        {"creationTimestamp": "yesterday"},
        {"creationTimestamp": "2025-01-01T00:00:00"},
        {"parameters": ["a"]},
        {"parameters": {"max_speed": 10}},
        {"parameters": "x"},
    ],
)
def test_malformed_job_items_fail_as_from_json_says(change: dict[str, Any]) -> None:
    data = changed(JOB, change)
    assert _job(data) is None
    with pytest.raises(ApiResponseError) as expected:
        Job.from_json(data)
    with pytest.raises(ApiResponseError) as caught:
        read_job(data)
    assert str(caught.value) == str(expected.value)


@pytest.mark.parametrize(
    ("parse", "model", "item"),
    [
        (read_job, Job.from_json, JOB),
        (
            metrics_data_parser(MetricOwner.JOB),
            functools.partial(ApiMetricsData.from_json, owner=MetricOwner.JOB),
            DATA,
        ),
        (
            metrics_data_parser(MetricOwner.BATCH),
            functools.partial(ApiMetricsData.from_json, owner=MetricOwner.BATCH),
            DATA | {"batchID": IDS[4]},
        ),
    ],
)
def test_items_with_fields_left_out_or_parsed_by_orjson_read_as_from_json(
    parse: Callable[[dict[str, Any]], object],
    model: Callable[[dict[str, Any]], object],
    item: dict[str, Any],
) -> None:
    # The fields are read in one call, by the JSON parser's own keys: an item that leaves
    # one out is read field by field, and a parsed one as a written one.
    for key in item:
        fewer = {k: v for k, v in item.items() if k != key}
        try:
            expected = model(fewer)
        except ApiResponseError:
            with pytest.raises(ApiResponseError):
                parse(fewer)
        else:
            same(parse(fewer), expected)
    parsed = orjson.loads(orjson.dumps(item))
    same(parse(parsed), model(parsed))
