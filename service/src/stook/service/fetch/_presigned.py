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

__all__ = ["fetch_listed", "fetch_relisted"]

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
    url = url_of(item)
    if url is None:
        return None, item
    try:
        return await storage.fetch_bytes(url), item
    except PresignedUrlExpiredError as expired:
        return await fetch_relisted(
            storage, item, expired, url_of=url_of, id_of=id_of, relist=relist, source=source
        )


async def fetch_relisted(
    storage: StorageClient,
    item: _Item,
    expired: PresignedUrlExpiredError,
    *,
    url_of: Callable[[_Item], str | None],
    id_of: Callable[[_Item], Hashable],
    relist: Callable[[], Awaitable[Sequence[_Item]]],
    source: str,
) -> tuple[bytes | None, _Item]:
    """`fetch_listed` once `item`'s URL was refused as `expired`: list again for a fresh
    URL and fetch that, twice at most. A caller that awaits the first download in its own
    frame (one coroutine fewer for every resumption of it) comes here on expiry."""
    for relisted in range(1, _MAX_RELISTS + 1):
        log.info("presigned URL expired; listing again", source=source)
        fresh = {id_of(i): i for i in await relist()}
        if id_of(item) not in fresh:
            raise expired
        item = fresh[id_of(item)]
        url = url_of(item)
        if url is None:
            return None, item
        try:
            return await storage.fetch_bytes(url), item
        except PresignedUrlExpiredError as again:
            if relisted == _MAX_RELISTS:
                raise
            expired = again
    raise AssertionError("unreachable: the loop returns or raises")
