"""Telling a listing that will not end from a long one, from what its pages prove."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any, Final, NoReturn

from stook.service.api._errors import ApiResponseError

__all__ = ["ListingGuard"]


# The field that identifies an item of each listing, for telling repeats from new items.
_ITEM_ID_KEYS: Final = {
    "jobs": "jobID",
    "batches": "batchID",
    "metrics": "metricID",
    "batchMetrics": "metricID",
    "metricsData": "dataID",
    "batchMetricsData": "dataID",
}
# Empty pages that each hand out a new token: a server may skip ahead over a few, never
# over this many (156,000 a minute were seen from a server that never stopped).
_MAX_EMPTY_PAGES: Final = 50


class ListingGuard:
    """Stops a listing whose pages prove it will not end, instead of following it for ever.

    Only what the answers themselves prove counts: a page token seen before; a page of
    nothing but items listed already (the same jobs again and again); an empty page with a
    further token once the listing's own ``total`` has been delivered, or more items than
    that total by a whole page; and a long run of empty pages that each carry a new token.
    The first ``total`` a page carries bounds every later page, those without one too: a
    listing that drops it after a few pages cannot go on for ever with fresh items. Until
    a page carries one, ``expected`` (what the caller knows of the count: a batch's
    ``totalJobs``) bounds it the same way.
    """

    def __init__(
        self,
        listing: str | Callable[[], str],
        items_key: str,
        page_size: int,
        *,
        expected: int | None = None,
    ) -> None:
        # `listing` names the listing in the error; a function makes that name only then.
        self._listing = listing
        self._id_key = _ITEM_ID_KEYS.get(items_key)
        self._page_size = page_size
        self._tokens: set[str] = set()
        self._seen: set[str] = set()
        self._pages = 0
        self._empty_run = 0
        self._total: int | None = None  # the first total a page carried
        self._expected = expected

    def check(
        self, items: list[dict[str, Any]], token: str | None, total: object
    ) -> list[dict[str, Any]]:
        """The page's items to hand on: those not listed before, by their ID.

        Paging by offset while a listing changes can repeat an item on a later page; a
        caller wants each job (metric, batch) once, so a repeat is dropped here, for every
        listing, and a page that holds nothing else ends the listing as endless.
        """
        self._pages += 1
        if token is None and self._pages == 1:
            # A listing of one page, as most are (a job's): nothing to compare it with.
            return items
        fresh: list[dict[str, Any]] = []
        new = 0  # items not seen before, by ID or (without one) by content
        for item in items:
            identity = self._identity(item)
            if identity not in self._seen:
                self._seen.add(identity)
                new += 1
                fresh.append(item)
            elif not self._has_id(item):
                fresh.append(item)  # no ID to tell it by: not dropped as a repeat
        if token is None:
            return fresh  # the last page: nothing more will be asked for
        if token in self._tokens:
            self._stop("the API repeated a page token")
        self._tokens.add(token)
        if items and new == 0:
            self._stop(f"page {self._pages} holds only items listed on earlier pages")
        self._empty_run = 0 if items else self._empty_run + 1
        if self._total is None and isinstance(total, int) and not isinstance(total, bool):
            self._total = total
        total = self._total if self._total is not None else self._expected
        if total is not None:
            if not items and len(self._seen) >= total:
                self._stop(
                    f"page {self._pages} is empty and all {total} items of the listing's "
                    "total have been listed, yet it hands out another page token"
                )
            if len(self._seen) > total + self._page_size:
                self._stop(
                    f"{len(self._seen)} items listed, more than the listing's total of {total}"
                )
        if self._empty_run >= _MAX_EMPTY_PAGES:
            self._stop(f"{self._empty_run} empty pages in a row, each with a new page token")
        return fresh

    def _has_id(self, item: dict[str, Any]) -> bool:
        value = item.get(self._id_key) if self._id_key else None
        return isinstance(value, str) and bool(value)

    def _identity(self, item: dict[str, Any]) -> str:
        value = item.get(self._id_key) if self._id_key else None
        if isinstance(value, str) and value:
            return value
        # An item without its ID is told apart by its whole content.
        return json.dumps(item, sort_keys=True, default=str)

    def _stop(self, why: str) -> NoReturn:
        listing = self._listing if isinstance(self._listing, str) else self._listing()
        raise ApiResponseError(f"{listing}: the listing does not end ({why})")
