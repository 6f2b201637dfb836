"""Report mode's per-job step: a job's metric listing read from its items when well-formed,
through the model otherwise (its errors, and null scalars' messages, as before)."""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator
from typing import Any

import pytest

from stook.sdk.aggregations import Needs
from stook.service.api._errors import ApiResponseError
from stook.service.api._models import ApiMetric, Batch, Job, MetricOwner
from stook.service.fetch._listed_scalars import ListedScalars
from stook.service.fetch._report_fetch import ReportFetcher
from tests.service.api.test_listing_items import IDS, METRIC


class _Listings:
    """An API that lists one job's metrics, as given, and has no storage to read from."""

    storage = None

    def __init__(self, items: list[Any]) -> None:
        self.items = items
        self.relisted = 0

    async def all_job_metric_items(self, *ids: uuid.UUID) -> list[Any]:
        return list(self.items)

    async def list_job_metrics(self, *ids: uuid.UUID) -> AsyncIterator[ApiMetric]:
        self.relisted += 1
        for item in self.items:
            yield ApiMetric.from_json(item, owner=MetricOwner.JOB)


async def _read(items: list[Any]) -> ListedScalars:
    api: Any = _Listings(items)
    fetcher = ReportFetcher(api, uuid.uuid4(), uuid.uuid4(), Needs())
    batch, job = Batch(batch_id=uuid.UUID(IDS[4])), Job(uuid.UUID(IDS[3]), None)
    return await fetcher._job_scalars(batch, job)


async def test_a_well_formed_listing_is_read_from_its_items() -> None:
    listed = await _read([METRIC, METRIC | {"metricID": IDS[5], "name": "B", "value": 2.0}])
    assert listed == ListedScalars(
        {"Localization error": (0.25, "m"), "B": (2.0, "m")},
        ["Localization error", "B"],
        ["PASSED", "PASSED"],
        {"Localization error": "PASSED", "B": "PASSED"},
        ["Localization error", "B"],
    )


@pytest.mark.parametrize("change", [{"metricID": "1234"}, {"creationTimestamp": "yesterday"}])
async def test_a_malformed_item_fails_as_the_model_words_it(change: dict[str, Any]) -> None:
    item = METRIC | change
    with pytest.raises(ApiResponseError) as expected:
        ApiMetric.from_json(item, owner=MetricOwner.JOB)
    with pytest.raises(ApiResponseError) as caught:
        await _read([METRIC, item])
    assert str(caught.value) == str(expected.value)


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
