"""Reading a listing page by page, and ending one whose pages prove it will not end."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from typing import Any, Final, NoReturn

from stook.service.api._errors import ApiResponseError

__all__ = ["Listing"]

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


class Listing:
    """One listing's pages: `query` asks for the next one, `take` checks each one's items.

    ``on_total`` hears the listing's ``total`` from the first page that carries one. An item
    listed again (offset paging while the listing changes) is dropped. A listing whose pages
    prove it will not end is an ApiResponseError: a page token seen before; a page of items
    listed already; an empty page with a further token once the listing's total has been
    listed, or more items than that total by a whole page; a long run of empty pages. The
    first ``total`` a page carries bounds every later page; until then ``expected`` (what
    the caller knows: a batch's ``totalJobs``) does.
    """

    def __init__(
        self,
        name: Callable[[], str],
        items_key: str,
        page_size: int,
        params: Mapping[str, str | int] | None = None,
        *,
        on_total: Callable[[int], None] | None = None,
        expected: int | None = None,
    ) -> None:
        self._name = name  # the listing's name, made only for an error
        self._items_key = items_key
        self._id_key = _ITEM_ID_KEYS.get(items_key)
        self._page_size = page_size
        self._on_total = on_total
        self._bound = expected
        self._bound_is_total = False
        self.query: dict[str, str | int] = {**(params or {}), "pageSize": page_size}
        self.more = True  # until a page without a next page token
        self._pages = self._empty_run = 0
        self._tokens: set[str] = set()
        self._seen: set[object] = set()  # items' IDs, or (without one) their contents

    def take(self, page: dict[str, Any]) -> list[dict[str, Any]]:
        """The page's items to hand on; `query` then asks for the next page, if any."""
        items = page.get(self._items_key)
        if items is None:
            items = []  # the API omits empty lists
        if not isinstance(items, list):
            self._fail(f"'{self._items_key}' should be a list, got {type(items).__name__}")
        for item in items:
            if not isinstance(item, dict):
                kind = type(item).__name__
                self._fail(f"an item of '{self._items_key}' is {kind}, not an object")
        token = page.get("nextPageToken") or None
        if token is not None and not isinstance(token, str):
            self._fail("'nextPageToken' should be a string")
        total = page.get("total")
        if not isinstance(total, int) or isinstance(total, bool):
            total = None
        self._pages += 1
        if token is not None or self._pages > 1:  # a listing of one page has nothing to check
            items = self._check(items, token, total)
        if total is not None and self._on_total is not None:
            self._on_total(total)
            self._on_total = None  # once: later pages repeat it
        if token is None:
            self.more = False
        else:
            self.query["pageToken"] = token
        return items

    def _check(
        self, items: list[dict[str, Any]], token: str | None, total: int | None
    ) -> list[dict[str, Any]]:
        """The items not listed before, once the page is known not to prove the listing
        endless (its repeats must not reach the caller)."""
        fresh, new = [], 0
        for item in items:
            item_id = item.get(self._id_key) if self._id_key else None
            has_id = isinstance(item_id, str) and item_id != ""
            if not has_id:  # told apart by its content, and never dropped as a repeat
                item_id = json.dumps(item, sort_keys=True, default=str)
            if item_id not in self._seen:
                self._seen.add(item_id)
                new += 1
                fresh.append(item)
            elif not has_id:
                fresh.append(item)
        if token is None:
            return fresh  # the last page: nothing more will be asked for
        if token in self._tokens:
            self._stop("the API repeated a page token")
        self._tokens.add(token)
        if items and new == 0:
            self._stop(f"page {self._pages} holds only items listed on earlier pages")
        self._empty_run = 0 if items else self._empty_run + 1
        if total is not None and not self._bound_is_total:
            self._bound, self._bound_is_total = total, True
        if (bound := self._bound) is not None:
            if not items and len(self._seen) >= bound:
                self._stop(
                    f"page {self._pages} is empty and all {bound} items of the listing's "
                    "total have been listed, yet it hands out another page token"
                )
            if len(self._seen) > bound + self._page_size:
                self._stop(
                    f"{len(self._seen)} items listed, more than the listing's total of {bound}"
                )
        if self._empty_run >= _MAX_EMPTY_PAGES:
            self._stop(f"{self._empty_run} empty pages in a row, each with a new page token")
        return fresh

    def _stop(self, why: str) -> NoReturn:
        self._fail(f"the listing does not end ({why})")

    def _fail(self, problem: str) -> NoReturn:
        raise ApiResponseError(f"{self._name()}: {problem}")
