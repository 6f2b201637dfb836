"""Report mode's per-job step: a job's metric listing read through its model (its errors,
and null scalars' messages)."""

from __future__ import annotations

import json
import uuid
from typing import Any

import msgspec
import pytest

from stook.sdk.aggregations import Needs
from stook.service.api._models import ApiMetric, Batch, Job, JobMetricsPage, decoder
from stook.service.fetch._report_fetch import JobScalars, ReportFetcher

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


class _Listings:
    """An API that lists one job's metrics, as given, and has no storage to read from."""

    storage = None

    def __init__(self, items: list[Any]) -> None:
        self.items = items

    async def list_job_metrics(self, *ids: uuid.UUID) -> list[ApiMetric]:
        page = decoder(JobMetricsPage).decode(json.dumps({"metrics": self.items}))
        return page.items or []


async def _read(items: list[Any]) -> JobScalars:
    api: Any = _Listings(items)
    fetcher = ReportFetcher(api, uuid.uuid4(), uuid.uuid4(), Needs())
    batch, job = Batch(batch_id=uuid.UUID(IDS[4])), Job(uuid.UUID(IDS[3]), None)
    return await fetcher._job_scalars(batch, job)


async def test_a_well_formed_listing_gives_its_scalars() -> None:
    listed = await _read([METRIC, METRIC | {"metricID": IDS[5], "name": "B", "value": 2.0}])
    assert listed.values == {"Localization error": (0.25, "m"), "B": (2.0, "m")}
    assert sorted(listed.names) == ["B", "Localization error"]
    assert listed.statuses == ["PASSED", "PASSED"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"metricID": "1234"}, "Invalid UUID - at `$.metrics[1].metricID`"),
        ({"value": "many"}, "Expected `float | null`, got `str` - at `$.metrics[1].value`"),
    ],
)
async def test_a_malformed_item_fails_naming_the_metric_and_field(
    change: dict[str, Any], message: str
) -> None:
    with pytest.raises(msgspec.ValidationError) as caught:
        await _read([METRIC, METRIC | change])
    assert str(caught.value) == message


async def test_a_null_scalar_nobody_reads_is_named_but_not_downloaded() -> None:
    # No aggregation reads it: its message is not read (there is no storage to read it).
    items = [METRIC, METRIC | {"metricID": IDS[5], "name": "Null", "value": None}]
    listed = await _read(items)
    assert listed.values == {"Localization error": (0.25, "m")}
    assert sorted(listed.names) == ["Localization error", "Null"]
    assert listed.statuses == ["PASSED", "PASSED"]


async def test_an_integer_value_is_converted_by_the_model() -> None:
    listed = await _read([METRIC | {"value": 3}])
    assert listed.values == {"Localization error": (3.0, "m")}
    assert type(listed.values["Localization error"][0]) is float
