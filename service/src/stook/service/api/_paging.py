"""Reading a listing page by page, and ending one whose pages prove it will not end."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Final, Generic, NoReturn, TypeVar

from stook.service.api._errors import ApiResponseError
from stook.service.api._models import Page

__all__ = ["Listing"]

_T = TypeVar("_T")

# Empty pages that each hand out a new token: a server may skip ahead over a few, never
# over this many (156,000 a minute were seen from a server that never stopped).
_MAX_EMPTY_PAGES: Final = 50


class Listing(Generic[_T]):
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
        item_id: str,
        page_size: int,
        params: Mapping[str, str | int] | None = None,
        *,
        on_total: Callable[[int], None] | None = None,
        expected: int | None = None,
    ) -> None:
        self._name = name  # the listing's name, made only for an error
        self._item_id = item_id  # the attribute that tells the items apart
        self._page_size = page_size
        self._on_total = on_total
        self._bound = expected
        self._bound_is_total = False
        self.query: dict[str, str | int] = {**(params or {}), "pageSize": page_size}
        self.more = True  # until a page without a next page token
        self._pages = self._empty_run = 0
        self._tokens: set[str] = set()
        self._seen: set[object] = set()  # the IDs of the items listed

    def take(self, page: Page[_T]) -> list[_T]:
        """The page's items to hand on; `query` then asks for the next page, if any."""
        items = page.items or []  # the API omits empty lists
        token = page.next_page_token or None
        total = page.total
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

    def _check(self, items: list[_T], token: str | None, total: int | None) -> list[_T]:
        """The items not listed before, once the page is known not to prove the listing
        endless (its repeats must not reach the caller)."""
        fresh = []
        for item in items:
            item_id = getattr(item, self._item_id)
            if item_id not in self._seen:
                self._seen.add(item_id)
                fresh.append(item)
        if token is None:
            return fresh  # the last page: nothing more will be asked for
        if token in self._tokens:
            self._stop("the API repeated a page token")
        self._tokens.add(token)
        if items and not fresh:
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
