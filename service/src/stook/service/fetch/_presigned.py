"""Downloading a listed item's presigned URL, listing again when the URL has expired.

A metric or metrics-data listing hands out presigned URLs that expire; one listed early in
a long run can be refused by the time its download starts. Listing again gives a fresh URL
for the same item (found by its ID). Batch data downloads and null-scalar reads share this.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Hashable, Sequence
from typing import TypeVar

import structlog

from stook.service.api import PresignedUrlExpiredError, StorageClient

__all__ = ["fetch_listed"]

log = structlog.get_logger("stook.fetch")

_Item = TypeVar("_Item")

# Presigned URLs can expire between listing and download; listing again gives fresh ones.
_MAX_RELISTS = 2


async def fetch_listed(
    storage: StorageClient,
    item: _Item,
    *,
    url_of: Callable[[_Item], str | None],
    id_of: Callable[[_Item], Hashable],
    relist: Callable[[], Awaitable[Sequence[_Item]]],
    source: str,
) -> tuple[bytes | None, _Item]:
    """The bytes behind `item`'s URL, and the item as last listed; None when it has no URL.

    Raises PresignedUrlExpiredError when the URL is still refused after listing again
    twice, or when the item is gone from the new listing.
    """
    for relisted in range(_MAX_RELISTS + 1):
        url = url_of(item)
        if url is None:
            return None, item
        try:
            return await storage.fetch_bytes(url), item
        except PresignedUrlExpiredError:
            if relisted == _MAX_RELISTS:
                raise
            log.info("presigned URL expired; listing again", source=source)
            fresh = {id_of(i): i for i in await relist()}
            if id_of(item) not in fresh:
                raise
            item = fresh[id_of(item)]
    raise AssertionError("unreachable: the loop returns or raises")
