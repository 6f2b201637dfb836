"""Expired presigned URLs: listed again, whether the first download was awaited by
`fetch_listed` or by its caller (`JobBlobs`, which awaits a job's one download in its own
frame) before `fetch_relisted` takes over."""

from __future__ import annotations

import uuid
from collections.abc import Awaitable, Callable, Sequence
from typing import cast

import pytest

from stook.sdk import MetricsWriter, data
from stook.sdk.aggregations import Needs
from stook.service.api import (
    ApiMetric,
    ApiMetricsData,
    PresignedUrlExpiredError,
    StorageClient,
)
from stook.service.api._models import MetricsDataStorageType
from stook.service.fetch._job_blobs import JobBlobs
from stook.service.fetch._presigned import fetch_listed

DATA_ID = uuid.UUID(int=7)
Relist = Callable[[], Awaitable[Sequence[ApiMetricsData]]]


class _Storage:
    """Serves `bodies` by URL; a URL in `expired` is refused as expired."""

    def __init__(self, bodies: dict[str, bytes], expired: set[str]) -> None:
        self.bodies, self.expired = bodies, expired
        self.asked: list[str] = []

    async def fetch_bytes(self, url: str) -> bytes:
        self.asked.append(url)
        if url in self.expired:
            raise PresignedUrlExpiredError(f"GET {url} answered HTTP 403", url=url, status=403)
        return self.bodies[url]


def _item(url: str | None, data_id: uuid.UUID = DATA_ID) -> ApiMetricsData:
    return ApiMetricsData(data_id, "speeds", MetricsDataStorageType.STANDARD, url)


def _relists(*listings: Sequence[ApiMetricsData]) -> tuple[list[int], Relist]:
    """A relist that answers `listings` one after another (the last one again after)."""
    calls: list[int] = []

    async def relist() -> Sequence[ApiMetricsData]:
        calls.append(1)
        return listings[min(len(calls), len(listings)) - 1]

    return calls, relist


def _payload() -> bytes:
    writer = MetricsWriter(uuid.UUID(int=1), deterministic=True)
    writer.add_data(data.doubles("speeds", [1.0, 2.5], id=DATA_ID))
    return writer.to_proto().metrics_data[0].SerializeToString()


async def _download(by: str, storage: _Storage, item: ApiMetricsData, relist: Relist) -> object:
    """The payload as `fetch_listed` gives it, or the series as `JobBlobs` reads it."""
    if by == "fetch_listed":
        payload, _ = await fetch_listed(
            cast(StorageClient, storage),
            item,
            url_of=lambda d: d.metrics_data_url,
            id_of=lambda d: d.data_id,
            relist=relist,
            source="job 1",
        )
        return payload

    async def no_metrics() -> Sequence[ApiMetric]:
        return ()

    blobs = JobBlobs(
        cast(StorageClient, storage),
        uuid.UUID(int=1),
        Needs(data=frozenset({"speeds"})),
        metrics=(),
        data=[item],
        relist_metrics=no_metrics,
        relist_data=relist,
    )
    return (await blobs.fetch()).series["speeds"].to_list()


@pytest.mark.parametrize("by", ["fetch_listed", "JobBlobs"])
@pytest.mark.parametrize("refusals", [0, 1, 2])
async def test_an_expired_url_is_listed_again_up_to_twice(by: str, refusals: int) -> None:
    urls = ["u0", "u1", "u2"]
    storage = _Storage(dict.fromkeys(urls, _payload()), set(urls[:refusals]))
    calls, relist = _relists(*([_item(url)] for url in urls[1:]))
    got = await _download(by, storage, _item("u0"), relist)
    assert got == (_payload() if by == "fetch_listed" else [1.0, 2.5])
    assert storage.asked == urls[: refusals + 1]
    assert len(calls) == refusals


@pytest.mark.parametrize("by", ["fetch_listed", "JobBlobs"])
async def test_a_url_still_refused_after_two_listings_raises(by: str) -> None:
    storage = _Storage({}, {"u0", "u1", "u2"})
    calls, relist = _relists([_item("u1")], [_item("u2")])
    with pytest.raises(PresignedUrlExpiredError, match="u2"):
        await _download(by, storage, _item("u0"), relist)
    assert storage.asked == ["u0", "u1", "u2"]
    assert len(calls) == 2


@pytest.mark.parametrize("by", ["fetch_listed", "JobBlobs"])
async def test_an_item_gone_from_the_new_listing_raises_the_first_refusal(by: str) -> None:
    storage = _Storage({}, {"u0"})
    _, relist = _relists([_item("u1", data_id=uuid.UUID(int=8))])
    with pytest.raises(PresignedUrlExpiredError, match="u0"):
        await _download(by, storage, _item("u0"), relist)
    assert storage.asked == ["u0"]


async def test_an_item_listed_again_without_a_url_has_no_bytes() -> None:
    storage = _Storage({}, {"u0"})
    _, relist = _relists([_item(None)])
    assert await _download("fetch_listed", storage, _item("u0"), relist) is None
